"""tmafm.continuation(): branches of periodic orbits continued in one input key, each branch a
task (in this process, in a pool of processes, or on a Dask client), gathered into one
xarray.Dataset along the points (docs/continuation.md)."""

from __future__ import annotations

import math
import warnings

import numpy as np

from .._namelist import shown
from ..errors import ContinuationWarning, InputError, InputTypeError, SolverError
from ..sweeps.dataset import key_units
from ..sweeps.executors import _check_run, _dask_results, _process_pool, _progress, _results, _workers
from ..sweeps.points import _base_config, _base_dict, _config, _noiseless, _split_key
from ..sweeps.runs import _observe_one
from .branch import (FINISHED, Problem, _ns_test, _pd_test, follow, grazing_distance, physical_tangent,
                     start_point, switch_period_doubling)
from .._model import Model
from .shooting import _positive_int, _state, _tolerance, map_period, map_size, periodic_map, state_scale

#: Per-point diagnostics (docs/continuation.md, section 6).
DIAGNOSTICS = {
    "newton_iterations": "Newton iterations of the corrector that gave the point (0: located or "
                         "a start)",
    "step": "the scaled arclength step that reached the point (NaN: located or a start)",
    "test_fold": "the parameter's component of the unit tangent (fold: through 0)",
    "test_period_doubling": "det(M + I) = prod(mu + 1) (period doubling: through 0)",
    "test_neimark_sacker": "max |mu| - 1 over the complex multipliers (NaN if none)",
    "test_grazing": "the smallest V_T (no contact) or the smallest minimum of V_T inside a "
                    "flight, over the amplitude (grazing: through 0)",
    "max_multiplier_before": "at a located point: the largest |mu| of the orbit just before it "
                             "along the branch (NaN elsewhere)",
    "max_multiplier_after": "at a located point: the largest |mu| of the orbit just after it "
                            "(NaN elsewhere; differs from before at a grazing point)",
}

#: Per-orbit observables (model units; lengths in gap units d, times in units of tau).
OBSERVABLES = {
    "amplitude": ("half the peak-to-peak V_T over the orbit", "d"),
    "min_gap": ("the smallest V_T over the orbit (negative: the deepest indentation)", "d"),
    "max_gap": ("the largest V_T over the orbit", "d"),
    "flight_gap_min": ("the smallest local minimum of V_T inside a free flight (NaN if none): "
                       "the distance from grazing", "d"),
    "contacts": ("contacts begun per drive period", "1"),
    "contact_fraction": ("the fraction of the drive period in contact", "1"),
    "switch_rate_min": ("the smallest |dV_T/dtau| at a switch (NaN if none)", "d/tau"),
}


def _number(name: str, value) -> float:
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise InputTypeError(f"{name} = {shown(value)}: must be a finite number")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise InputTypeError(f"{name} = {shown(value)}: must be a finite number") from None
    if not math.isfinite(x):
        raise InputError(f"{name} = {shown(value)}: must be finite")
    return x


def _guesses(y0, m: int) -> list:
    if y0 is None:
        return [None]
    if isinstance(y0, list) and y0 and np.ndim(y0[0]) == 1:
        return [_state(f"y0[{k}]", g, m) for k, g in enumerate(y0)]
    # A text (or anything else numpy cannot read as reals) is _state's InputError, not numpy's
    # ValueError (the hostile-call campaign, issue 27).
    try:
        rank = np.ndim(y0)
    except (TypeError, ValueError):  # a ragged nesting: _state refuses it by name
        rank = 1
    if not isinstance(y0, list) and rank == 2:
        return [_state(f"y0[{k}]", g, m) for k, g in enumerate(_state_rows("y0", y0))]
    return [_state("y0", y0, m)]


def _state_rows(name: str, value) -> np.ndarray:
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name} must be real numbers, got {shown(value)}") from None


def _is_dataset(value) -> bool:
    return type(value).__name__ == "Dataset" and hasattr(value, "attrs")


