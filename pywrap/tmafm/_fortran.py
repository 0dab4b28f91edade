"""The generated f90wrap layer, imported in one place: ``api`` (module tmafm_api) and the classes,
and the core's limits (``LIMITS``)."""

import threading

from . import _objects

#: The in-memory entry points (fortran/src/api/tmafm_api.f90).
api = _objects.tmafm_api

#: A new, empty config_t handle (filled by api.config_from_text(s)).
config_t = _objects.tmafm_config.config_t

#: A new, empty batch_t handle (filled by api.batch_add, run by api.batch_run).
batch_t = _objects.tmafm_api.batch_t


def text(value) -> str:
    """A blank-padded character result of the core as a str."""
    if isinstance(value, (bytes, bytearray)):
        value = value.decode("ascii")
    return str(value).rstrip()


def _limits() -> dict:
    limits = {}
    for k in range(1, int(api.limit_count()) + 1):
        name, value = api.limit_entry(k)
        limits[text(name)] = int(value) if float(value).is_integer() else float(value)
    return limits


#: The core's limits that Python checks against before it calls the core (tmafm_api
#: limit_entry): max_modes, max_samples, max_trajectory_bytes, max_max_steps, max_mode_horizon,
#: max_harmonics, max_p_max, max_observed_periods.
LIMITS = _limits()


def polls() -> bool:
    """Whether a call into the core should poll for Ctrl-C (the entry points' ``poll``): only on
    Python's main thread, where signal handlers run.  Elsewhere a poll could never stop the run
    and would only wait for the GIL (docs/model-notes.md, item 12)."""
    return threading.current_thread() is threading.main_thread()
