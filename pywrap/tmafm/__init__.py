"""tmafm: contact dynamics of tapping-mode AFM, a Modern Fortran core with a thin Python layer.

>>> import tmafm
>>> result = tmafm.run("inputs/fig2_n4.nml", solver={"tau_end": 10})
>>> result.vt.min() <= 0
True
"""

from importlib.metadata import PackageNotFoundError, version as _version

from ._run import SCENE_KEYS, Result, resolve, run
from .errors import BlowUpError, InputError, InputFileError, SolverError, TmafmError
from ._exe import executable

try:
    __version__ = _version("tmafm")
except PackageNotFoundError:  # running from a source tree
    __version__ = "unknown"

__all__ = ["run", "resolve", "Result", "SCENE_KEYS", "executable", "TmafmError", "InputError",
           "InputFileError", "SolverError", "BlowUpError", "__version__"]
