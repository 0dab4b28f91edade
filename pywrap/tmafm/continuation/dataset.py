"""tmafm.continuation(): branches of periodic orbits continued in one input key, each branch a
task (in this process, in a pool of processes, or on a Dask client), gathered into one
xarray.Dataset along the points (docs/continuation.md)."""

from __future__ import annotations

import math

import numpy as np

from .._namelist import shown
from ..errors import InputError, InputTypeError, SolverError
from ..sweeps.executors import _check_run, _dask_results, _process_pool, _progress, _results, _workers
from ..sweeps.points import _base_config, _base_dict, _config, _split_key
from ..sweeps.runs import _observe_one
from .branch import Problem, follow, start_point, switch_period_doubling
from .._model import Model
from .shooting import _positive_int, _state, _tolerance, map_period, map_size, periodic_map, state_scale

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
    except (TypeError, ValueError):
        raise InputTypeError(f"{name} = {shown(value)}: must be a finite number") from None
    if not math.isfinite(x):
        raise InputError(f"{name} = {shown(value)}: must be finite")
    return x


def _guesses(y0, m: int) -> list:
    if y0 is None:
        return [None]
    array = np.asarray(y0, dtype=object if isinstance(y0, list) else float)
    if isinstance(y0, list) and y0 and np.ndim(y0[0]) == 1:
        return [_state(f"y0[{k}]", g, m) for k, g in enumerate(y0)]
    if np.ndim(array) == 2:
        return [_state(f"y0[{k}]", g, m) for k, g in enumerate(np.asarray(y0, dtype=float))]
    return [_state("y0", y0, m)]


def _branch_task(args):
    """One branch (and the doubled branches born on it): a list of point records (picklable).
    Everything is rebuilt from the base's dict of groups, so the task runs in any process."""
    (base, key, start, stop, guess, period, options, branch_id) = args
    span = stop - start
    probe = Problem(base, key, 1, options["rtol"], start, abs(span), 1.0)
    m = probe.m
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
    states = [guess]
    for _ in range(period - 1):
        states.append(periodic_map(probe.model(start), states[-1], 1, options["rtol"]).y)
    states = np.array(states)
    sx = state_scale(probe.model(start), states)

    def make_problem(n):
        return Problem(base, key, n, options["rtol"], start, abs(span), sx)

    problem = make_problem(period)
    bounds = (min(start, stop), max(start, stop))
    ds = options["ds"]
    common = dict(ds=ds, ds_min=ds * 1e-4, ds_max=options["ds_max"], tol=options["tol"],
                  loc_tol=options["loc_tol"], bounds=bounds)
    first = start_point(problem, states, start, options["tol"], branch_id, math.copysign(1.0, span))
    todo = [(problem, first, False)]
    records = []
    born = []  # (period, the switched branch's points): its ends meet the parent's doublings
    branch = branch_id
    while todo:
        prob, head, doubled = todo.pop(0)
        head.branch = branch
        points = follow(prob, head, stop, max_points=options["max_points"], branch=branch,
                        doubled=doubled, **common)
        points[-1].label = points[-1].label or "end"
        records.extend(_record(prob, p) for p in points)
        if doubled:
            born.append((prob.period, points))
        if options["switch"] and prob.period < options["max_period"]:
            for p in points:
                if p.label == "period_doubling" and not _reached(born, 2 * prob.period, p, prob):
                    doubled_problem, new = switch_period_doubling(prob, p, options["tol"], ds,
                                                                  make_problem)
                    if new is not None:
                        todo.append((doubled_problem, new, True))
                        born.append((2 * prob.period, [new]))
        branch += 1000
    return records


def _reached(born: list, period: int, pd, problem) -> bool:
    """Whether a period-`period` branch already switched to ends at the doubling pd (the
    branch that links two doublings of its parent is followed once, from the first)."""
    target = np.concatenate([pd.states, pd.states])
    for n, points in born:
        if n != period:
            continue
        for p in (points[0], points[-1]):
            gap = np.max(np.abs(p.states - target)) / problem.sx
            if abs(p.value - pd.value) <= 0.05 * problem.ls and gap <= 0.05:
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
            "tip": np.array([np.dot(model.tip, x[:model.n_modes]) for x in p.states])}