def _restart_point(point, key: str) -> dict:
    """The start of a restart from one point of a continuation Dataset: its orbit's section
    states, value, period, label and tangent (physical units)."""
    if point.attrs.get("tmafm_kind") != "continuation":
        raise InputTypeError("y0: a Dataset must be a point of tmafm.continuation's Dataset "
                             "(ds.isel(point=k))")
    if "point" in point.dims:
        if point.sizes["point"] != 1:
            raise InputError(f"y0: a restart needs one point of the Dataset, got "
                             f"{point.sizes['point']} (use ds.isel(point=k))")
        point = point.isel(point=0)
    if point.attrs.get("key") != key:
        raise InputError(f"key = {shown(key)}: the point was continued in "
                         f"{point.attrs.get('key')!r}")
    n = int(point["period"])
    return {"states": np.asarray(point["state"].values[:n], dtype=float),
            "value": float(point[key]), "period": n, "label": str(point["label"].values),
            "tangent": (np.asarray(point["tangent_state"].values[:n], dtype=float),
                        float(point["tangent_key"]))}


def _branch_task(args):
    """One branch (and the doubled branches born on it): a list of point records (picklable).
    Everything is rebuilt from the base's dict of groups, so the task runs in any process."""
    (base, key, start, stop, guess, period, options, branch_id) = args
    span = stop - start
    probe = Problem(base, key, 1, options["rtol"], start, abs(span), 1.0)
    m = probe.m
    restart = guess if isinstance(guess, dict) else None
    if restart is not None:
        guess = restart["states"][0]
    if guess is None:
        summary = _observe_one(_config(base, {key: start}), {"max_periods": options["settle"]})
        if "error" in summary:
            raise SolverError(f"continuation: the run that gives the start state failed: "
                              f"{summary['error']}")
        guess = np.asarray(summary["final_state"], dtype=float)[:m]
        if len(guess) < m:
            # The run reports (a, adot) only: with a viscoelastic sample the dashpot coordinate
            # w starts at 0 and settles with the orbit over `settle` more periods of the map.
            guess = np.concatenate([guess, np.zeros(m - len(guess))])
            model = probe.model(start)
            for _ in range(options["settle"]):
                guess = periodic_map(model, guess, 1, options["rtol"]).y
    if restart is not None:
        states = np.asarray(restart["states"], dtype=float)
    else:
        states = [guess]
        for _ in range(period - 1):
            states.append(periodic_map(probe.model(start), states[-1], 1, options["rtol"]).y)
        states = np.array(states)
    sx = state_scale(probe.model(start), states)

    def make_problem(n):
        return Problem(base, key, n, options["rtol"], start, abs(span), sx)

    problem = make_problem(len(states))
    bounds = (min(start, stop), max(start, stop))
    ds = options["ds"]
    common = dict(ds=ds, ds_min=ds * 1e-4, ds_max=options["ds_max"], tol=options["tol"],
                  loc_tol=options["loc_tol"], bounds=bounds,
                  cross_non_smooth=options["cross_non_smooth"])
    direction = options["direction"]
    if restart is None:
        first = start_point(problem, states, start, options["tol"], branch_id,
                            direction * math.copysign(1.0, span))
    else:
        first = start_point(problem, states, start, options["tol"], branch_id, direction,
                            along=restart["tangent"])
    doubled_start = False
    if period == 2 * problem.period:  # a restart at a period doubling with the doubled period
        problem, first = switch_period_doubling(problem, first, options["tol"], ds, make_problem)
        if first is None:
            raise SolverError(f"continuation: no period-{period} orbit found next to the period "
                              f"doubling at {key} = {start:.9g}")
        first.branch = branch_id
        if direction < 0:
            first.tangent = -first.tangent
            first.orientation = -first.orientation
        doubled_start = True
    records = []
    followed = []  # (period, points) of every branch traced, in order
    counter = [branch_id]

    def explore(prob, head, doubled):
        """Trace one branch, then (depth first) the doubled branch born at each of its period
        doublings that no branch traced so far reaches: a period-2n branch that links two
        doublings of its parent is traced once, from the first."""
        branch = counter[0]
        counter[0] += 1000
        head.branch = branch
        points = follow(prob, head, stop, max_points=options["max_points"], branch=branch,
                        doubled=doubled, **common)
        slot = len(records)
        records.append(None)  # this branch's records, once its doublings are switched at
        followed.append((prob.period, points))
        for p in points:
            if not (options["switch"] and prob.period < options["max_period"]):
                break
            if p.label != "period_doubling" or _reached(followed, prob, p, options["ds_max"]):
                continue
            doubled_problem, new = switch_period_doubling(prob, p, options["tol"], ds, make_problem)
            if new is None:
                p.end_detail = "no period-doubled orbit found next to this doubling"
                continue
            explore(doubled_problem, new, True)
        records[slot] = [_record(prob, p) for p in points]

    explore(problem, first, doubled_start)
    return [r for branch in records for r in branch]


