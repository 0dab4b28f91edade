"""Warm-started curves: approach/retract and frequency sweeps, each point started from the
previous one's final state so that bistable branches show, and the jumps between branches."""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Mapping

import numpy as np

from .._namelist import shown
from ..errors import InputError, TmafmWarning
from ..observe import observable_groups
from .dataset import (_attrs, _coordinate, _failure_attrs, _index_coordinates,
                      _steady_variables, _units, key_units)
from .executors import _check_run, _dask_results, _progress, _results, _Stopped, _thread_pool, _workers
from .points import (_axis_values, _base_config, _base_dict, _check_axes, _check_flag,
                     _check_points, _check_positive, _config, _for_keys, _observe_keywords, _raw, _sizes,
                     _split_key, _validate)
from .runs import _observe_one, _warn_failures, _warn_unsteady


def _warm_chain(base: dict, key: str, values, curve_point: Mapping, n_modes: int,
                keywords: Mapping, start_state=None, stop=None) -> tuple[list[dict], np.ndarray]:
    """Observe `values` of `key` in order, each point starting from the previous final state.
    ``stop`` (a threading.Event, in a worker thread) is checked before each point: once set,
    _Stopped is raised."""
    state = start_state
    summaries = []
    for value in values:
        if stop is not None and stop.is_set():
            raise _Stopped()
        point = dict(curve_point)
        point[key] = value
        if state is not None:
            point["initial.a0"] = state[:n_modes].tolist()
            point["initial.adot0"] = state[n_modes:].tolist()
        summary = _observe_one(_config(base, point), keywords)
        summaries.append(summary)
        if "error" not in summary:  # after a failed point, go on from the last good state
            state = summary["final_state"]
    return summaries, state


def _both_ways(base: dict, key: str, first, n_modes: int, curve_point: Mapping,
               keywords: Mapping, reverse: bool, stop=None) -> list[list[dict]]:
    """[forward summaries, backward summaries (in forward order)] of one curve; ``stop`` as in
    _warm_chain."""
    forward, state = _warm_chain(base, key, first, curve_point, n_modes, keywords, stop=stop)
    if not reverse:
        return [forward]
    backward, _ = _warm_chain(base, key, first[::-1], curve_point, n_modes, keywords, state,
                              stop)
    return [forward, backward[::-1]]


def mark_jumps(values, threshold: float = 0.2, ratio: float = 2.0) -> np.ndarray:
    """Flag jumps along the last axis (the order of travel): True at point i when the step
    d_i = |y[i] - y[i-1]| exceeds `threshold` times the curve's range of y AND `ratio` times
    both neighbouring steps d_(i-1) and d_(i+1).  So a branch that changes steeply but
    smoothly is not a jump, and a switch between branches is (marked on its arrival point)."""
    threshold = _check_positive("mark_jumps threshold", threshold)
    ratio = _check_positive("mark_jumps ratio", ratio)
    try:
        if isinstance(values, (str, bytes)):
            raise TypeError("not numbers")
        y = np.asarray(values, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"mark_jumps values must be real numbers: {shown(str(exc))[1:-1]}") \
            from None
    if y.ndim == 0:
        raise InputError(f"mark_jumps values must be an array of at least one dimension, got "
                         f"{shown(values)}")
    if y.size == 0:
        return np.zeros(y.shape, dtype=bool)
    flat = y.reshape(-1, y.shape[-1])
    flags = np.zeros(flat.shape, dtype=bool)
    for row, out in zip(flat, flags):
        if row.size < 2 or not np.isfinite(row).all():
            continue
        step = np.abs(np.diff(row))
        span = np.ptp(row)
        if span == 0:
            continue
        left = np.concatenate([[0.0], step[:-1]])
        right = np.concatenate([step[1:], [0.0]])
        out[1:] = (step > threshold * span) & (step > ratio * left) & (step > ratio * right)
    return flags.reshape(y.shape)


#: The observables whose jumps mark a change of branch in continuation sweeps.
JUMP_NAMES = ("amplitude", "phase")


