"""The generated f90wrap layer, imported in one place: ``api`` (module tmafm_api) and the classes."""

from . import _objects

#: The in-memory entry points (fortran/src/api/tmafm_api.f90).
api = _objects.tmafm_api

#: A new, empty config_t handle (filled by api.config_from_text(s)).
config_t = _objects.tmafm_config.config_t