def _reached(followed: list, problem, pd, ds_max: float) -> bool:
    """Whether a period-2n branch traced already passes through the doubling pd (its orbit
    doubled, within two of the largest steps in the scaled unknowns)."""
    target = np.concatenate([np.ravel(np.concatenate([pd.states, pd.states])) / problem.sx,
                             [pd.u[-1]]])
    for n, points in followed:
        if n != 2 * problem.period:
            continue
        for p in points:
            if np.linalg.norm(p.u - target) <= 2 * ds_max:
                return True
    return False


def _record(problem: Problem, p) -> dict:
    s = p.stats
    n = problem.period
    model = problem.model(p.value)
    return {"branch": p.branch, "value": p.value, "period": n, "states": p.states,
            "multipliers": p.multipliers, "stable": bool(np.max(np.abs(p.multipliers)) < 1),
            "label": p.label,
            "amplitude": 0.5 * (s["gap_max"] - s["gap_min"]), "min_gap": s["gap_min"],
            "max_gap": s["gap_max"], "flight_gap_min": s["flight_gap_min"],
            "contacts": s["contacts"] / n,
            "contact_fraction": s["contact_time"] / (n * map_period(model)),
            "switch_rate_min": s["switch_rate_min"],
            "newton_iterations": p.iterations, "step": p.step,
            "test_fold": float(p.tangent[-1]), "test_period_doubling": _pd_test(p),
            "test_neimark_sacker": _ns_test(p), "test_grazing": grazing_distance(p),
            "max_multiplier_before": p.mu_before, "max_multiplier_after": p.mu_after,
            "end_reason": p.end_reason, "end_detail": p.end_detail,
            "tangent": physical_tangent(problem, p),
            "tip": np.array([np.dot(model.tip, x[:model.n_modes]) for x in p.states])}


