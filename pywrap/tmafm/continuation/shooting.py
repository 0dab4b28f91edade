"""Periodic orbits by shooting: the core's stroboscopic map and monodromy matrix
(fortran/src/solve/tmafm_monodromy.f90), Newton's method on P^n(x) = x by multiple shooting (one
drive period per segment), and the Floquet multipliers (docs/continuation.md).  No physics is
computed here: every state and every Jacobian comes from the core."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._fortran import api as _api
from .._model import Model
from .._namelist import _NOT_NUMBERS, shown
from .._run import Config
from ..errors import InputError, InputTypeError, SolverError, raise_for
from .periodic_schur import product_eigenvalues

__all__ = ["periodic_map", "periodic_orbit", "floquet_multipliers", "map_size", "map_period", "jacobian",
           "MapResult", "Orbit", "STAT_NAMES"]

#: The statistics of one map, in the core's order (tmafm_monodromy stat_*).
STAT_NAMES = ("contacts", "gap_min", "gap_max", "flight_gap_min", "contact_time",
              "switch_rate_min", "contact_steps", "evaluations")

#: The default relative tolerance of the integrated phases (contact; under 'dmt_vdw' the flights
#: too; the other laws' free flights are exact).
DEFAULT_RTOL = 1e-11


class MapResult(NamedTuple):
    """y = P^n(y0), its Jacobian (the monodromy matrix) and the orbit's statistics."""

    y: np.ndarray
    monodromy: np.ndarray
    stats: dict


class Orbit(NamedTuple):
    """A periodic orbit: its section points (period x map_size, at tau = 0, T, ..., (n-1)T), the
    Floquet multipliers (largest modulus first), stable, and the statistics over the n periods."""

    states: np.ndarray
    multipliers: np.ndarray
    stable: bool
    stats: dict
    iterations: int
    residual: float


def _model(base) -> Model:
    if isinstance(base, Model):
        return base
    if isinstance(base, Config):
        return Model(base)
    return Model(Config(base))


def _positive_int(name: str, value, upper: int | None = None) -> int:
    if isinstance(value, _NOT_NUMBERS) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InputTypeError(f"{name} = {shown(value)}: must be a positive integer")
    if upper is not None and value > upper:
        raise InputError(f"{name} = {value}: must be at most {upper}")
    return int(value)


def _tolerance(name: str, value, low: float, high: float) -> float:
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise InputTypeError(f"{name} = {shown(value)}: must be a number")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise InputTypeError(f"{name} = {shown(value)}: must be a number") from None
    if not (low <= x <= high):
        raise InputError(f"{name} = {shown(value)}: must be in [{low:g}, {high:g}]")
    return x


def map_size(model) -> int:
    """The length of the map's state: 2N, (a, adot); 2N + 1, (a, adot, w), with a viscoelastic
    sample (w its dashpot coordinate, docs/model.md section 14)."""
    return int(_api.orbit_state_size(_model(model)._f))


def map_period(model) -> float:
    """The map's period in units of tau: 2 pi/Omega, or with two tones (or a drive phase) the
    drive's common period 2 pi/Omega_0 (docs/model.md, "The multifrequency drive")."""
    return float(_api.orbit_period(_model(model)._f))


def jacobian(model, tau: float, y, in_contact: bool) -> np.ndarray:
    """The core's Jacobian of the time derivative (tmafm_model_jacobian) at (tau, y) in a phase:
    what the variational equations integrate; y and the matrix have map_size(model) rows."""
    model = _model(model)
    m = map_size(model)
    y = _state("y", y, m)
    if not isinstance(in_contact, (bool, np.bool_)):
        raise InputTypeError(f"in_contact = {shown(in_contact)}: must be True or False")
    jac = np.zeros((m, m), order="F")
    ierr, errmsg = _api.jacobian_of(model._f, float(tau), np.asfortranarray(y), bool(in_contact), jac)
    raise_for(ierr, _text(errmsg))
    return jac.copy()


