"""The generated f90wrap layer, imported in one place: ``api`` (module tmafm_api) and the classes."""

from . import _objects

#: The in-memory entry points (fortran/src/api/tmafm_api.f90).
api = _objects.tmafm_api