def continuation(base, key, start, stop, *, y0=None, period=None, direction=1, ds=None,
                 ds_max=None, max_points=200, rtol=1e-10, tol=1e-9, loc_tol=1e-9, switch=True,
                 max_period=8, settle=400, cross=True, workers=None, client=None, progress=False,
                 **unknown):
    """Continue periodic orbits of `base` in `key` from `start` towards `stop`.

    y0: the start state(s) at tau = 0, (a, adot) or with a viscoelastic sample (a, adot, w): None
    (a brute-force run of `settle` periods at `start` gives it), one state, or a list of states
    (one branch each, run in parallel on `workers` processes or a Dask `client`).  period: the
    orbit's period in drive periods (default 1).
    Restart: y0 may be one point of a continuation Dataset, ``ds.isel(point=k)`` (any labelled
    point, or any other): the branch starts from its orbit (start None or its value; period its
    period, or twice it at a 'period_doubling' point: the doubled branch born there), and
    direction = 1 follows the branch the way it was traced there, -1 the other way (at a fold:
    the other side).  Without a restart, direction = 1 starts towards stop, -1 away from it.
    ds / ds_max: first and largest arclength step (scaled: the parameter in units of
    |stop - start|, states in units of their size); tol: Newton's tolerance on the scaled
    unknowns; loc_tol: the arclength tolerance of a located special point.  switch: follow the
    period-2n branch born at each period doubling (up to max_period).  cross: where the
    corrector fails at a non-smooth point (grazing, a change of the contact sequence), pose the
    shooting problem again past it and go on.  Every branch's last point has an `end_reason`;
    a ContinuationWarning names the branches that end early (not at stop, nor a doubled branch
    meeting its parent).

    Returns an xarray.Dataset along 'point': the parameter (named `key`), branch, period,
    label ('start', 'end', 'fold', 'period_doubling', 'neimark_sacker', 'grazing' or ''),
    stable, the multipliers (real and imaginary parts, largest modulus first), the section
    states (segment, state), the tip displacement p.a at each section, and the per-orbit
    observables (OBSERVABLES).
    """
    if unknown:
        raise InputTypeError("tmafm.continuation: unknown keyword argument(s) "
                             + ", ".join(f"{k} = {shown(v)}" for k, v in sorted(unknown.items())))
    _check_run(workers, client, progress, None, "batch", "tmafm.continuation")
    import xarray as xr
    _split_key(key)
    restart = _restart_point(y0, key) if _is_dataset(y0) else None
    if restart is not None:
        if start is None:
            start = restart["value"]
        elif _number("start", start) != restart["value"]:
            raise InputError(f"start = {shown(start)}: a restart from a point of a Dataset starts "
                             f"at its {key} = {restart['value']!r} (or start = None)")
        if period is None:
            period = restart["period"]
        elif period not in (restart["period"], 2 * restart["period"]) or \
                (period == 2 * restart["period"] and restart["label"] != "period_doubling"):
            raise InputError(f"period = {shown(period)}: a restart from a period-"
                             f"{restart['period']} point ('{restart['label']}') keeps period "
                             f"{restart['period']}; period {2 * restart['period']} only from a "
                             f"'period_doubling' point")
    start = _number("start", start)
    stop = _number("stop", stop)
    if start == stop:
        raise InputError(f"continuation: start = stop = {start:g}: the interval is empty")
    period = _positive_int("period", 1 if period is None else period, 64)
    if direction not in (1, -1) or isinstance(direction, (bool, np.bool_)):
        raise InputTypeError(f"direction = {shown(direction)}: must be 1 or -1")
    max_points = _positive_int("max_points", max_points, 100000)
    max_period = _positive_int("max_period", max_period, 64)
    settle = _positive_int("settle", settle, 100000)
    rtol = _tolerance("rtol", rtol, 1e-14, 1e-6)
    tol = _tolerance("tol", tol, 1e-13, 1e-4)
    loc_tol = _tolerance("loc_tol", loc_tol, 1e-13, 1e-2)
    ds = 0.02 if ds is None else _tolerance("ds", ds, 1e-8, 1.0)
    ds_max = 0.05 if ds_max is None else _tolerance("ds_max", ds_max, 1e-8, 1.0)
    for name, flag in (("switch", switch), ("cross", cross)):
        if not isinstance(flag, (bool, np.bool_)):
            raise InputTypeError(f"{name} = {shown(flag)}: must be True or False")
    base_config = _base_config(base)
    _noiseless(base_config, "continuation")
    groups = _base_dict(base_config)
    _config(groups, {key: start})
    _config(groups, {key: stop})
    n_modes = base_config.n_modes
    m = map_size(Model(_config(groups, {key: start})))
    if restart is not None:
        if restart["states"].shape[1] != m:
            raise InputError(f"y0: the point's state has {restart['states'].shape[1]} components, "
                             f"this base's map {m}")
        guesses = [restart]
    else:
        guesses = _guesses(y0, m)
    options = dict(rtol=rtol, tol=tol, loc_tol=loc_tol, ds=ds, ds_max=ds_max,
                   max_points=max_points, switch=bool(switch), max_period=max_period,
                   cross_non_smooth=bool(cross), direction=int(direction), settle=settle)
    tasks = [(groups, key, start, stop, g, period, options, k)
             for k, g in enumerate(guesses)]
    n_workers = _workers(workers)
    bar = _progress(len(tasks), progress, "continuation")
    try:
        if client is not None:
            futures = [client.submit(_branch_task, t, pure=False) for t in tasks]
            results = _dask_results(client, futures, None if bar is None else
                                    lambda k: bar.update(1))
        elif n_workers > 1 and len(tasks) > 1:
            with _process_pool(min(n_workers, len(tasks))) as pool:
                futures = [pool.submit(_branch_task, t) for t in tasks]
                results = _results(futures, None if bar is None else lambda k: bar.update(1))
        else:
            results = []
            for t in tasks:
                results.append(_branch_task(t))
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    results = _drop_duplicates(results, start, stop, ds_max)
    records = [r for branch in results for r in branch]
    _warn_early_ends(records, key)
    return _dataset(xr, records, key, n_modes, m, base_config, options, start, stop, groups)


