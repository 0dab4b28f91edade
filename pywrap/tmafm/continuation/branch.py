"""Pseudo-arclength continuation of periodic orbits in one scalar input key, with detection and
location of folds, period doublings (and the switch to the doubled branch), Neimark-Sacker
pairs and grazing (docs/continuation.md).  The orbits, their Jacobians and their multipliers
come from the core through tmafm.continuation.shooting; this module only orchestrates."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._model import Model
from .._run import Config
from ..errors import InputError, SolverError
from ..sweeps.points import _config
from .shooting import (_jacobian, _merge_stats, _residual, floquet_multipliers, map_period, map_size,
                       periodic_map)

#: Labels of special points.
LABELS = ("", "start", "end", "fold", "period_doubling", "neimark_sacker", "grazing",
          "contact_sequence")


@dataclass
class Point:
    """One corrected point of a branch (scaled unknowns u = (X / sx, (lambda - l0) / ls))."""

    u: np.ndarray
    tangent: np.ndarray
    value: float
    states: np.ndarray
    monodromies: list
    stats: dict
    multipliers: np.ndarray = field(default=None)
    label: str = ""
    branch: int = 0
    #: sign det [dF/du; tangent]: constant along a regular branch followed one way (a fold does
    #: not change it); a corrector that lands on a nearby branch followed the other way (the
    #: unstable side of a fold, close to the stable one) flips it.
    orientation: float = 0.0
    #: Diagnostics: Newton iterations of the corrector, the arclength step that reached the
    #: point (NaN at a start or a located point), the largest |multiplier| of the orbits on
    #: either side of a located point (NaN elsewhere), why the branch ends here ('' if it
    #: does not) and the corrector's last failure there.
    iterations: int = 0
    step: float = math.nan
    mu_before: float = math.nan
    mu_after: float = math.nan
    end_reason: str = ""
    end_detail: str = ""


class Problem:
    """The periodic orbits of period n of base with `key` free: R(X, lambda) = 0."""

    def __init__(self, base: dict, key: str, period: int, rtol: float, l0: float, ls: float,
                 sx: float):
        self.base, self.key, self.period, self.rtol = base, key, period, rtol
        # The base as a Config of this process: each value patches it (the core reads the
        # override, as tmafm.Config(config, scene={...}) does).
        self._config = _config(base, {})
        self._group, self._name = key.split(".")
        self.l0, self.ls, self.sx = l0, ls, sx
        self._models: dict = {}
        # The map's state: (a, adot), or (a, adot, w) with a viscoelastic sample.
        self.m = map_size(self.model(l0))
        #: The corrector's last failure, in words (the end_detail of a branch that ends there).
        self.failure = ""

    def model(self, value: float) -> Model:
        model = self._models.get(value)
        if model is None:
            model = Model(Config(self._config, **{self._group: {self._name: float(value)}}))
            if len(self._models) > 64:
                self._models.clear()
            self._models[value] = model
        return model

    def unpack(self, u: np.ndarray) -> tuple[np.ndarray, float]:
        return u[:-1].reshape(self.period, self.m) * self.sx, self.l0 + u[-1] * self.ls

    def pack(self, states: np.ndarray, value: float) -> np.ndarray:
        return np.concatenate([np.ravel(states) / self.sx, [(value - self.l0) / self.ls]])

    def maps(self, states: np.ndarray, value: float) -> list:
        model = self.model(value)
        return [periodic_map(model, x, 1, self.rtol) for x in states]

    def residual(self, u: np.ndarray):
        """The scaled residual F(u), dF/dX~ and the maps at u."""
        states, value = self.unpack(u)
        maps = self.maps(states, value)
        return _residual(maps, states) / self.sx, _jacobian(maps), maps

    def lambda_column(self, u: np.ndarray, maps: list) -> np.ndarray:
        """dF/dlambda~ at u, by a forward difference of the core's map in the key (a step of
        1e-6 of the parameter's scale; `maps` are the maps at u).  Its O(h) error slows
        Newton's convergence only (the residual is exact), and a fold's location does not
        depend on it (there the null vector has no lambda part)."""
        states, value = self.unpack(u)
        h = 1e-6 * self.ls
        plus = _residual(self.maps(states, value + h), states)
        return (plus - _residual(maps, states)) / h * self.ls / self.sx


def _tangent(jac: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
    """The unit null vector of the n x (n+1) Jacobian, oriented along `previous`."""
    if previous is None:
        _, _, vt = np.linalg.svd(jac)
        t = vt[-1]
        if t[-1] < 0:
            t = -t
    else:
        t = np.linalg.solve(np.vstack([jac, previous]), np.concatenate([np.zeros(len(jac)), [1.0]]))
        t /= np.linalg.norm(t)
        if t @ previous < 0:
            t = -t
    return t


def correct(problem: Problem, u_pred: np.ndarray, direction: np.ndarray, tol: float,
            max_iter: int = 12):
    """Newton on (F(u) = 0, direction.(u - u_pred) = 0) from u_pred, with dF/dlambda taken once
    at u_pred (a chord in that column only).  Converged when the Newton step and the residual
    are below tol; returns (u, jacobian, maps, iterations), the Jacobian and maps those of the
    last iterate (within tol of u), or None if it does not converge."""
    u = u_pred.copy()
    column = None
    for it in range(1, max_iter + 1):
        try:
            res, jx, maps = problem.residual(u)
            if column is None:
                column = problem.lambda_column(u, maps)
        except (InputError, SolverError) as error:  # the key out of its range, or the map failed
            problem.failure = f"{type(error).__name__}: {error}"
            return None
        if not np.all(np.isfinite(res)):
            problem.failure = "the residual is not finite"
            return None
        jac = np.column_stack([jx, column])
        full = np.vstack([jac, direction])
        rhs = -np.concatenate([res, [direction @ (u - u_pred)]])
        try:
            du = np.linalg.solve(full, rhs)
        except np.linalg.LinAlgError:
            problem.failure = "the Newton matrix is singular"
            return None
        u = u + du
        if np.max(np.abs(du)) <= tol and np.max(np.abs(res)) <= 10 * tol:
            return u, jac, maps, it
        if not np.all(np.isfinite(du)) or np.max(np.abs(du)) > 1e3:
            problem.failure = "Newton diverged"
            return None
    problem.failure = (f"Newton did not converge in {max_iter} iterations (scaled residual "
                       f"{np.max(np.abs(res)):.3g})")
    return None


def make_point(problem: Problem, u, jac, maps, previous_tangent, branch) -> Point:
    states, value = problem.unpack(u)
    t = _tangent(jac, previous_tangent)
    mono = [mp.monodromy for mp in maps]
    orientation = float(np.linalg.slogdet(np.vstack([jac, t]))[0])
    return Point(u=u, tangent=t, value=value, states=states, monodromies=mono,
                 stats=_merge_stats(maps), multipliers=floquet_multipliers(mono), branch=branch,
                 orientation=orientation)


# --- test functions --------------------------------------------------------------------------

def _pd_test(point: Point) -> float:
    """det(M + I) = prod(mu + 1): real; changes sign when a real multiplier passes -1."""
    return float(np.real(np.prod(point.multipliers + 1)))


def _ns_count(point: Point) -> int:
    mu = point.multipliers
    return int(np.sum((np.abs(mu.imag) > 1e-9 * np.abs(mu)) & (np.abs(mu) > 1)))


def _ns_test(point: Point) -> float:
    mu = point.multipliers
    cplx = np.abs(mu.imag) > 1e-9 * np.abs(mu)
    return float(np.max(np.abs(mu[cplx])) - 1) if cplx.any() else math.nan


def _tests(point: Point) -> dict:
    return {"fold": point.tangent[-1], "period_doubling": _pd_test(point),
            "neimark_sacker": _ns_test(point), "grazing": point.stats["contacts"]}


def detect(a: Point, b: Point) -> list[str]:
    """The special points between two consecutive points of a branch."""
    ta, tb = _tests(a), _tests(b)
    found = []
    if ta["fold"] * tb["fold"] < 0:
        found.append("fold")
    if ta["period_doubling"] * tb["period_doubling"] < 0:
        found.append("period_doubling")
    if _ns_count(a) != _ns_count(b) and not (math.isnan(ta["neimark_sacker"])
                                            or math.isnan(tb["neimark_sacker"])):
        found.append("neimark_sacker")
    if ta["grazing"] != tb["grazing"]:
        found.append("grazing")
    return found


def locate(problem: Problem, a: Point, b: Point, kind: str, tol: float, loc_tol: float):
    """The special point `kind` between a and b, by the Illinois method on the arclength sigma
    from a along a's tangent.  Grazing: on the orbit's minimum gap when the orbit starts or
    stops touching, by bisection on the count of contacts otherwise."""
    ds_total = float(a.tangent @ (b.u - a.u))
    counts = (a.stats["contacts"], b.stats["contacts"])
    by_count = kind == "grazing" and min(counts) > 0

    def at(sigma: float) -> Point | None:
        out = correct(problem, a.u + sigma * a.tangent, a.tangent, tol, max_iter=30)
        if out is None:
            return None
        return make_point(problem, *out[:3], a.tangent, a.branch)

    def value(p: Point) -> float:
        if kind == "grazing":
            if by_count:
                return p.stats["contacts"] - 0.5 * sum(counts)
            return p.stats["gap_min"]
        return _tests(p)[kind]

    lo, hi = 0.0, ds_total
    flo, fhi = value(a), value(b)
    best = None
    side = 0
    # The last iterates on either side of the point (the bracket's ends): their multipliers
    # give the stability just before and just after it (discontinuous at a grazing point).
    before, after = a, b
    for _ in range(100):
        if abs(hi - lo) <= loc_tol:
            break
        if by_count:
            mid = 0.5 * (lo + hi)
        else:
            mid = hi - fhi * (hi - lo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
            if not (min(lo, hi) < mid < max(lo, hi)):
                mid = 0.5 * (lo + hi)
        p = at(mid)
        if p is None:  # Newton failed: try the middle of the bracket instead
            mid = 0.5 * (lo + hi)
            p = at(mid)
            if p is None:
                break
        fm = value(p)
        best = p
        if fm == 0:
            break
        if (fm < 0) == (flo < 0):
            before = p
            lo, flo = mid, fm
            if side == -1 and not by_count:
                fhi /= 2
            side = -1
        else:
            after = p
            hi, fhi = mid, fm
            if side == 1 and not by_count:
                flo /= 2
            side = 1
    if best is not None:
        best.label = kind
        best.mu_before = _mu_max(before)
        best.mu_after = _mu_max(after)
    return best


def _mu_max(p: Point) -> float:
    return float(np.max(np.abs(p.multipliers)))


#: Why a branch ends (Point.end_reason, the Dataset's `end_reason`): the stop value or the
#: interval's end reached, max_points points, a doubled branch meeting its parent again, a
#: start state on a branch another start state traced (tmafm.continuation), the corrector
#: failing at a non-smooth point (a contact appearing or vanishing at grazing; the number of
#: contacts per period changing) that could not be crossed, or failing elsewhere.
END_REASONS = ("stop", "max_points", "rejoined", "duplicate", "grazing", "contact_sequence",
               "corrector_failed")
#: Ends that are not early (no warning).
FINISHED = ("stop", "rejoined", "duplicate")
#: Most non-smooth points one branch crosses.
MAX_CROSSINGS = 20


def _amplitude(p: Point) -> float:
    return 0.5 * (p.stats["gap_max"] - p.stats["gap_min"])


def grazing_distance(p: Point) -> float:
    """How far the orbit is from a contact appearing, relative to its amplitude: its
    smallest V_T if it never touches, else the smallest minimum of V_T inside a flight (NaN
    if it has none)."""
    g = p.stats["gap_min"] if p.stats["contacts"] == 0 else p.stats["flight_gap_min"]
    return g / max(_amplitude(p), 1e-300)


def _non_smooth(problem: Problem, current: Point, h: float) -> str | None:
    """Why the corrector fails next to `current` (its step h): 'grazing' where a contact is
    about to appear (a minimum of V_T within 1e-4 of the amplitude above the surface) or
    vanish (|dV_T/dtau| at a switch within 1e-3 of amplitude x omega), 'contact_sequence'
    where the orbit at the predicted point has another number of contacts, else None."""
    rate = current.stats["switch_rate_min"]
    omega = 2 * math.pi / map_period(problem.model(current.value))
    distance = grazing_distance(current)
    if (not math.isnan(distance) and distance < 1e-4) or \
            (not math.isnan(rate) and rate < 1e-3 * _amplitude(current) * omega):
        return "grazing"
    try:
        states, value = problem.unpack(current.u + h * current.tangent)
        maps = problem.maps(states, value)
    except (InputError, SolverError):
        return None
    if sum(mp.stats["contacts"] for mp in maps) != current.stats["contacts"]:
        return "contact_sequence"
    return None


def correct_fixed(problem: Problem, u0: np.ndarray, tol: float, max_iter: int = 60):
    """Newton at fixed lambda from u0 with a backtracking line search on the residual (the
    map's Jacobian is singular at a grazing point, so a plain Newton step from there lands
    anywhere).  Returns as correct() does, or None."""
    u = u0.copy()
    for it in range(1, max_iter + 1):
        try:
            res, jx, maps = problem.residual(u)
        except (InputError, SolverError) as error:
            problem.failure = f"{type(error).__name__}: {error}"
            return None
        r0 = np.max(np.abs(res))
        try:
            du = np.linalg.solve(jx, -res)
        except np.linalg.LinAlgError:
            problem.failure = "the Newton matrix is singular"
            return None
        if np.max(np.abs(du)) <= tol and r0 <= 10 * tol:
            column = problem.lambda_column(u, maps)
            return u, np.column_stack([jx, column]), maps, it
        step = 1.0
        while step > 1e-6:
            trial = u.copy()
            trial[:-1] += step * du
            try:
                r1 = np.max(np.abs(problem.residual(trial)[0]))
            except (InputError, SolverError):
                r1 = math.inf
            if r1 < (1 - 1e-4 * step) * r0:
                break
            step *= 0.5
        if step <= 1e-6:
            problem.failure = "the line search found no decrease at fixed parameter"
            return None
        u = trial
    problem.failure = f"Newton at fixed parameter did not converge in {max_iter} iterations"
    return None


def _signature(p: Point) -> tuple:
    return (p.stats["contacts"], p.stats["gap_min"] < 0)


def cross(problem: Problem, current: Point, *, tol: float, ds: float, ds_min: float,
          branch: int, previous_signature=None):
    """The branch past a non-smooth point next to `current`: the shooting problem posed again
    on the new event sequence.  At fixed lambda past the point, Newton with a line search from
    `current`'s orbit: first ds past it, then 4 times closer down to 100 ds_min, in the
    branch's own direction; then the same backwards (where the new branch leaves backwards),
    where an orbit of the sequence before the last crossing does not count (that is the way
    back).  The first orbit with another contact sequence (number of contacts, or touching
    where it did not) starts the branch again, its tangent pointing away from the point.
    Returns (that point, the orbit just past the point: at 100 ds_min on the same side, for
    the multipliers there) or None."""
    sign = math.copysign(1.0, current.tangent[-1]) if current.tangent[-1] != 0 else 1.0
    deltas = []
    delta = ds
    while delta >= 100 * ds_min:
        deltas.append(delta)
        delta /= 4
    for s in (sign, -sign):
        for delta in deltas:
            p = _fixed_orbit(problem, current, s * delta, tol, branch)
            if p is None:
                continue
            # Forwards any orbit past the point continues the branch (the sequence may change
            # in more than the counts: a flight's minimum appearing); backwards only one of
            # another sequence, and not the one before the last crossing.
            if s != sign and (_signature(p) == _signature(current)
                              or _signature(p) == previous_signature):
                continue
            if p.tangent[-1] * s < 0:
                p.tangent = -p.tangent
                p.orientation = -p.orientation
            p.step = delta
            near = _fixed_orbit(problem, current, s * 100 * ds_min, tol, branch) \
                if delta > 100 * ds_min else p
            if near is None or _signature(near) != _signature(p):
                near = p
            return p, near
    return None


def _fixed_orbit(problem: Problem, current: Point, offset: float, tol: float, branch: int):
    """The orbit at current's lambda + offset (scaled), from current's states, or None."""
    u0 = current.u.copy()
    u0[-1] += offset
    fixed = np.zeros_like(u0)
    fixed[-1] = 1.0
    # Plain Newton first (past a change of the sequence its first step may raise the residual
    # before it converges), then with the line search (from a grazing orbit, where the plain
    # step lands anywhere).
    out = correct(problem, u0, fixed, tol, max_iter=40) or correct_fixed(problem, u0, tol)
    if out is None:
        return None
    p = make_point(problem, *out[:3], None, branch)
    p.iterations = out[3]
    return p


def refine_grazing(problem: Problem, previous: Point, current: Point, tol: float) -> Point:
    """The grazing point on the smooth side: the secant method in lambda on the grazing
    distance (grazing_distance) from the branch's last two points, each trial an orbit at
    fixed lambda; the trial nearest grazing on the smooth side, or `current`."""
    best = current
    a, b = previous, current
    fixed = np.zeros_like(current.u)
    fixed[-1] = 1.0
    for _ in range(8):
        ga, gb = grazing_distance(a), grazing_distance(b)
        if math.isnan(ga) or math.isnan(gb) or ga == gb or abs(gb) < 1e-12:
            break
        lam = b.u[-1] - gb * (b.u[-1] - a.u[-1]) / (gb - ga)
        u0 = b.u + (lam - b.u[-1]) / (b.u[-1] - a.u[-1]) * (b.u - a.u) if b.u[-1] != a.u[-1] \
            else b.u.copy()
        out = correct(problem, u0, fixed, tol, max_iter=30)
        if out is None:
            break
        p = make_point(problem, *out[:3], current.tangent, current.branch)
        if _signature(p) != _signature(current) or grazing_distance(p) < 0:
            break
        a, b = b, p
        best = p
    return best


def follow(problem: Problem, first: Point, stop_value: float, *, ds: float, ds_min: float,
           ds_max: float, max_points: int, tol: float, loc_tol: float, bounds: tuple,
           branch: int, progress=None, doubled: bool = False,
           cross_non_smooth: bool = True) -> list[Point]:
    """The branch from `first` along its tangent until `stop_value` is passed, the parameter
    leaves `bounds`, or max_points points; special points are inserted where located.  A
    corrector that fails at a non-smooth point (grazing, a change of the contact sequence) is
    re-posed past it (cross) when cross_non_smooth.  The last point carries end_reason
    (END_REASONS) and end_detail.
    doubled: a branch born at a period doubling, which ends where it meets its parent again
    (the difference between its two halves, having grown past twice its size at the start,
    comes back below it: past that lies the same orbit with its halves swapped)."""
    points = [first]
    size0 = np.linalg.norm(halves(first)) if doubled else 0.0
    grown = False
    current = first
    previous = None
    h = ds
    lo, hi = bounds
    reason, detail = "max_points", f"{max_points} points"
    crossings = 0
    signature_before = None
    while len(points) < max_points:
        out = correct(problem, current.u + h * current.tangent, current.tangent, tol)
        if out is None:
            h *= 0.5
            if h >= ds_min:
                continue
            kind = _non_smooth(problem, current, 2 * h)
            failure = problem.failure
            if kind is not None and cross_non_smooth and crossings < MAX_CROSSINGS:
                crossed = cross(problem, current, tol=tol, ds=ds, ds_min=ds_min, branch=branch,
                                previous_signature=signature_before)
                if crossed is not None:
                    past, near = crossed
                    crossings += 1
                    signature_before = _signature(current)
                    graze = refine_grazing(problem, previous, current, tol) \
                        if previous is not None and kind == "grazing" else current
                    if graze is not current:
                        points.append(graze)
                    graze.label = graze.label or kind
                    graze.mu_before = _mu_max(graze)
                    graze.mu_after = _mu_max(near)
                    points.append(past)
                    previous, current, h = None, past, max(past.step, ds_min)
                    if progress is not None:
                        progress()
                    continue
            reason = kind or "corrector_failed"
            detail = (f"the corrector failed below the smallest step ({ds_min:.3g}): "
                      f"{failure}")
            if kind is not None:
                detail += "; not crossed" if cross_non_smooth else "; crossing off"
            break
        u, jac, maps, iterations = out
        nxt = make_point(problem, u, jac, maps, current.tangent, branch)
        nxt.iterations, nxt.step = iterations, h
        # A step that turned the branch too far back (a corner), or that landed on another
        # branch followed the other way (docs/vdw.md: the two sides of a fold 0.05 nm apart in a
        # 10 nm orbit), is retried shorter.
        if (nxt.tangent @ current.tangent < 0.8 or nxt.orientation != current.orientation) \
                and h > ds_min:
            h *= 0.5
            continue
        if doubled:
            size = np.linalg.norm(halves(nxt))
            grown = grown or size > 2 * size0
            if grown and size < size0:
                reason, detail = "rejoined", "the doubled branch meets its parent again"
                break
        for kind in detect(current, nxt):
            special = locate(problem, current, nxt, kind, tol, loc_tol)
            if special is not None:
                points.append(special)
        points.append(nxt)
        if progress is not None:
            progress()
        previous, current = current, nxt
        if iterations <= 4:
            h = min(h * 1.5, ds_max)
        elif iterations >= 9:
            h = max(h * 0.5, ds_min)
        if not (lo <= nxt.value <= hi):
            reason, detail = "stop", f"{problem.key} passed {stop_value:.9g}"
            break
    last = points[-1]
    last.label = last.label or "end"
    last.end_reason, last.end_detail = reason, detail
    return points


def halves(p: Point) -> np.ndarray:
    """The difference between the two halves of a period-2n orbit: zero on the doubled
    period-n orbit."""
    h = len(p.states) // 2
    return np.ravel(p.states[:h] - p.states[h:])


def start_point(problem: Problem, states: np.ndarray, value: float, tol: float, branch: int,
                direction: float, along=None) -> Point:
    """The first point: Newton at fixed lambda from states, then its tangent: pointing towards
    increasing lambda~ when direction > 0, or, given `along` (a tangent in physical units,
    (dX, dlambda), as physical_tangent gives), along it when direction > 0 and against it
    otherwise.  A period-n orbit whose segments repeat with a shorter period is refused (it is
    the shorter orbit run several times: its branch is that orbit's, and a period-2 branch
    starts at a period doubling)."""
    u = problem.pack(states, value)
    fixed = np.zeros_like(u)
    fixed[-1] = 1.0
    out = correct(problem, u, fixed, tol, max_iter=40)
    if out is None:
        raise SolverError(f"continuation: no periodic orbit of period {problem.period} found "
                          f"from the start state at {problem.key} = {value:.9g} "
                          f"({problem.failure})")
    p = make_point(problem, *out[:3], None, branch)
    n = problem.period
    for d in range(1, n):
        if n % d == 0 and np.max(np.abs(p.states - np.roll(p.states, -d, axis=0))) \
                <= 1e3 * tol * problem.sx:
            raise InputError(f"period = {n}: the orbit found from the start state at "
                             f"{problem.key} = {value:.9g} has period {d} (its segments repeat); "
                             f"a period-{n} branch starts at a period doubling: restart from its "
                             f"'period_doubling' point with period = {n}")
    if along is None:
        flip = p.tangent[-1] * direction < 0
    else:
        scaled = np.concatenate([np.ravel(along[0]) / problem.sx, [along[1] / problem.ls]])
        flip = (p.tangent @ scaled) * direction < 0
    if flip:
        p.tangent = -p.tangent
        p.orientation = -p.orientation
    p.label = "start"
    return p


def physical_tangent(problem: Problem, p: Point) -> tuple:
    """p's tangent in physical units: (dX (period x state), dlambda)."""
    return p.tangent[:-1].reshape(problem.period, problem.m) * problem.sx, p.tangent[-1] * problem.ls


