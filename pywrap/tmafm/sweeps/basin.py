"""tmafm.basin: a map of initial states a1(0) x a1'(0), each labelled by the attractor it
reaches; the runs of a pass stop at the attractors found before (docs/sweeps.md, "Stopping at
a known attractor")."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._namelist import _NOT_NUMBERS, shown
from .._run import Config
from ..errors import InputError, InputTypeError
from .attractors import _new_attractors, label_attractors
from .dataset import _attrs, _steady_columns, _units
from .executors import _check_run, _dask_results, _process_pool, _progress, _results, _workers
from .points import (_axis_values, _base_config, _base_dict, _check_flag, _check_points,
                     _check_positive, _observe_keywords, _short)
from .runs import _basin_chunk, _basin_chunk_processes, _drive_period, _warn_failed


def basin(base, a1, adot1, *, tol=1e-3, workers=None, client=None, progress=False, chunk=None,
          backend="batch", observables=(), known_attractors=True, coarse=None, confirm=None,
          capture=None, **observe_keywords):
    """A basin map: a grid of initial states a1(0) x a1'(0) (other modes from the base's
    &initial), each labelled by the attractor it reaches.  Variables (dims ('a1', 'adot1')):
    ``attractor`` (0, 1, ...: points whose final Poincaré orbits agree within `tol` times the
    largest |state| up to a cyclic shift share a label; -1: no period found),
    ``attractor_period``, ``period`` (the steady-state test's), ``periods``, ``stopped_known``
    (1 where the run stopped at a known attractor) and the steady values of ``observables``
    (none by default; e.g. ``["lockin"]`` adds amplitude and phase);
    ``attractor_orbit_<k>`` holds each attractor's Poincaré orbit.

    With ``known_attractors`` (the default) a first pass runs every `coarse`-th point of both
    axes (about 256 points); the other points then run in chunks, each run stopped as soon
    as its Poincaré points repeat an attractor already found (docs/sweeps.md, "Stopping at a
    known attractor").  The input is read and its model built once per chunk, and each run
    starts from its state in memory (tmafm.observe.observe_states)."""
    _check_run(workers, client, progress, chunk, backend, "tmafm.basin")
    import xarray as xr
    keywords = _observe_keywords(dict(observe_keywords, observables=observables))
    a1 = _axis_values("a1", a1, real=True)
    adot1 = _axis_values("adot1", adot1, real=True)
    tol = _check_positive("tol", tol, 1.0)
    known_attractors = _check_flag("known_attractors", known_attractors)
    _coarse_stride((len(a1), len(adot1)), coarse)
    p_max = keywords.get("p_max", 8)
    _check_confirm(confirm)
    if capture is not None:
        capture = _check_positive("capture", capture, 1.0)
    where = f"basin axes a1 ({len(a1)} values) x adot1 ({len(adot1)} values)"
    _check_points(len(a1) * len(adot1), where, 2 * (2 * p_max + 2))  # N = 1 until the base is read
    base_config = _base_config(base)
    base_groups = _base_dict(base_config)
    n = base_config.n_modes
    _check_points(len(a1) * len(adot1), where, 2 * n * (2 * p_max + 2))
    shape = (len(a1), len(adot1))
    states = _basin_states(base_groups, n, a1, adot1)
    stride = _coarse_stride(shape, coarse)
    # One resolved text for every run: the base with its N fixed (an automatic N is chosen once).
    run_groups = dict(base_groups, model=dict(base_groups.get("model", {}), n_modes=n))
    if capture is None:
        capture = tol  # the labels' own resolution (docs/sweeps.md)
    runs = _BasinRuns(states=states, run_groups=run_groups, run_config=Config(run_groups),
                      keywords=dict(keywords, confirm=confirm, capture=capture), tol=tol,
                      learn=known_attractors, client=client, backend=backend,
                      workers=_workers(workers), size=int(chunk) if chunk is not None else 2048)
    first, rest = _passes(shape, stride, known_attractors and keywords.get("stop_at_steady", True))
    _run_basin(runs, first, rest, progress)
    merged, failures = _merged(runs.results, states.shape[0])
    data, coords, attractors = _basin_variables(merged, shape, a1, adot1, tol, base_config)
    attrs = _attrs(base, "basin", keywords)
    failures.sort()
    attrs.update({"failures": int(merged["failed"].sum()),
                  "first_failure": failures[0][1] if failures else ""})
    _warn_failed(attrs["failures"], states.shape[0], attrs["first_failure"], "basin")
    attrs["attractors"] = attractors
    attrs["known_attractors"] = int(bool(known_attractors))
    attrs["coarse_stride"] = stride
    attrs["capture"] = float(capture)
    attrs["confirm"] = int(confirm if confirm is not None else keywords.get("steady_repeats", 3))
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _check_confirm(confirm) -> None:
    if confirm is not None and (isinstance(confirm, _NOT_NUMBERS) or not isinstance(
            confirm, (int, np.integer)) or not 1 <= confirm <= 10_000_000):
        raise InputTypeError(f"confirm = {shown(confirm)}: must be an integer from 1 to "
                             f"10000000, or None")


def _coarse_stride(shape: tuple, coarse) -> int:
    """The stride of the first pass of a basin map: about 256 points, at least every 2nd point
    of both axes when both have 4 points or more (otherwise every point)."""
    if coarse is None:
        if min(shape) < 4:
            return 1
        return max(2, int(round(math.sqrt(shape[0] * shape[1] / 256))))
    if isinstance(coarse, _NOT_NUMBERS) or not isinstance(coarse, (int, np.integer)) or coarse < 1:
        raise InputTypeError(f"coarse = {shown(coarse)}: must be a positive integer or None")
    return int(coarse)




def _basin_states(base_groups: dict, n: int, a1, adot1) -> np.ndarray:
    """The initial states (points, 2N) of the map, in C order: a1 and a1' from the axes, the
    other values from the base's &initial; InputError naming the first point out of range."""
    initial = base_groups.get("initial", {})
    a0 = np.zeros(n)
    adot0 = np.zeros(n)
    a0[:] = np.resize(np.asarray(initial.get("a0", [0.0]), dtype=float), n) if "a0" in initial \
        else 0.0
    adot0[:] = np.resize(np.asarray(initial.get("adot0", [0.0]), dtype=float), n) \
        if "adot0" in initial else 0.0
    shape = (len(a1), len(adot1))
    states = np.empty((shape[0], shape[1], 2 * n))
    states[:] = np.concatenate([a0, adot0])
    states[..., 0] = np.asarray(a1, dtype=float)[:, None]
    states[..., n] = np.asarray(adot1, dtype=float)[None, :]
    states = states.reshape(-1, 2 * n)
    bad = np.flatnonzero(~np.all(np.isfinite(states) & (np.abs(states) <= 1.0), axis=1))
    if bad.size:
        i, j = np.unravel_index(int(bad[0]), shape)
        raise InputError(f"basin point a1 = {_short(a1[i])}, adot1 = {_short(adot1[j])}: "
                         f"&initial values must be finite with |value| <= 1 (gap units)")
    return states


def _passes(shape: tuple, stride: int, two: bool) -> tuple[np.ndarray, np.ndarray]:
    """(first, rest): the points of the two passes (``two``: every `stride`-th point of both
    axes first), or every point in one pass."""
    order = np.arange(shape[0] * shape[1]).reshape(shape)
    if two:
        first = order[::stride, ::stride].ravel()
        return first, np.setdiff1d(order.ravel(), first)
    return order.ravel(), np.zeros(0, dtype=int)


@dataclass
class _BasinRuns:
    """What every chunk of a basin map shares, and the chunks' results as they come
    ({(first point,): (points, the chunk's arrays)})."""

    states: np.ndarray
    run_groups: dict
    run_config: Config
    keywords: dict
    tol: float
    learn: bool  # known_attractors: runs stop at the attractors found before
    client: object
    backend: str
    workers: int
    size: int
    bar: object = None
    results: dict = field(default_factory=dict)

    @property
    def incremental(self) -> bool:
        """Local batches run chunk after chunk, each stopping at what the ones before found;
        processes and Dask run a pass's chunks at once, with what the first pass found."""
        return self.client is None and self.backend == "batch"


def _run_basin(runs: _BasinRuns, first: np.ndarray, rest: np.ndarray, progress: bool) -> None:
    """Run the first pass, then the rest with the attractors found so far."""
    runs.bar = _progress(runs.states.shape[0], progress, "basin")
    try:
        known = _run_pass(runs, first, [])
        if runs.learn and rest.size:
            if not runs.incremental:  # the chunks ran at once: collect what the first pass found
                for _, out in list(runs.results.values()):
                    known = known + _new_attractors(out, known, runs.tol, runs.run_config,
                                                    runs.keywords)
            _run_pass(runs, rest, known)
    finally:
        if runs.bar is not None:
            runs.bar.close()


def _run_pass(runs: _BasinRuns, indices: np.ndarray, attractors: list) -> list:
    """Run the points `indices` in chunks, stopping at `attractors`; the attractors known
    after the pass (more than given only for incremental runs)."""
    pieces = [indices[i:i + runs.size] for i in range(0, len(indices), runs.size)]
    if runs.client is not None:
        futures = [runs.client.submit(_basin_chunk, runs.run_groups, runs.states[p], 1,
                                      runs.keywords, attractors, pure=False) for p in pieces]
        outs = _dask_results(runs.client, futures)
    elif runs.backend == "processes":
        with _process_pool(runs.workers) as pool:
            outs = _results([pool.submit(_basin_chunk_processes,
                                         (runs.run_groups, runs.states[p], 1, runs.keywords,
                                          attractors))
                             for p in pieces])
    elif runs.backend == "batch":
        outs = []
        for p in pieces:
            outs.append(_basin_chunk(runs.run_config, runs.states[p], runs.workers,
                                     runs.keywords, attractors))
            if runs.learn:  # later chunks may stop at what this one found
                attractors = attractors + _new_attractors(outs[-1], attractors, runs.tol,
                                                          runs.run_config, runs.keywords)
            if runs.bar is not None:
                runs.bar.update(len(p))
    else:
        raise InputTypeError(f"backend = {shown(runs.backend)}: must be 'batch' or 'processes'")
    if runs.bar is not None and not runs.incremental:
        runs.bar.update(len(indices))
    for p, out in zip(pieces, outs):
        runs.results[tuple(p[:1])] = (p, out)
    return attractors


def _merged(results: dict, total: int) -> tuple[dict, list]:
    """({name: (total, ...) array} of the chunks' arrays, 'steady:<name>' and
    'physical:<name>' for their groups; [(first point, first failure) of each chunk])."""
    merged: dict = {}
    failures = []
    for p, out in sorted(results.values(), key=lambda item: item[0][0]):
        for name in ("orbit", "periods", "period", "attractor", "failed", "jitter"):
            merged.setdefault(name, np.empty((total, *out[name].shape[1:]),
                                             dtype=out[name].dtype))[p] = out[name]
        for group in ("steady", "physical"):
            for name, values in (out[group] or {}).items():
                merged.setdefault(f"{group}:{name}", np.empty((total, *values.shape[1:])))[p] = \
                    values
        if out["first_failure"]:
            failures.append((p[0], out["first_failure"]))
    return merged, failures


def _labels(merged: dict, tol: float) -> tuple[np.ndarray, list, float]:
    """(labels, representative orbits, resolution) of the merged runs (label_attractors)."""
    period = merged["period"]
    total = period.shape[0]
    p_max = merged["orbit"].shape[1]
    orbits = [merged["orbit"][k, p_max - max(int(period[k]), 1):] for k in range(total)]
    finite = [np.all(np.isfinite(o)) for o in orbits]
    scale = max((float(np.max(np.abs(o))) for o, ok in zip(orbits, finite) if ok), default=0.0) \
        or 1.0
    # A fixed-step method's orbits are known only to its jitter level (rk4_paper): attractors
    # closer than that are not told apart (docs/observables.md, "Steady state").
    jitter = merged["jitter"][np.isfinite(merged["jitter"]) & (period > 0)]
    resolution = max(tol * scale, float(jitter.max()) if jitter.size else 0.0)
    labels, reps = label_attractors(orbits, [int(q) if ok else 0 for q, ok in zip(period, finite)],
                                    resolution)
    return labels, reps, resolution


def _basin_variables(merged: dict, shape: tuple, a1, adot1, tol: float,
                     base_config) -> tuple[dict, dict, int]:
    """(variables, coordinates, number of attractors) of the map's Dataset."""
    import xarray as xr
    labels, reps, resolution = _labels(merged, tol)
    period = merged["period"]
    units, physical_units = _units(base_config)
    columns = {name.split(":", 1)[1]: v for name, v in merged.items() if name.startswith("steady:")}
    physical = {name.split(":", 1)[1]: v for name, v in merged.items()
                if name.startswith("physical:")}
    drive_period = None
    if physical:
        drive_period = np.full(period.shape, _drive_period(base_config))
    data = _steady_columns(columns, physical, period, period > 0, merged["failed"],
                           merged["periods"], shape, ("a1", "adot1"), units, physical_units,
                           drive_period)
    data["attractor"] = xr.Variable(("a1", "adot1"), labels.reshape(shape), attrs={
        "long_name": "attractor label (-1: no period found)", "tolerance": resolution})
    data["attractor_period"] = xr.Variable(("a1", "adot1"), np.array(
        [len(reps[k]) if k >= 0 else 0 for k in labels], dtype=np.int32).reshape(shape),
        attrs={"long_name": "period of the attractor reached (0: none found)"})
    data["stopped_known"] = xr.Variable(("a1", "adot1"), (merged["attractor"] >= 0).astype(
        np.int8).reshape(shape), attrs={"long_name": "1 where the run stopped at an attractor "
                                                     "found before (docs/sweeps.md)"})
    for k, orbit in enumerate(reps):
        data[f"attractor_orbit_{k}"] = xr.Variable(
            (f"orbit_{k}_point", "state"), orbit,
            attrs={"units": "1", "long_name": f"Poincare orbit of attractor {k}: rows (a, a') "
                                              f"in model units (d, d/tau)"})
    coords = {"a1": xr.Variable(("a1",), a1, attrs={"units": "1",
                                                    "long_name": "a1(0) (in gap units d)"}),
              "adot1": xr.Variable(("adot1",), adot1,
                                   attrs={"units": "1", "long_name": "a1'(0) (in d/tau)"})}
    return data, coords, len(reps)
