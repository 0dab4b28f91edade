"""tmafm.continuation: periodic orbits by shooting, their Floquet multipliers, and their
pseudo-arclength continuation in any scalar input key, with folds, period doublings (and the
switch to the doubled branch), Neimark-Sacker pairs and grazing located (docs/continuation.md).

    >>> import tmafm                                                          # doctest: +SKIP
    >>> ds = tmafm.continuation("inputs/sweeps/bistable_n2.nml", "scene.delta_hat", 0.003, -0.003)

Modules: ``shooting`` (the core's map and monodromy matrix, Newton, multipliers), ``branch``
(the arclength steps, test functions, location, branch switching, non-smooth points),
``dataset`` (the xarray.Dataset of a branch), ``fold_curve`` (a fold continued in two keys),
``plots`` (a branch over a brute-force sweep).
"""

from __future__ import annotations

from .branch import LABELS
from .dataset import continuation, orbit_run
from .fold_curve import fold_curve, period_doubling_curve
from .shooting import (STAT_NAMES, MapResult, Orbit, floquet_multipliers, jacobian, map_period,
                       map_size, periodic_map, periodic_orbit)

__all__ = ["continuation", "fold_curve", "period_doubling_curve", "orbit_run", "periodic_map", "periodic_orbit",
           "floquet_multipliers", "jacobian", "map_size", "map_period", "MapResult", "Orbit", "STAT_NAMES", "LABELS"]


class _CallableModule(__import__("types").ModuleType):
    """tmafm.continuation is both this package and the function continuation(): calling the
    module calls the function (the package's submodules stay reachable as attributes)."""

    def __call__(self, *args, **keywords):
        return continuation(*args, **keywords)


__import__("sys").modules[__name__].__class__ = _CallableModule