def continuation(base, key, start, stop, *, y0=None, period=1, ds=None, ds_max=None,
                 max_points=200, rtol=1e-10, tol=1e-9, loc_tol=1e-9, switch=True,
                 max_period=8, settle=400, workers=None, client=None, progress=False, **unknown):
    """Continue periodic orbits of `base` in `key` from `start` towards `stop`.

    y0: the start state(s) at tau = 0, (a, adot) or with a viscoelastic sample (a, adot, w): None
    (a brute-force run of `settle` periods at `start` gives it), one state, or a list of states
    (one branch each, run in parallel on `workers` processes or a Dask `client`).  period: the
    orbit's period in drive periods.
    ds / ds_max: first and largest arclength step (scaled: the parameter in units of
    |stop - start|, states in units of their size); tol: Newton's tolerance on the scaled
    unknowns; loc_tol: the arclength tolerance of a located special point.  switch: follow the
    period-2n branch born at each period doubling (up to max_period).

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
    start = _number("start", start)
    stop = _number("stop", stop)
    if start == stop:
        raise InputError(f"continuation: start = stop = {start:g}: the interval is empty")
    period = _positive_int("period", period, 64)
    max_points = _positive_int("max_points", max_points, 100000)
    max_period = _positive_int("max_period", max_period, 64)
    settle = _positive_int("settle", settle, 100000)
    rtol = _tolerance("rtol", rtol, 1e-14, 1e-6)
    tol = _tolerance("tol", tol, 1e-13, 1e-4)
    loc_tol = _tolerance("loc_tol", loc_tol, 1e-13, 1e-2)
    ds = 0.02 if ds is None else _tolerance("ds", ds, 1e-8, 1.0)
    ds_max = 0.05 if ds_max is None else _tolerance("ds_max", ds_max, 1e-8, 1.0)
    if not isinstance(switch, (bool, np.bool_)):
        raise InputTypeError(f"switch = {shown(switch)}: must be True or False")
    base_config = _base_config(base)
    groups = _base_dict(base_config)
    _config(groups, {key: start})
    _config(groups, {key: stop})
    n_modes = base_config.n_modes
    m = map_size(Model(_config(groups, {key: start})))
    guesses = _guesses(y0, m)
    options = dict(rtol=rtol, tol=tol, loc_tol=loc_tol, ds=ds, ds_max=ds_max,
                   max_points=max_points, switch=bool(switch), max_period=max_period,
                   settle=settle)
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
    records = [r for branch in results for r in branch]
    return _dataset(xr, records, key, n_modes, m, base_config, options, start, stop)


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


def _dataset(xr, records, key, n_modes, m, base_config, options, start, stop):
    n = len(records)
    segments = max(r["period"] for r in records)
    states = np.full((n, segments, m), np.nan)
    tip = np.full((n, segments), np.nan)
    for i, r in enumerate(records):
        states[i, :r["period"]] = r["states"]
        tip[i, :r["period"]] = r["tip"]
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
    }
    for name, (meaning, unit) in OBSERVABLES.items():
        data[name] = ("point", np.array([r[name] for r in records], dtype=float),
                      {"long_name": meaning, "units": unit})
    for name, (factor, unit) in _si_factors(base_config).items():
        data[f"{name}_si"] = ("point", data[name][1] * factor,
                              {"long_name": f"{name} in SI-derived units", "units": unit})
    ds = xr.Dataset(data, coords={key: ("point", np.array([r["value"] for r in records])),
                                  "point": np.arange(n)})
    ds.attrs.update({"tmafm_kind": "continuation", "key": key, "start": start, "stop": stop,
                     "base": base_config.label, "n_modes": n_modes,
                     **{f"option_{k}": (int(v) if isinstance(v, bool) else v)
                        for k, v in options.items()}})
    return ds