def _drop_duplicates(results: list, start: float, stop: float, ds_max: float) -> list:
    """Several start states on one branch trace it once: a task whose first orbit lies within
    one largest step (ds_max, in the scaled unknowns: states over their size, the key over
    |stop - start|) of an orbit an earlier task traced, of the same period, keeps only that
    start, with end_reason 'duplicate' naming the branch.  (The tasks run in parallel, so the
    later one's work is done; it is not shown twice.)"""
    span = abs(stop - start)
    kept = []
    for records in results:
        first = records[0]
        scale = max(float(np.max(np.abs(first["states"]))), 1e-300)
        hit = None
        for earlier in kept:
            for r in earlier:
                if r["period"] != first["period"]:
                    continue
                gap = np.hypot(np.linalg.norm(r["states"] - first["states"]) / scale,
                               (r["value"] - first["value"]) / span)
                if gap <= ds_max:
                    hit = r["branch"]
                    break
            if hit is not None:
                break
        if hit is not None:
            only = dict(first, end_reason="duplicate",
                        end_detail=f"the start lies on branch {hit}, traced already")
            kept.append([only])
        else:
            kept.append(records)
    return kept


def _warn_early_ends(records: list, key: str) -> None:
    """One ContinuationWarning naming every branch that ends early (end_reason not in
    FINISHED), with where and why."""
    early = [r for r in records if r["end_reason"] and r["end_reason"] not in FINISHED]
    if early:
        text = "; ".join(f"branch {r['branch']} (period {r['period']}) at {key} = "
                         f"{r['value']:.9g}: {r['end_reason']} ({r['end_detail']})" for r in early)
        warnings.warn(f"tmafm.continuation: {len(early)} branch(es) end early: {text}",
                      ContinuationWarning, stacklevel=_caller_level())


def _caller_level() -> int:
    """The stacklevel of the first frame outside the tmafm package (the user's call, whether
    through tmafm.continuation() or the module's function)."""
    import sys
    from pathlib import Path
    package = str(Path(__file__).resolve().parents[1])
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename.startswith(package):
        frame, level = frame.f_back, level + 1
    return level


#: The observables that are lengths (gap units d), converted as the core's min_gap row is.
_LENGTHS = ("amplitude", "min_gap", "max_gap", "flight_gap_min")


def _si_factors(config) -> dict:
    """{name: (factor, unit)} for the length observables when the input gives &physical: the
    core's factor of its min_gap row (tmafm_api observable_table_factors: the gap d in the
    SI-derived unit), else {}."""
    from .._fortran import OBSERVABLE_TABLE, api
    if "physical" not in config.to_dict():
        return {}
    factors = np.zeros(len(OBSERVABLE_TABLE), order="F")
    ierr, errmsg = api.observable_table_factors(config._f, factors)
    if ierr:
        return {}
    row = next(k for k, r in enumerate(OBSERVABLE_TABLE) if r["name"] == "min_gap")
    return {name: (float(factors[row]), OBSERVABLE_TABLE[row]["si_unit"]) for name in _LENGTHS}