def _state(name: str, value, size: int) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name} must be real numbers, got {shown(value)}") from None
    if array.shape != (size,):
        raise InputError(f"{name} must have shape ({size},) = (a, adot{'' if size % 2 == 0 else ', w'}), "
                         f"got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise InputError(f"{name} must be finite, got {shown(value)}")
    return array


def periodic_map(model, y0, n_periods: int = 1, rtol: float = DEFAULT_RTOL) -> MapResult:
    """P^n(y0) over n_periods drive periods (map_period each) from tau = 0, its monodromy matrix
    dP^n/dy0 (from the variational equations and the saltation matrices), and the orbit's
    statistics.  y0 has map_size(model) components."""
    model = _model(model)
    m = map_size(model)
    y0 = _state("y0", y0, m)
    n_periods = _positive_int("n_periods", n_periods, 100000)
    rtol = _tolerance("rtol", rtol, 1e-14, 1e-3)
    y = np.zeros(m, order="F")
    mono = np.zeros((m, m), order="F")
    stats = np.zeros(int(_api.orbit_stat_count()), order="F")
    ierr, errmsg = _api.periodic_map_of(model._f, np.asfortranarray(y0), n_periods, rtol, y, mono,
                                        stats)
    raise_for(ierr, _text(errmsg))
    out = dict(zip(STAT_NAMES, (float(v) for v in stats)))
    for name in ("flight_gap_min", "switch_rate_min"):
        if out[name] >= 0.5 * np.finfo(float).max:
            out[name] = math.nan
    out["contacts"] = int(out["contacts"])
    return MapResult(y.copy(), mono.copy(), out)


def _text(errmsg) -> str:
    if isinstance(errmsg, bytes):
        errmsg = errmsg.decode("utf-8", "replace")
    return str(errmsg).strip()


def floquet_multipliers(monodromies) -> np.ndarray:
    """The Floquet multipliers of an orbit from the monodromy matrices of its segments (in
    order, M_1 first): the eigenvalues of M_n ... M_1, largest modulus first.  One segment: the
    eigenvalues of M_1.  Several: the periodic Schur decomposition of the segments
    (periodic_schur.product_eigenvalues), which never forms the product, so multipliers many
    decades below the largest keep their accuracy (docs/continuation.md, section 4)."""
    factors = _monodromy_list(monodromies)
    if len(factors) == 1:
        mu = np.linalg.eigvals(factors[0])
    else:
        mu = product_eigenvalues(factors)
    order = np.lexsort((-mu.imag, -np.abs(mu)))
    return mu[order]


def _monodromy_list(monodromies) -> list[np.ndarray]:
    """The segments' monodromy matrices as real square arrays of one size, or InputError."""
    if isinstance(monodromies, np.ndarray) and monodromies.ndim == 2:
        raise InputError(f"monodromies must be a sequence of square matrices (one per segment), "
                         f"got one array of shape {monodromies.shape}")
    try:
        items = list(monodromies)
    except TypeError:
        raise InputError(f"monodromies must be a sequence of square matrices, got "
                         f"{shown(monodromies)}") from None
    if not items:
        raise InputError("monodromies must hold at least one matrix, got none")
    factors = []
    for i, item in enumerate(items):
        if np.iscomplexobj(item):
            raise InputError(f"monodromies[{i}] must be real, got complex values")
        try:
            a = np.asarray(item, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise InputError(f"monodromies[{i}] must be real numbers, got {shown(item)}") from None
        if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
            raise InputError(f"monodromies[{i}] must be a non-empty square matrix, got shape "
                             f"{a.shape}")
        if factors and a.shape != factors[0].shape:
            raise InputError(f"monodromies[{i}] has shape {a.shape}, monodromies[0] "
                             f"{factors[0].shape}: all segments must have the same size")
        if not np.all(np.isfinite(a)):
            raise InputError(f"monodromies[{i}] must be finite, got a non-finite entry")
        factors.append(a)
    return factors


def _segments(model: Model, states: np.ndarray, rtol: float) -> list[MapResult]:
    return [periodic_map(model, x, 1, rtol) for x in states]


def _residual(maps: list[MapResult], states: np.ndarray) -> np.ndarray:
    n = len(states)
    return np.concatenate([maps[i].y - states[(i + 1) % n] for i in range(n)])


def _jacobian(maps: list[MapResult]) -> np.ndarray:
    """dR/dX of R_i = P(x_i) - x_(i+1) (cyclic): M_i on the diagonal, -I one block right."""
    n = len(maps)
    m = maps[0].monodromy.shape[0]
    jac = np.zeros((n * m, n * m))
    for i in range(n):
        jac[i * m:(i + 1) * m, i * m:(i + 1) * m] = maps[i].monodromy
        j = (i + 1) % n
        jac[i * m:(i + 1) * m, j * m:(j + 1) * m] -= np.eye(m)
    return jac


def _merge_stats(maps: list[MapResult]) -> dict:
    stats = {}
    for name in STAT_NAMES:
        values = [mp.stats[name] for mp in maps]
        if name in ("gap_min", "flight_gap_min", "switch_rate_min"):
            finite = [v for v in values if not math.isnan(v)]
            stats[name] = min(finite) if finite else math.nan
        elif name == "gap_max":
            stats[name] = max(values)
        else:
            stats[name] = sum(values)
    stats["contacts"] = int(stats["contacts"])
    return stats


def state_scale(model: Model, states: np.ndarray) -> float:
    """The size against which states are measured: the largest |component|, or the drive
    amplitude alpha2 when that is larger."""
    return max(float(np.max(np.abs(states))), abs(float(model.scene["alpha2"])), 1e-300)


def periodic_orbit(base, y0, *, period: int = 1, rtol: float = DEFAULT_RTOL, tol: float = 1e-10,
                   max_iter: int = 40) -> Orbit:
    """Newton's method on P^period(x) = x by multiple shooting (one drive period per segment),
    from y0: one state (the others are its images) or `period` states.  Converged when the
    relative residual and Newton step are below tol (relative to the state's scale)."""
    model = _model(base)
    m = map_size(model)
    period = _positive_int("period", period, 64)
    rtol = _tolerance("rtol", rtol, 1e-14, 1e-3)
    tol = _tolerance("tol", tol, 1e-14, 1e-2)
    max_iter = _positive_int("max_iter", max_iter, 1000)
    guess = np.asarray(y0, dtype=float)
    if guess.ndim == 1:
        first = _state("y0", guess, m)
        states = [first]
        for _ in range(period - 1):
            states.append(periodic_map(model, states[-1], 1, rtol).y)
        states = np.array(states)
    else:
        if guess.shape != (period, m):
            raise InputError(f"y0 must have shape ({m},) or ({period}, {m}), got {guess.shape}")
        states = np.array([_state("y0", row, m) for row in guess])
    scale = state_scale(model, states)
    for iteration in range(1, max_iter + 1):
        maps = _segments(model, states, rtol)
        res = _residual(maps, states)
        step = np.linalg.solve(_jacobian(maps), -res)
        states = states + step.reshape(period, m)
        if np.max(np.abs(step)) <= tol * scale and np.max(np.abs(res)) <= 10 * tol * scale:
            maps = _segments(model, states, rtol)
            res = _residual(maps, states)
            mu = floquet_multipliers([mp.monodromy for mp in maps])
            return Orbit(states, mu, bool(np.max(np.abs(mu)) < 1), _merge_stats(maps), iteration,
                         float(np.max(np.abs(res)) / scale))
    raise SolverError(f"periodic_orbit: Newton did not converge in {max_iter} iterations "
                      f"(relative residual {np.max(np.abs(res)) / scale:.3g}, period {period})")