def _continuation(base, key: str, values, *, directions: tuple[str, str], reverse: bool,
                  curves, workers, client, progress, jump_threshold, kind, keywords,
                  dim: str | None = None):
    """The Dataset of approach() and frequency_sweep(): every argument checked and every point
    validated before any run, then the curves run (_run_curves) and collected (_curve_dataset).
    ``dim`` names the swept dimension (default: the key itself)."""
    _check_run(workers, client, progress, user=f"tmafm.{kind}")
    reverse = _check_flag("retract" if kind == "approach" else "reverse", reverse)
    keywords = _curve_keywords(keywords)
    jump_threshold = _check_positive("jump_threshold", jump_threshold)
    _split_key(key)
    values = _axis_values(key, values)
    curves = _curve_axes(curves, key, kind)
    _check_points(math.prod(len(v) for v in curves.values()) * len(values) * (2 if reverse else 1),
                  f"{kind} axes {_sizes(dict(curves, **{key: values}))}")
    base_config = _base_config(base)
    base_groups = _for_keys(_base_dict(base_config), [key, *curves])
    curve_points = [dict(zip(curves, combo))
                    for combo in itertools.product(*map(_raw, curves.values()))]
    _validate(base_groups, [dict(c, **{key: v}) for c in curve_points for v in _raw(values)])
    results = _run_curves(base_groups, key, _raw(values), base_config.n_modes, curve_points,
                          keywords, reverse, workers=workers, client=client, progress=progress,
                          label=kind)
    used = directions if reverse else directions[:1]
    # Summaries in the order (direction, curve..., value).
    ordered = [s for d in range(len(used)) for r in results for s in r[d]]
    _warn_unsteady(ordered, kind, keywords)
    _warn_failures(ordered, kind)
    dim = dim or key
    ds = _curve_dataset(ordered, base_config, key, values, curves, used, jump_threshold, dim)
    ds.attrs.update(_attrs(base, kind, keywords))
    ds.attrs.update(_failure_attrs(ordered))
    ds.attrs["swept_key"] = dim
    ds.attrs["input_key"] = key
    ds.attrs["order"] = f"{used[0]} runs {key} in the order given" + (
        f", {used[1]} in reverse" if reverse else "")
    _free_amplitude(ds, base_groups, kind)
    return ds


def _curve_keywords(keywords: Mapping) -> dict:
    """The observe keywords of a continuation, checked; the lock-in group always computed (the
    jumps are found on amplitude and phase)."""
    keywords = _observe_keywords(keywords)
    if keywords.get("observables") is not None and "lockin" not in keywords["observables"]:
        keywords["observables"] = observable_groups(("lockin",) + tuple(keywords["observables"]))
    return keywords


def _curve_axes(curves, key: str, kind: str) -> dict:
    """{curve key: values} of ``curves`` (None or {} for one curve), checked."""
    empty = curves is None or (isinstance(curves, Mapping) and not curves)
    curves = {} if empty else _check_axes(curves)
    if key in curves:
        raise InputError(f"{kind}: {shown(key)} is both the swept key and a curve key")
    return curves


def _run_curves(base_groups: dict, key: str, values: list, n_modes: int, curve_points: list,
                keywords: dict, reverse: bool, *, workers, client, progress, label) -> list:
    """[_both_ways of each curve], in order: one Dask task or one local thread per curve."""
    bar = _progress(len(curve_points), progress, label)
    done = None if bar is None else lambda k: bar.update(1)
    try:
        if client is not None:
            futures = [client.submit(_both_ways, base_groups, key, values, n_modes, c, keywords,
                                     reverse, pure=False) for c in curve_points]
            return _dask_results(client, futures, done)
        # One curve per thread.  A Ctrl-C reaches this (main) thread while it waits; the
        # threads stop before their next point, and KeyboardInterrupt comes out.
        with _thread_pool(_workers(workers)) as (pool, stop):
            futures = [pool.submit(_both_ways, base_groups, key, values, n_modes, c, keywords,
                                   reverse, stop) for c in curve_points]
            return _results(futures, done)
    finally:
        if bar is not None:
            bar.close()