def _dataset(xr, records, key, n_modes, m, base_config, options, start, stop, groups):
    n = len(records)
    segments = max(r["period"] for r in records)
    states = np.full((n, segments, m), np.nan)
    tip = np.full((n, segments), np.nan)
    for i, r in enumerate(records):
        states[i, :r["period"]] = r["states"]
        tip[i, :r["period"]] = r["tip"]
    tangent_state = np.full((n, segments, m), np.nan)
    for i, r in enumerate(records):
        tangent_state[i, :r["period"]] = r["tangent"][0]
    mu = np.array([r["multipliers"] for r in records])
    data = {
        "branch": ("point", np.array([r["branch"] for r in records], dtype=np.int32)),
        "period": ("point", np.array([r["period"] for r in records], dtype=np.int32)),
        "label": ("point", np.array([r["label"] for r in records], dtype=object).astype(str)),
        "stable": ("point", np.array([r["stable"] for r in records])),
        "multiplier_re": (("point", "multiplier"), mu.real),
        "multiplier_im": (("point", "multiplier"), mu.imag),
        "multiplier_abs": (("point", "multiplier"), np.abs(mu)),
        "state": (("point", "segment", "state"), states),
        "tip": (("point", "segment"), tip),
        "tangent_state": (("point", "segment", "state"), tangent_state,
                          {"long_name": "the unit tangent's state part in physical units "
                                        "(the direction the branch was followed)"}),
        "tangent_key": ("point", np.array([r["tangent"][1] for r in records]),
                        {"long_name": "the unit tangent's parameter part in physical units"}),
    }
    for name, (meaning, unit) in OBSERVABLES.items():
        data[name] = ("point", np.array([r[name] for r in records], dtype=float),
                      {"long_name": meaning, "units": unit})
    for name, meaning in DIAGNOSTICS.items():
        kind = int if name == "newton_iterations" else float
        data[name] = ("point", np.array([r[name] for r in records], dtype=kind),
                      {"long_name": meaning})
    for name in ("end_reason", "end_detail"):
        data[name] = ("point", np.array([r[name] for r in records], dtype=object).astype(str))
    # The gap d is each point's own: continued along the distance Z (or a length that sets d),
    # the base's d would be off by the change in d (1e-3 over 12 -> 25 nm on tapping_polystyrene).
    per_point = [_si_factors(_config(groups, {key: r["value"]})) for r in records]
    for name, (_, unit) in _si_factors(base_config).items():
        factors = np.array([f[name][0] for f in per_point])
        data[f"{name}_si"] = ("point", data[name][1] * factors,
                              {"long_name": f"{name} in SI-derived units", "units": unit})
    ds = xr.Dataset(data, coords={key: ("point", np.array([r["value"] for r in records])),
                                  "point": np.arange(n)})
    ds[key].attrs["units"] = key_units(key)
    ds.attrs.update({"tmafm_kind": "continuation", "key": key, "start": start, "stop": stop,
                     "base": base_config.label, "n_modes": n_modes,
                     **{f"option_{k}": (int(v) if isinstance(v, bool) else v)
                        for k, v in options.items()}})
    return ds


def orbit_run(base, point, *, periods=None, samples=200):
    """The trajectory of the orbit at `point` (one point of a continuation Dataset,
    ds.isel(point=k), stable or not): a tmafm.run of `base` at the point's key value from its
    first section state (a0, adot0) over `periods` drive periods (default: the orbit's period),
    with base's solver, sampled `samples` times per drive period (so the last sample is at
    the end of the last period).  An unstable orbit is followed as long as its
    multipliers let the run's error grow no larger than wanted (|mu|^periods times the
    solver's tolerance).  Refused for a viscoelastic sample, whose dashpot state a run cannot
    start from."""
    from .._run import Config
    if not _is_dataset(point):
        raise InputTypeError("point: must be one point of tmafm.continuation's Dataset "
                             "(ds.isel(point=k))")
    key = point.attrs.get("key")
    if key is None:
        raise InputTypeError("point: must be one point of tmafm.continuation's Dataset")
    restart = _restart_point(point, key)
    n = restart["period"]
    periods = n if periods is None else _positive_int("periods", periods, 100000)
    samples = _positive_int("samples", samples, 10 ** 6)
    state = restart["states"][0]
    if len(state) % 2:
        raise InputError("orbit_run: the orbit has a viscoelastic sample's dashpot state w, which "
                         "a run cannot start from (&initial gives a0 and adot0 only)")
    group, name = key.split(".")
    config = Config(_base_config(base), **{group: {name: restart["value"]}})
    period = map_period(Model(config))
    half = len(state) // 2
    return Config(config, initial={"a0": list(state[:half]), "adot0": list(state[half:])},
                  solver={"tau_end": periods * period},
                  output={"sample_dtau": period / samples}).run()
