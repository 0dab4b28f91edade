"""tmafm.sweep: a grid of runs over any input keys."""

from __future__ import annotations

import itertools
import math

from .dataset import _grid_dataset
from .executors import _check_run, _run_points
from .points import (_base_config, _base_dict, _check_axes, _check_points, _for_keys,
                     _observe_keywords, _raw, _sizes, _validate)


def sweep(base, axes, *, workers=None, client=None, progress=False, chunk=None,
          backend="batch", **observe_keywords):
    """A grid of runs over any input keys; an xarray.Dataset of steady values.

    ``axes`` maps 'group.key' to 1-D values; the grid is their outer product (C order, the
    first key slowest).  The Dataset has one dimension per key, named as the key, and one
    variable per steady observable (tmafm.observe.OBSERVABLES, with units as attributes; plus
    ``<name>_<unit>`` in physical units when the base has &physical), ``period`` (0 where
    none was found), ``steady`` and ``periods``.  Every point is validated before any run.
    ``workers`` threads of the core's batch (default: all cores), or ``backend='processes'``
    for a process pool; ``client`` a dask.distributed Client (one task per chunk).
    """
    _check_run(workers, client, progress, chunk, backend, "tmafm.sweep")
    axes = _check_axes(axes)
    keywords = _observe_keywords(observe_keywords)
    _check_points(math.prod(len(v) for v in axes.values()), f"sweep axes {_sizes(axes)}")
    base_config = _base_config(base)
    keys = list(axes)
    base_groups = _for_keys(_base_dict(base_config), keys)
    points = [dict(zip(keys, combo)) for combo in itertools.product(*map(_raw, axes.values()))]
    configs = _validate(base_groups, points)
    summaries = _run_points(base_groups, points, configs=configs, workers=workers, client=client,
                            progress=progress, chunk=chunk, backend=backend, keywords=keywords)
    return _grid_dataset(base, base_config, axes, summaries, keywords, "sweep")