def _curve_dataset(ordered: list, base_config, key: str, values, curves: dict, used: tuple,
                   jump_threshold: float, dim: str):
    """The Dataset of the summaries ``ordered`` (direction, curve..., value): steady values,
    ``final_state`` and ``jump``, without the attributes; the swept dimension is ``dim``."""
    import xarray as xr
    dims = ("direction", *curves, dim)
    shape = (len(used), *(len(v) for v in curves.values()), len(values))
    units, physical_units = _units(base_config)
    data = _steady_variables(ordered, shape, dims, units, physical_units)
    data["final_state"] = xr.Variable(
        (*dims, "state"),
        np.array([s["final_state"] for s in ordered]).reshape(*shape, 2 * base_config.n_modes),
        attrs={"long_name": "state (a, a') at the last period boundary"})
    flags = _jump_flags(data, shape, len(used) == 2, jump_threshold)
    data["jump"] = xr.Variable(dims, flags.astype(np.int8), attrs={
        "long_name": "1 where amplitude or phase jumped on arriving at this point "
                     "(tmafm.sweeps.mark_jumps)", "threshold": float(jump_threshold)})
    coords = {dim: xr.Variable((dim,), np.asarray(values), attrs={
                  "units": key_units(key),
                  "long_name": _LONG_NAMES.get(key, key) + ("" if dim == key else f" ({key})")}),
              "direction": xr.Variable(("direction",), np.array(used, dtype="U8"),
                                       attrs={"long_name": "direction of travel"})}
    for ckey, cvalues in curves.items():
        coords[ckey] = _coordinate(ckey, cvalues)
    coords.update(_index_coordinates(data))
    return xr.Dataset(data, coords=coords)


#: The long names of the swept coordinates of approach() and frequency_sweep().
_LONG_NAMES = {"physical.tip_sample_distance": "tip-sample distance Z",
               "physical.drive_frequency": "drive frequency",
               "scene.delta_hat": "static offset delta_hat", "scene.omega": "drive frequency Omega"}


def _free_amplitude(ds, base_groups: dict, label: str = "approach") -> None:
    """A physical scene given by its free amplitude A0 (&physical free_amplitude): ``setpoint``
    = amplitude/A0 (the setpoint A/A0 of AM-AFM; with two tones tone 1's) and, for one A0, the
    attribute free_amplitude (in the amplitude's unit, nm).  A second tone given by its free
    amplitude (free_amplitude_2) adds ``setpoint_2`` = tone2_amplitude/A0,2 the same way.  A0
    may be a curve key.  Where A0 = 0 there is no setpoint: NaN there, and one
    tmafm.TmafmWarning saying so (not inf)."""
    for key, amplitude, setpoint, ratio in (("free_amplitude", "amplitude", "setpoint", "A/A0"),
                                            ("free_amplitude_2", "tone2_amplitude", "setpoint_2", "A2/A0,2")):
        unit = ds[amplitude].attrs.get("units") if amplitude in ds else None
        if unit != "nm":
            continue
        if f"physical.{key}" in ds.coords:
            a0_nm = ds[f"physical.{key}"] * 1e9
            text = "A0: the curve's free amplitude"
            zero = a0_nm.values == 0
        else:
            a0 = base_groups.get("physical", {}).get(key)
            if a0 is None:
                continue
            a0_nm = float(a0) * 1e9
            ds.attrs[key] = a0_nm
            text = f"A0: the free amplitude {a0_nm:.6g} nm"
            zero = np.array([a0_nm == 0])
        if zero.any():
            warnings.warn(f"{label}: &physical {key} = 0 in {int(zero.sum())} of {zero.size} "
                          f"curves: the setpoint A/A0 is NaN there (no free amplitude to divide by)",
                          TmafmWarning, stacklevel=4)
            a0_nm = a0_nm.where(a0_nm != 0) if not isinstance(a0_nm, float) else np.nan
        ds[setpoint] = ds[amplitude] / a0_nm
        ds[setpoint].attrs = {"units": "1", "long_name": f"setpoint {ratio} ({text})"}


def _jump_flags(data: dict, shape: tuple, reverse: bool, jump_threshold: float) -> np.ndarray:
    """Where amplitude or phase jumped, marked along the direction of travel: the first point
    of the new branch.  With both directions, a step that both take between the same two
    points, with the same values there (within a tenth of the step: no hysteresis), is a steep
    but single-valued change on a coarse grid, a smooth crossover, and is not marked."""
    flags = np.zeros(shape, dtype=bool)
    for name in JUMP_NAMES:
        observed = data[name].values
        travel = [observed[0]] + ([observed[1][..., ::-1]] if reverse else [])
        found = np.zeros(shape, dtype=bool)
        unwrapped = []
        for d, y in enumerate(travel):
            if name == "phase":  # degrees: a wrap at +-180 is no jump
                y = np.unwrap(y, period=360.0, axis=-1)
            unwrapped.append(y)
            marks = mark_jumps(y, jump_threshold)
            found[d] = marks if d == 0 else marks[..., ::-1]
        if reverse:
            found &= ~_crossovers(unwrapped[0], unwrapped[1][..., ::-1], name == "phase")
        flags |= found
    return flags


