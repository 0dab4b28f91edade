"""Two-parameter continuation of a fold or a period doubling of periodic orbits
(docs/continuation.md, section 5a): the curve of folds (or doublings) in two input keys
(lambda, mu), by the minimally augmented system

    F(X, lambda, mu) = 0,      g(X, lambda, mu) = 0,

F the multiple-shooting residual (tmafm.continuation.shooting) and g the last component of the
solution of the bordered system [[J, b], [c^T, 0]] [v; g] = [0; 1], J = dF/dX the block-cyclic
shooting Jacobian (Govaerts, *Numerical Methods for Bifurcations of Dynamical Equilibria*,
SIAM 2000, ch. 4; the fold test of AUTO, MatCont, BifurcationKit).  g = 0 exactly where J is
singular, which for a periodic orbit is a Floquet multiplier at +1: a fold.  For a period
doubling J's wrap-around block -I is replaced by +I: singular where a multiplier is -1.  The bordering
vectors b, c are the left and right null vectors of J at the start and are replaced by w and v
(the bordered system's own solutions) after every point, so the bordered matrix stays regular.
The orbits, monodromy matrices and multipliers come from the core; g's gradient is a forward
difference of g in each unknown (each a map of the orbit's segments), whose O(h) error slows
Newton only: the curve is where g = 0, computed from the exact monodromy matrices.
"""

from __future__ import annotations

import math

import numpy as np

from .._model import Model
from .._namelist import shown
from .._run import Config
from ..errors import InputError, InputTypeError, SolverError
from ..sweeps.points import _base_config, _base_dict, _config, _noiseless, _split_key
from .shooting import (_jacobian, _merge_stats, _positive_int, _residual, _tolerance, floquet_multipliers,
                       map_size, periodic_map, state_scale)

__all__ = ["fold_curve", "period_doubling_curve"]


class _FoldProblem:
    """F = 0, g = 0 in the scaled unknowns u = (X/sx, (lambda - l0)/ls, (mu - m0)/ms)."""

    def __init__(self, groups, key, key2, period, rtol, l0, ls, m0, ms, sx, kind="fold"):
        self.groups, self.key, self.key2, self.period, self.rtol = groups, key, key2, period, rtol
        self.kind = kind
        self.l0, self.ls, self.m0, self.ms, self.sx = l0, ls, m0, ms, sx
        self._config = _config(groups, {})
        self.m = map_size(self.model(l0, m0))
        self.b = self.c = None
        self.failure = ""

    def model(self, lam: float, mu: float) -> Model:
        over: dict = {}
        for key, value in ((self.key, lam), (self.key2, mu)):
            group, name = key.split(".")
            over.setdefault(group, {})[name] = float(value)
        return Model(Config(self._config, **over))

    def unpack(self, u):
        return (u[:-2].reshape(self.period, self.m) * self.sx, self.l0 + u[-2] * self.ls,
                self.m0 + u[-1] * self.ms)

    def maps(self, u):
        states, lam, mu = self.unpack(u)
        model = self.model(lam, mu)
        return states, [periodic_map(model, x, 1, self.rtol) for x in states]

    def bordered(self, jx):
        """(v, g, w) of [[J, b], [c^T, 0]] [v; g] = [0; 1] and its transpose."""
        n = len(jx)
        big = np.zeros((n + 1, n + 1))
        big[:n, :n] = jx
        big[:n, n] = self.b
        big[n, :n] = self.c
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        vg = np.linalg.solve(big, rhs)
        wh = np.linalg.solve(big.T, rhs)
        return vg[:n], vg[n], wh[:n]

    def test_matrix(self, maps):
        """The matrix singular at the point followed: J = dF/dX for a fold; for a period
        doubling J with its wrap-around block +I instead of -I (singular where the product of
        the segments has a multiplier -1: M_i v_i = v_(i+1), M_n v_n = -v_1)."""
        jac = _jacobian(maps)
        if self.kind == "period_doubling":
            n, m = self.period, self.m
            jac[(n - 1) * m:, :m] += 2 * np.eye(m)
        return jac

    def g_only(self, u) -> float:
        states, maps = self.maps(u)
        return self.bordered(self.test_matrix(maps))[1]

    def system(self, u):
        """R = (F/sx, g) at u and its (n+1) x (n+2) Jacobian; the maps at u."""
        states, maps = self.maps(u)
        res = _residual(maps, states) / self.sx
        jx = _jacobian(maps)
        _, g, _ = self.bordered(self.test_matrix(maps))
        h = 1e-6
        columns = []
        for k in (-2, -1):  # dF/dlambda~, dF/dmu~: forward differences of the map
            up = u.copy()
            up[k] += h
            st, mp = self.maps(up)
            columns.append((_residual(mp, st) / self.sx - res) / h)
        grad = np.empty(len(u))
        for k in range(len(u)):
            up = u.copy()
            up[k] += h
            grad[k] = (self.g_only(up) - g) / h
        jac = np.vstack([np.column_stack([jx, columns[0], columns[1]]), grad])
        return np.concatenate([res, [g]]), jac, maps