def switch_period_doubling(problem: Problem, pd: Point, tol: float, ds: float,
                           make_problem) -> tuple:
    """The period-2n branch born at a period doubling: the eigenvector v of the multiplier
    nearest -1 gives the doubled orbit's direction (x + e v, P(x) - e M v, ...); a predictor
    along it with the arclength constraint orthogonal to it (lambda free) lands on the new
    branch (the doubling is a pitchfork of P^(2n))."""
    product = pd.monodromies[0]
    for mono in pd.monodromies[1:]:
        product = mono @ product
    mu, vecs = np.linalg.eig(product)
    k = int(np.argmin(np.abs(mu + 1)))
    v = np.real(vecs[:, k])
    # The eigenvector carried around the orbit's segments: v_(i+1) = M_i v_i.
    vs = [v]
    for mono in pd.monodromies[:-1]:
        vs.append(mono @ vs[-1])
    doubled = make_problem(2 * problem.period)
    states2 = np.concatenate([pd.states, pd.states])
    w = np.concatenate([np.concatenate(vs), -np.concatenate(vs)]) / doubled.sx
    direction = np.concatenate([w, [0.0]])
    direction /= np.linalg.norm(direction)
    base_u = doubled.pack(states2, pd.value)
    for scale in (1.0, 0.3, 3.0, 0.1):
        for sign in (1.0, -1.0):
            out = correct(doubled, base_u + sign * scale * ds * direction, direction, tol)
            if out is None:
                continue
            st, _ = doubled.unpack(out[0])
            half = len(st) // 2
            if np.max(np.abs(st[:half] - st[half:])) > 1e-6 * doubled.sx:
                p = make_point(doubled, *out[:3], None, pd.branch + 1)
                # Orient the tangent away from the doubling point.
                if p.tangent @ (p.u - base_u) < 0:
                    p.tangent = -p.tangent
                    p.orientation = -p.orientation
                p.label = "start"
                return doubled, p
    return doubled, None