def _crossovers(forward, back, degrees: bool) -> np.ndarray:
    """[approach, retract] masks of the points where a mark would sit on a step that both
    directions take between the same two points with the same values there (within a tenth of
    the step): the approach's arrival point i, the retract's i-1 (it travels the other way)."""
    if degrees:   # the same branch of the unwrap for both
        back = back + 360.0 * np.round((forward[..., :1] - back[..., :1]) / 360.0)
    step = np.abs(np.diff(forward, axis=-1))
    apart = np.abs(forward - back)
    cross = (apart[..., :-1] <= 0.1 * step) & (apart[..., 1:] <= 0.1 * step)
    masks = np.zeros((2, *forward.shape), dtype=bool)
    masks[0][..., 1:] = cross
    masks[1][..., :-1] = cross
    return masks


def _one_axis(kind: str, dimensionless: tuple, physical: tuple) -> tuple:
    """(input key, values, dimension name) of the one axis given: (name, values, key, dim) of
    the dimensionless and the physical choice; InputError unless exactly one is given."""
    given = [axis for axis in (dimensionless, physical) if axis[1] is not None]
    if len(given) != 1:
        raise InputError(f"{kind}: give either {dimensionless[0]}= (dimensionless, "
                         f"{dimensionless[2]}) or {physical[0]}= (SI, {physical[2]}), "
                         f"{'not both' if given else 'none was given'}")
    _, values, key, dim = given[0]
    return key, values, dim


def approach(base, delta_hat=None, *, z=None, retract=True, curves=None, workers=None,
             client=None, progress=False, jump_threshold=0.2, **observe_keywords):
    """Approach/retract: sweep the tip-sample rest distance through the values given (give them
    decreasing: the tip approaches the sample), then back, each point warm-started from the
    previous one's final state, so bistable branches show.

    ``z`` (m) sweeps &physical tip_sample_distance Z of a physical base (the dimension ``z``,
    units 'm'; the observables in nm, nN, degree, aJ, ...; ``setpoint`` = A/A0 when the base
    gives free_amplitude); ``delta_hat`` sweeps &scene delta_hat of a dimensionless base (the
    dimension 'scene.delta_hat').  ``curves`` ({'group.key': values}) adds curves, run in
    parallel.  The Dataset has dims ('direction', *curve keys, swept) with direction
    'approach'/'retract', the steady values, ``jump`` and ``final_state``."""
    key, values, dim = _one_axis("approach", ("delta_hat", delta_hat, "scene.delta_hat",
                                              "scene.delta_hat"),
                                 ("z", z, "physical.tip_sample_distance", "z"))
    return _continuation(base, key, values, directions=("approach", "retract"),
                         reverse=retract, curves=curves, workers=workers, client=client,
                         progress=progress, jump_threshold=jump_threshold, kind="approach",
                         keywords=observe_keywords, dim=dim)


def frequency_sweep(base, omega=None, *, frequency=None, reverse=True, curves=None,
                    workers=None, client=None, progress=False, jump_threshold=0.2,
                    **observe_keywords):
    """Frequency sweep: the drive frequency through the values given (give them increasing),
    then back, warm started as in approach(); direction 'up'/'down'.  ``frequency`` (Hz)
    sweeps &physical drive_frequency of a physical base (the dimension ``frequency``, units
    'Hz'); ``omega`` sweeps &scene omega of a dimensionless base (dimension 'scene.omega')."""
    key, values, dim = _one_axis("frequency_sweep", ("omega", omega, "scene.omega",
                                                     "scene.omega"),
                                 ("frequency", frequency, "physical.drive_frequency",
                                  "frequency"))
    return _continuation(base, key, values, directions=("up", "down"), reverse=reverse,
                         curves=curves, workers=workers, client=client, progress=progress,
                         jump_threshold=jump_threshold, kind="frequency_sweep",
                         keywords=observe_keywords, dim=dim)