def _tangent(jac, previous):
    if previous is None:
        t = np.linalg.svd(jac)[2][-1]
    else:
        t = np.linalg.solve(np.vstack([jac, previous]), np.concatenate([np.zeros(len(jac)), [1.0]]))
        t /= np.linalg.norm(t)
        if t @ previous < 0:
            t = -t
    return t


def _correct(problem, u_pred, direction, tol, max_iter=15):
    u = u_pred.copy()
    for it in range(1, max_iter + 1):
        try:
            res, jac, maps = problem.system(u)
        except (InputError, SolverError) as error:
            problem.failure = f"{type(error).__name__}: {error}"
            return None
        except np.linalg.LinAlgError:
            problem.failure = "the bordered matrix is singular"
            return None
        full = np.vstack([jac, direction])
        try:
            du = np.linalg.solve(full, -np.concatenate([res, [direction @ (u - u_pred)]]))
        except np.linalg.LinAlgError:
            problem.failure = "the Newton matrix is singular"
            return None
        u = u + du
        if np.max(np.abs(du)) <= tol and np.max(np.abs(res)) <= 10 * tol:
            return u, jac, maps, it
        if not np.all(np.isfinite(du)) or np.max(np.abs(du)) > 1e3:
            problem.failure = "Newton diverged"
            return None
    problem.failure = f"Newton did not converge in {max_iter} iterations"
    return None


def _refresh_borders(problem, maps):
    v, _, w = problem.bordered(problem.test_matrix(maps))
    problem.c = v / np.linalg.norm(v)
    problem.b = w / np.linalg.norm(w)


def fold_curve(base, key2, point, stop2, *, ds=0.02, ds_max=0.1, max_points=100, rtol=1e-10,
               tol=1e-9, direction=1, **unknown):
    """The curve of folds through `point` (a 'fold' point of a tmafm.continuation Dataset) in
    the plane of its key and key2: see _curve."""
    return _curve("fold", base, key2, point, stop2, ds=ds, ds_max=ds_max,
                  max_points=max_points, rtol=rtol, tol=tol, direction=direction, **unknown)


def period_doubling_curve(base, key2, point, stop2, *, ds=0.02, ds_max=0.1, max_points=100,
                          rtol=1e-10, tol=1e-9, direction=1, **unknown):
    """The curve of period doublings through `point` (a 'period_doubling' point) in the plane
    of its key and key2: as fold_curve, the bordered matrix built on J with its wrap-around
    block +I (a multiplier -1), multipliers with one at -1 along it."""
    return _curve("period_doubling", base, key2, point, stop2, ds=ds, ds_max=ds_max,
                  max_points=max_points, rtol=rtol, tol=tol, direction=direction, **unknown)


