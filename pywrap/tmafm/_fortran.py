"""The generated f90wrap layer, imported in one place: ``api`` (module tmafm_api) and the classes."""

import threading

from . import _objects

#: The in-memory entry points (fortran/src/api/tmafm_api.f90).
api = _objects.tmafm_api

#: A new, empty config_t handle (filled by api.config_from_text(s)).
config_t = _objects.tmafm_config.config_t


def polls() -> bool:
    """Whether a call into the core should poll for Ctrl-C (the entry points' ``poll``): only on
    Python's main thread, where signal handlers run.  Elsewhere a poll could never stop the run
    and would only wait for the GIL (docs/model-notes.md, item 12)."""
    return threading.current_thread() is threading.main_thread()
