"""tmafm: contact dynamics of tapping-mode AFM, a Modern Fortran core with a thin Python layer.

>>> import tmafm
>>> result = tmafm.run("fig2_n4", solver={"tau_end": 10})
>>> bool(result.vt.min() <= 0)
True
"""

from . import _startup  # noqa: F401  (first: Ctrl-C while python -m tmafm.sweeps starts)
from importlib.metadata import PackageNotFoundError, version as _version

from . import inputs
from ._run import COUNTER_KEYS, DERIVED_UNITS, SCENE_KEYS, SERIES_UNITS, Config, Result, resolve, run
from ._model import POWER_NAMES, ContactState, Model
from ._resultio import load
from .errors import (BlowUpError, FailedRunWarning, InputError, InputFileError, InputTypeError,
                     SolverError, TmafmError, TmafmWarning, UnsteadyWarning, ContinuationWarning)
from ._exe import executable
from .observe import Observation, observe, observe_batch

_SWEEPS = ("sweep", "approach", "frequency_sweep", "bifurcation", "basin")


def __getattr__(name):
    """tmafm.sweep & co. come from tmafm.sweeps, imported on first use (so that
    ``python -m tmafm.sweeps`` runs a module the package has not imported yet)."""
    if name in _SWEEPS:
        from . import sweeps
        return getattr(sweeps, name)
    if name in ("continuation", "instrument"):  # tmafm.continuation is callable too
        import importlib
        return importlib.import_module("." + name, __name__)
    if name == "fm_approach":  # the FM-AFM approach curve (docs/instrument.md, "FM-AFM")
        from .instrument import fm_approach
        return fm_approach
    raise AttributeError(f"module 'tmafm' has no attribute {name!r}")

try:
    __version__ = _version("tmafm")
except PackageNotFoundError:  # running from a source tree
    __version__ = "unknown"

__all__ = ["run", "resolve", "load", "Config", "Model", "Result", "ContactState", "inputs",
           "SCENE_KEYS", "COUNTER_KEYS", "DERIVED_UNITS", "SERIES_UNITS", "observe", "observe_batch", "Observation",
           "POWER_NAMES", "executable",
           "TmafmError", "InputError",
           "InputTypeError", "InputFileError", "SolverError", "BlowUpError", "TmafmWarning",
           "UnsteadyWarning", "FailedRunWarning", "ContinuationWarning", "__version__",
           "sweep", "approach", "frequency_sweep", "bifurcation", "basin", "continuation", "instrument"]