def _curve(kind, base, key2, point, stop2, *, ds, ds_max, max_points, rtol, tol, direction,
           **unknown):
    """The curve of `kind` points (fold, period_doubling) through `point` (such a point of a
    tmafm.continuation Dataset, ds.isel(point=k), continued in its key) in the plane of its key
    and key2, from key2's value in base towards stop2: an xarray.Dataset along 'point' with both
    keys, the orbit's section states, its multipliers (one at +1, or -1), g (the test
    function, 0 to the tolerance), the
    Newton iterations and steps, and end_reason ('stop', 'max_points' or 'corrector_failed'
    with end_detail) at the last point.  ds / ds_max / tol as tmafm.continuation's, in units of
    the Dataset's |stop - start| and of |stop2 - key2's start|; direction 1 starts with key2
    moving towards stop2, -1 away from it."""
    import xarray as xr
    if unknown:
        raise InputTypeError("fold_curve: unknown keyword argument(s) "
                             + ", ".join(f"{k} = {shown(v)}" for k, v in sorted(unknown.items())))
    if type(point).__name__ != "Dataset" or point.attrs.get("tmafm_kind") != "continuation":
        raise InputTypeError("point: must be one point of tmafm.continuation's Dataset "
                             "(ds.isel(point=k))")
    if "point" in point.dims:
        if point.sizes["point"] != 1:
            raise InputError(f"point: one point of the Dataset, got {point.sizes['point']}")
        point = point.isel(point=0)
    if str(point["label"].values) != kind:
        raise InputError(f"point: its label is {str(point['label'].values)!r}, not '{kind}'")
    key = point.attrs["key"]
    _split_key(key2)
    if key2 == key:
        raise InputError(f"key2 = {shown(key2)}: must differ from the point's key")
    if direction not in (1, -1) or isinstance(direction, bool):
        raise InputTypeError(f"direction = {shown(direction)}: must be 1 or -1")
    max_points = _positive_int("max_points", max_points, 100000)
    rtol = _tolerance("rtol", rtol, 1e-14, 1e-6)
    tol = _tolerance("tol", tol, 1e-13, 1e-4)
    ds = _tolerance("ds", ds, 1e-8, 1.0)
    ds_max = _tolerance("ds_max", ds_max, 1e-8, 1.0)
    _noiseless(_base_config(base), f"{kind}_curve")
    groups = _base_dict(_base_config(base))
    group2, name2 = key2.split(".")
    if name2 not in groups.get(group2, {}):
        raise InputError(f"key2 = {shown(key2)}: the base gives no value of it to start from")
    start2 = float(groups[group2][name2])
    try:
        stop2 = float(stop2)
    except (TypeError, ValueError, OverflowError):
        raise InputTypeError(f"stop2 = {shown(stop2)}: must be a finite number") from None
    if not math.isfinite(stop2) or stop2 == start2:
        raise InputError(f"stop2 = {shown(stop2)}: must be finite and differ from {key2} = "
                         f"{start2!r}")
    _config(groups, {key2: stop2})
    n = int(point["period"])
    states = np.asarray(point["state"].values[:n], dtype=float)
    lam = float(point[key])
    ls = abs(float(point.attrs["stop"]) - float(point.attrs["start"]))
    probe = Model(_config(groups, {key: lam}))
    problem = _FoldProblem(groups, key, key2, n, rtol, lam, ls, start2, abs(stop2 - start2),
                           state_scale(probe, states), kind)
    u = np.concatenate([np.ravel(states) / problem.sx, [0.0, 0.0]])
    # The borders: the test matrix's null vectors at the point (smallest singular vectors).
    maps = problem.maps(u)[1]
    left, _, right = np.linalg.svd(problem.test_matrix(maps))
    problem.b, problem.c = left[:, -1], right[-1]
    fixed = np.zeros(len(u))
    fixed[-1] = 1.0  # the first point at key2's start: lambda free, mu fixed
    out = _correct(problem, u, fixed, tol, max_iter=30)
    if out is None:
        raise SolverError(f"{kind}_curve: no {kind} found from the point at {key} = {lam:.9g} "
                          f"({problem.failure})")
    u, jac, maps, it = out
    _refresh_borders(problem, maps)
    t = _tangent(jac, None)
    if t[-1] * direction * math.copysign(1.0, stop2 - start2) < 0:
        t = -t
    rows = [_row(problem, u, maps, it, math.nan)]
    h = ds
    reason, detail = "max_points", f"{max_points} points"
    lo, hi = min(start2, stop2), max(start2, stop2)
    while len(rows) < max_points:
        out = _correct(problem, u + h * t, t, tol)
        if out is None:
            h *= 0.5
            if h < ds * 1e-4:
                reason = "corrector_failed"
                detail = f"the corrector failed below the smallest step: {problem.failure}"
                break
            continue
        u_new, jac, maps, it = out
        t_new = _tangent(jac, t)
        if t_new @ t < 0.8 and h > ds * 1e-4:
            h *= 0.5
            continue
        u, t = u_new, t_new
        _refresh_borders(problem, maps)
        rows.append(_row(problem, u, maps, it, h))
        if it <= 4:
            h = min(1.5 * h, ds_max)
        elif it >= 9:
            h *= 0.5
        if not (lo <= rows[-1]["mu"] <= hi):
            reason, detail = "stop", f"{key2} passed {stop2:.9g}"
            break
    rows[-1]["end_reason"], rows[-1]["end_detail"] = reason, detail
    mu_all = np.array([r["multipliers"] for r in rows])
    data = {
        key2: ("point", np.array([r["mu"] for r in rows])),
        "state": (("point", "segment", "state"), np.array([r["states"] for r in rows])),
        "multiplier_re": (("point", "multiplier"), mu_all.real),
        "multiplier_im": (("point", "multiplier"), mu_all.imag),
        "multiplier_abs": (("point", "multiplier"), np.abs(mu_all)),
        "stable": ("point", np.array([bool(np.max(np.abs(r["multipliers"])) < 1) for r in rows])),
        "test_function": ("point", np.array([r["g"] for r in rows]),
                          {"long_name": "g of the bordered system (0 on the curve)"}),
        "contacts": ("point", np.array([r["contacts"] for r in rows], dtype=float)),
        "min_gap": ("point", np.array([r["min_gap"] for r in rows])),
        "newton_iterations": ("point", np.array([r["iterations"] for r in rows], dtype=int)),
        "step": ("point", np.array([r["step"] for r in rows])),
        "end_reason": ("point", np.array([r.get("end_reason", "") for r in rows], dtype=object)
                       .astype(str)),
        "end_detail": ("point", np.array([r.get("end_detail", "") for r in rows], dtype=object)
                       .astype(str)),
    }
    return xr.Dataset(data, coords={key: ("point", np.array([r["lam"] for r in rows])),
                                    "point": np.arange(len(rows))},
                      attrs={"tmafm_kind": f"{kind}_curve", "key": key, "key2": key2,
                             "start2": start2, "stop2": stop2, "period": n})


def _row(problem, u, maps, iterations, step) -> dict:
    states, lam, mu = problem.unpack(u)
    stats = _merge_stats(maps)
    _, g, _ = problem.bordered(problem.test_matrix(maps))
    return {"lam": lam, "mu": mu, "states": states, "g": g, "iterations": iterations,
            "step": step, "multipliers": floquet_multipliers([mp.monodromy for mp in maps]),
            "contacts": stats["contacts"] / problem.period, "min_gap": stats["gap_min"]}
