"""Sweeps at scale: grids of runs, approach/retract and frequency sweeps, bifurcation diagrams and
basin maps, each returned as an xarray.Dataset (needs the [sweep] extra: xarray, dask, tqdm).

Every grid point is one input: the base input with the swept keys ('group.key', e.g.
'scene.delta_hat') replaced.  All points are validated (a tmafm.Config each) before any run
starts, so a bad key or value raises one InputError and nothing runs.  Each point is then
observed period by period by the core (tmafm.observe_batch), stopped at steady state or after
max_periods periods.  Work is spread over local cores (workers=, the core's OpenMP batch) or
over a dask.distributed Client (client=, one task per chunk of points).

    >>> import tmafm
    >>> ds = tmafm.sweep("fig2_n4", {"scene.delta_hat": [0.2, 0.4]}, max_periods=20)
    >>> ds.amplitude.dims
    ('scene.delta_hat',)

The file-driven command line is ``python -m tmafm.sweeps FILE [-o OUT.nc]`` (docs/sweeps.md).

One module per concept: points (keys, values, validation, memory), runs (the calls into the
core's observers), executors (threads, processes, Dask, progress, Ctrl-C), dataset (xarray,
units, NetCDF), grid (sweep), curves (approach, frequency_sweep), bifurcation, attractors
(labels), basin, files (the &sweep file), cli (the command line), plots (matplotlib).
"""

from .attractors import label_attractors, minimal_orbit, minimal_period, same_orbit  # noqa: F401
from .basin import basin
from .bifurcation import bifurcation
from .cli import main
from .curves import approach, frequency_sweep, mark_jumps
from .dataset import read_dataset, summarize, write_dataset  # noqa: F401
from .files import read_sweep_file, run_sweep_file
from .grid import sweep
from .points import BYTES_PER_POINT, MAX_MODES, OBSERVE_KEYWORDS  # noqa: F401

__all__ = ["sweep", "approach", "frequency_sweep", "bifurcation", "basin", "read_sweep_file",
           "run_sweep_file", "write_dataset", "summarize", "mark_jumps", "label_attractors",
           "main"]
