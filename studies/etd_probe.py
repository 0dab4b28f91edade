"""Would an exponential collocation (ETD) method cut the contact steps?  A measured probe.

    /opt/tmafm-venv/bin/python studies/etd_probe.py [--out DIR] [--scenes fig2 ...]  # ~6 min CPU
    /opt/tmafm-venv/bin/python studies/etd_probe.py --table studies/results/etd_probe.json [--out DIR]

A study for docs/performance.md (section "An exponential collocation probe (not built)"), not a
method of tmafm.  The contacts are those of studies/lawson_probe.py: for each scene (Fig. 2
with N = 4, and tilted_hertz_3 of benchmarks/period_cost.py), the first contact after 60 % of a
30-period flight_exact run at rtol 1e-12; the inner interval runs from the second output sample
after the entry to the second before the exit (samples every 0.01): the kinks stay outside.

The contact right-hand side is split as y' = A y + N(tau, y): A the free flight's matrix (from
tmafm.Model.matrices: the linear part flight_exact solves exactly), N = f - A y (the drive and
the contact force; N's displacement half is zero).  Methods, on uniform steps (STEPS, RK_STEPS):
  dop853   the DOP853 tableau (scipy's coefficients), plain: 12 right-hand sides per step;
  lawson   the same tableau on v = exp(-A (tau - tau_n)) y (integrating factor);
  etd_*    exponential collocation on s nodes c_i (Gauss-Legendre, or Lobatto with its first
           node's N from the previous step): Y_i = exp(c_i h A) y_n + h sum_j a_ij(hA) N_j,
           y_n+1 = exp(hA) y_n + h sum_j b_j(hA) N_j, a_ij and b_j the exact integrals of
           exp((c_i - sigma) h A) times the Lagrange polynomials, from phi_k = the top row of one
           expm of an augmented block matrix (not counted; etd_side_madds says what computing
           them per step length would cost).  The stages start from the previous step's last N
           (PREDICTOR) and are solved by sweeps of
             picard       Y <- the formula with N at the last Y;
             newton       simplified Newton, the Jacobian of N at (tau_n, y_n);
             stagenewton  simplified Newton, each stage's Jacobian at its predicted value;
             fullnewton   each stage's Jacobian at its latest value, every sweep;
           the Jacobians cut to rank r (1: N depends on y through V_T and its rate), solved
           densely here and counted as Woodbury's (s r) x (s r) system.  Sweeps run to
           |increment| <= 0.01 x the error the same run reaches converged (to 1e-15 or round-off),
           or, for the _xK variants, exactly K sweeps per step (an explicit method).
Work: right-hand sides (N evaluations, and each Jacobian counted as one: an analytic Jacobian of
the contact force costs about one), and "equivalents", which add each method's own linear
algebra in multiply-adds, in the modal (2 x 2 block) form a real code would use (etd_madds,
rk_madds), at MADDS_PER_RHS multiply-adds per right-hand side.
Errors at the interval's end: "error", max over components of |y - y_ref| / scale, scale = the
component's largest size over the run's second half (lawson_probe.py's measure), and
"vt_error", |p.(a - a_ref)| / S_V, S_V the largest |V_T| over the run's second half; y_ref from
dop853 on REF_STEPS uniform steps, checked against 256 steps, etd on 64 and the run's sample.

tmafm's own steps: flight_exact at rtol 1e-7/atol 1e-10 and 1e-10/1e-14, stopped by its step
budget (&solver max_steps) one unit at a time; the stopping times are its steps' starts
(real_steps), so the steps inside the inner interval are counted, and the DOP853 tableau is run
on them.  tmafm_whole runs flight_exact through the contact alone (from the exact flight state at
the period boundary before it) for its counters and its error after the exit.

Whole contact: from the entry tau_e (the exact flight, expm of the affine system with the
drive, to V_T = 0) to the exit tau_x (scipy DOP853 at rtol 1e-13 with an event; the methods are
given tau_x), on uniform steps and on steps graded as tau = tau_e + L w(u),
w(u) = u^q / (u^q + (1 - u)^q), q = 2, 3 (q = 2: like tmafm's warp tau_e + sigma^2, at both ends).
Writes etd_probe.json and etd_probe.png into --out (default studies/results/) and prints the tables.
"""

import argparse
import json
import math
import re
import sys
from pathlib import Path

import numpy as np
from numpy.polynomial import legendre
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import tmafm

# The Lawson probe's tableau, scenes and contacts (studies/ is the script's own folder).
from lawson_probe import A_STAGE, B_WEIGHT, NODES, PERIOD, SCENES, reference_contact  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
#: the reference's uniform dop853 steps: 256 and 512 agree to 9e-14 of the scale and 1.1e-14 of
#: S_V (the JSON's reference_vs_dop853_256); 2048 adds round-off (5e-13 from 1024)
REF_STEPS = 512
#: print every sweep's increment (a debugging aid)
TRACE = False
#: the degree of the extrapolation that predicts a step's N from the previous step's: 0, its last
#: N (higher degrees took more sweeps in a trial)
PREDICTOR = 0
STEPS = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)
RK_STEPS = STEPS + (96, 128, 192)
#: multiply-adds per right-hand side, by N: a contact right-hand side costs 335 (N = 4) and 299
#: (N = 3) instructions (benchmarks/results/rhs_instructions.json, contact_at_phase), and dop853's stage
#: algebra 1997 and 1681 instructions per step tried on Fig. 2 and the tilted scene for 816 and
#: 612 multiply-adds (benchmarks/stage_cost.py on main df69127): 2.45 and 2.75 instructions each
MADDS_PER_RHS = {4: 335 / (1997 / 816), 3: 299 / (1681 / 612)}
#: (family, s, solver, Jacobian rank, fixed sweeps per step or None: to convergence)
ETD_VARIANTS = (("gauss", 4, "stagenewton", 1, None), ("gauss", 5, "stagenewton", 1, None),
                ("gauss", 6, "stagenewton", 1, None), ("gauss", 8, "stagenewton", 1, None),
                ("lobatto", 5, "stagenewton", 1, None), ("lobatto", 7, "stagenewton", 1, None),
                ("gauss", 6, "fullnewton", 1, None), ("gauss", 6, "newton", 1, None),
                ("gauss", 6, "picard", 0, None),
                ("gauss", 3, "stagenewton", 1, 2), ("gauss", 4, "stagenewton", 1, 3),
                ("gauss", 5, "stagenewton", 1, 3), ("gauss", 6, "stagenewton", 1, 2),
                ("gauss", 6, "stagenewton", 1, 3), ("gauss", 3, "picard", 0, 4),
                ("gauss", 6, "picard", 0, 5))
WHOLE_VARIANTS = (("gauss", 6, "stagenewton", 1, None), ("gauss", 6, "stagenewton", 1, 3),
                  ("gauss", 5, "stagenewton", 1, 3))


# ---------------------------------------------------------------- the split y' = A y + N
class Split:
    """The contact right-hand side as A y + N(tau, y), with evaluation counts."""

    def __init__(self, model):
        n = model.n_modes
        self.model, self.n = model, n
        mass, damping, stiffness, _ = model.matrices(0.0, np.zeros(n), False)
        self.A = np.block([[np.zeros((n, n)), np.eye(n)],
                           [-np.linalg.solve(mass, stiffness), -np.linalg.solve(mass, damping)]])
        y = np.linspace(0.3, -0.2, 2 * n) * 1e-3
        free = model.derivative(0.7, y, False) - model.derivative(0.7, np.zeros(2 * n), False)
        assert np.allclose(free, self.A @ y, rtol=1e-12, atol=1e-18), "free flight is not A y + b"
        self.evals = 0

    def N(self, tau, y):
        self.evals += 1
        return self.model.derivative(tau, y, True) - self.A @ y

    def f(self, tau, y):
        self.evals += 1
        return self.model.derivative(tau, y, True)

    def jacobian(self, tau, y, scale):
        """dN/dy at (tau, y) by central differences (not counted here: see the caller)."""
        m = 2 * self.n
        jac = np.zeros((m, m))
        for k in range(m):
            e = np.zeros(m)
            e[k] = 1e-6 * scale[k]
            jac[:, k] = (self.model.derivative(tau, y + e, True) - self.A @ (y + e)
                         - self.model.derivative(tau, y - e, True) + self.A @ (y - e)) / (2 * e[k])
        return jac


# ---------------------------------------------------------------- exponential collocation
def phi_top_row(Z, p):
    """[exp(Z), phi_1(Z), ..., phi_p(Z)] from one expm of the augmented block matrix."""
    m = Z.shape[0]
    big = np.zeros((m * (p + 1), m * (p + 1)))
    big[:m, :m] = Z
    for k in range(p):
        big[k * m:(k + 1) * m, (k + 1) * m:(k + 2) * m] = np.eye(m)
    ex = expm(big)
    return [ex[:m, k * m:(k + 1) * m] for k in range(p + 1)]


def nodes_of(family, s):
    if family == "gauss":
        x = legendre.leggauss(s)[0]
    elif family == "lobatto":
        inner = legendre.Legendre.basis(s - 1).deriv().roots() if s > 2 else np.array([])
        x = np.concatenate([[-1.0], np.sort(inner.real), [1.0]])
    else:
        raise ValueError(family)
    return (x + 1) / 2


class Collocation:
    """Coefficients E_i = exp(c_i hA), a_ij(hA), E = exp(hA), b_j(hA) for one step length."""

    def __init__(self, nodes, A, h):
        s, m = len(nodes), A.shape[0]
        self.c, self.s, self.h = nodes, s, h
        lag = np.linalg.inv(np.vander(nodes, s, increasing=True).T)  # l_j(x) = sum_k lag[j,k] x^k
        self.lag = lag
        fact = np.array([math.factorial(k) for k in range(s)])
        self.E = np.zeros((s, m, m))
        self.a = np.zeros((s, s, m, m))
        for i, c in enumerate(nodes):
            if c == 0.0:
                self.E[i] = np.eye(m)
                continue
            ph = phi_top_row(c * h * A, s)
            self.E[i] = ph[0]
            for j in range(s):
                self.a[i, j] = sum(lag[j, k] * c ** (k + 1) * fact[k] * ph[k + 1] for k in range(s))
        ph = phi_top_row(h * A, s)
        self.E_end = ph[0]
        self.b = np.array([sum(lag[j, k] * fact[k] * ph[k + 1] for k in range(s)) for j in range(s)])

    def stages(self, y, Nk):
        """Y_i = E_i y + h sum_j a_ij N_j."""
        return np.einsum("imn,n->im", self.E, y) + self.h * np.einsum("ijmn,jn->im", self.a, Nk)

    def extrapolate(self, Nk, degree):
        """The previous step's N, extrapolated to the next step's nodes 1 + c_j by the polynomial
        of the given degree through its last degree + 1 nodes."""
        nodes = self.c[self.s - degree - 1:]
        lag = np.linalg.inv(np.vander(nodes, degree + 1, increasing=True).T)
        powers = np.vander(1.0 + self.c, degree + 1, increasing=True)
        return powers @ lag @ Nk[self.s - degree - 1:]


def etd_madds(n, s, first_fixed, solver, rank):
    """Multiply-adds of one step (its fixed part) and of one sweep, in the modal form a real
    code would use: exp(c h A), a_ij and b_j block-diagonal in 2 x 2 blocks (4 per mode), N (n
    non-zeros) turned into modal coordinates (2n x n), each stage turned back (2n x 2n) to
    evaluate N; Newton on rank-r Jacobians J_j = U_j W_j^T by Woodbury: set-up (U_j turned, the
    blocks h a_ij U_j, W_i^T times them, an LU of (live r)^2) and per sweep W^T R, the small
    solve and the correction."""
    live = s - 1 if first_fixed else s
    step = s * 4 * n + 4 * n + s * 4 * n
    sweep = live * (s * 4 * n + 2 * n * n + 4 * n * n)
    if solver != "picard":
        r = rank
        setup = (live * 2 * n * n * r + live * r * 4 * n * n + live * live * 4 * n * r
                 + live * live * r * 2 * n * r + (live * r) ** 3 // 3)
        sweep += live * r * 2 * n + (live * r) ** 2 + live * live * 2 * n * r
        if solver == "fullnewton":
            sweep += setup
        else:
            step += setup
    return step, sweep


def low_rank(jac, rank):
    u, sv, vt = np.linalg.svd(jac)
    return (u[:, :rank] * sv[:rank]) @ vt[:rank]


def newton_matrix(co, jacs):
    """I - h [a_ij(hA) J_j]: the stage equations' Newton matrix (solved densely here; a real code
    would use Woodbury on the rank-r Jacobians, as etd_madds counts)."""
    s, m = co.s, jacs[0].shape[0]
    big = np.eye(s * m)
    for i in range(s):
        for j in range(s):
            big[i * m:(i + 1) * m, j * m:(j + 1) * m] -= co.h * co.a[i, j] @ jacs[j]
    return big


def etd_run(split, family, s, solver, rank, y0, t0, t1, nsteps, scale, tol, taus=None, fixed=None):
    """One run of exponential collocation; returns (y_end, N evaluations, Jacobians, sweeps), or
    None if the iteration diverges.  fixed: exactly that many sweeps per step (an explicit
    method), instead of sweeps to the tolerance tol."""
    taus = np.linspace(t0, t1, nsteps + 1) if taus is None else taus
    nodes = nodes_of(family, s)
    first_fixed = family == "lobatto"
    split.evals = 0
    y, prev, prev_h, coll_cache = y0.copy(), None, None, {}
    sweeps = jacs = 0
    m = len(y0)
    for n_step in range(len(taus) - 1):
        t, h = taus[n_step], taus[n_step + 1] - taus[n_step]
        key = round(h, 15)
        if key not in coll_cache:
            coll_cache = {key: Collocation(nodes, split.A, h)}
        co = coll_cache[key]
        if prev is None:
            Nk = np.tile(split.N(t, y), (s, 1))
        else:
            Nk = co.extrapolate(prev, PREDICTOR) if co.h == prev_h else np.tile(prev[-1], (s, 1))
            if first_fixed:
                Nk[0] = prev[-1]
        Y = co.stages(y, Nk)
        if solver == "newton":  # simplified: one Jacobian, at (tau_n, y_n)
            jac_r = [low_rank(split.jacobian(t, y, scale), rank)] * s
            jacs += 1
            big = newton_matrix(co, jac_r)
        elif solver == "stagenewton":  # simplified: each stage's Jacobian at its predicted value
            jac_r = [low_rank(split.jacobian(t + co.c[j] * h, Y[j], scale), rank)
                     if not (first_fixed and j == 0) else np.zeros((m, m)) for j in range(s)]
            jacs += s - 1 if first_fixed else s
            big = newton_matrix(co, jac_r)
        last_change = math.inf
        for sweep in range(1, 200):
            for j in range(s):
                if not (first_fixed and j == 0):
                    Nk[j] = split.N(t + co.c[j] * h, Y[j])
            target = co.stages(y, Nk)
            if solver == "fullnewton":  # each stage's Jacobian at its latest iterate
                jac_r = [low_rank(split.jacobian(t + co.c[j] * h, Y[j], scale), rank)
                         if not (first_fixed and j == 0) else np.zeros((m, m)) for j in range(s)]
                jacs += s - 1 if first_fixed else s
                big = newton_matrix(co, jac_r)
            if solver != "picard":
                delta = np.linalg.solve(big, (target - Y).ravel()).reshape(s, m)
            else:
                delta = target - Y
            Y = Y + delta
            step_change = np.max(np.abs(delta) / scale)
            if TRACE:
                print(f"    step {n_step} sweep {sweep}: {step_change:.2e}", file=sys.stderr)
            if not np.isfinite(step_change) or step_change > 1e3:
                return None
            if fixed is not None:
                if sweep == fixed:
                    break
                continue
            if step_change <= tol:
                break
            # round-off: an increment below 1e-12 that no longer falls to a third has converged
            if sweep > 1 and step_change < 1e-12 and step_change > last_change / 3:
                break
            last_change = step_change
        else:
            return None
        sweeps += sweep
        y = co.E_end @ y + co.h * np.einsum("jmn,jn->m", co.b, Nk)
        prev, prev_h = Nk.copy(), co.h  # Lobatto: prev[-1] is N at the step's end (FSAL)
    return y, split.evals, jacs, sweeps


# ---------------------------------------------------------------- dop853 and Lawson, uniform
def rk_run(split, y0, taus, lawson):
    """The DOP853 tableau on given steps (plain or Lawson); returns (y_end, right-hand sides)."""
    split.evals = 0
    y = y0.copy()
    cache = {}
    for t, t_next in zip(taus[:-1], taus[1:]):
        h = t_next - t
        k = np.zeros((12, len(y)))
        if lawson:
            key = round(h, 15)
            if key not in cache:
                turn = [expm(split.A * c * h) for c in NODES]
                cache = {key: (turn, [np.linalg.inv(mt) for mt in turn], expm(split.A * h))}
            turn, back, end = cache[key]

            def g(i, v):
                yy = turn[i] @ v
                return back[i] @ split.N(t + NODES[i] * h, yy)
        else:
            def g(i, v):
                return split.f(t + NODES[i] * h, v)
        try:
            k[0] = g(0, y)
            for st in range(1, 12):
                k[st] = g(st, y + h * (k[:st].T @ A_STAGE[st, :st]))
        except tmafm.InputError:  # a non-finite stage: the step is beyond the stability limit
            return None, 0
        y = y + h * (k.T @ B_WEIGHT)
        if lawson:
            y = end @ y
        if not np.all(np.isfinite(y)) or np.max(np.abs(y)) > 1.0:
            return None, 0
    steps = len(taus) - 1
    return y, 12 * steps + 1  # 12 per step with FSAL, the first step's f(y0) once


def rk_madds(n, lawson, estimates=False):
    """dop853's stage algebra per step (66 stage sums and the solution; with estimates, its two
    error estimates too, as in tmafm's adaptive steps), Lawson's turns (modal 2 x 2 blocks)."""
    m = 2 * n
    base = (66 + 12 + (24 if estimates else 0)) * m
    return base + (12 * 2 * 4 * n if lawson else 0)


def etd_side_madds(n, s):
    """Multiply-adds the probe leaves out, per mode pair in complex arithmetic (4 real each):
    the weights a_ij, b_j of one step length from phi_0..phi_s at the s + 1 points c_i h
    (s (s + 1) phi-sums of s terms each), and one dense-output sample: the weights at its
    fraction (s sums of s terms) and their product with the N_j (s + 1 terms); both besides
    n (s + 1) or n complex exponentials."""
    table = n * 4 * (s + 1) * s * s
    sample = n * 4 * (s * s + s + 1)
    return table, sample


# ---------------------------------------------------------------- the scenes
def graded(t0, t1, nsteps, q):
    u = np.linspace(0.0, 1.0, nsteps + 1)
    w = u ** q / (u ** q + (1 - u) ** q)
    return t0 + (t1 - t0) * w


def budget_tau(overrides, budget, t_end, rtol, atol):
    """The tau at which a flight_exact run runs out of a work budget of &solver max_steps (from
    its one-line error message; 7 digits), or t_end if it does not."""
    cfg = tmafm.Config("fig2_n4", **overrides,
                       solver={"method": "flight_exact", "tau_end": float(t_end), "rtol": rtol,
                               "atol": atol, "max_steps": int(budget)}, output={"sample_dtau": 0.5})
    try:
        tmafm.run(cfg)
    except tmafm.SolverError as exc:
        return float(re.search(r"spent at tau = *([-+.0-9Ee]+)", str(exc)).group(1))
    return float(t_end)


def real_steps(overrides, tau_e, tau_x, rtol, atol):
    """The starts of tmafm's own contact steps in [tau_e, tau_x): flight_exact at (rtol, atol)
    stopped by its step budget one unit at a time (each step tried, event iteration and flight
    costs a unit, charged at the step's start), so the distinct stopping times are the steps'
    starts (rejected steps and event iterations repeat a start)."""
    lo, hi = 1, 10 ** 6
    while hi - lo > 1:  # the first budget that stops at or after the entry
        mid = (lo + hi) // 2
        if budget_tau(overrides, mid, tau_x + 1.0, rtol, atol) >= tau_e - 1e-5:
            hi = mid
        else:
            lo = mid
    starts, budget = [], hi
    while True:
        tau = budget_tau(overrides, budget, tau_x + 1.0, rtol, atol)
        if tau >= tau_x - 1e-5:
            break
        if not starts or tau > starts[-1]:
            starts.append(tau)
        budget += 1
    return starts


def steps_within(starts, end, t0, t1):
    """Steps (fractional, by overlap) of the step pattern [starts..., end] inside [t0, t1]."""
    edges = list(starts) + [end]
    return sum(max(0.0, min(b, t1) - max(a, t0)) / (b - a) for a, b in zip(edges, edges[1:]))


def prepare(name, overrides):
    run, model, states, scale, first, last = reference_contact(overrides)
    return run, model, Split(model), states, scale, first, last


def vt_of(model):
    sc = model.scene
    p = model.tip
    omega, alpha2, offset = sc["omega"], sc["alpha2"], sc.get("delta_hat", 0.0)
    n = model.n_modes
    return lambda tau, y: p @ y[:n] + alpha2 * math.sin(omega * tau) + offset


def flight_of(model, split):
    """The exact free flight: flight(ys, ts, tau) = y(tau) from y(ts) = ys, by expm of the affine
    system in (y, sin, cos) (the drive is u sin(Omega tau) + v cos(Omega tau))."""
    m = 2 * model.n_modes
    omega = model.scene["omega"]
    b0 = model.derivative(0.0, np.zeros(m), False)                      # v
    b1 = model.derivative(math.pi / (2 * omega), np.zeros(m), False)     # u
    aug = np.zeros((m + 2, m + 2))
    aug[:m, :m] = split.A
    aug[:m, m], aug[:m, m + 1] = b1, b0
    aug[m, m + 1], aug[m + 1, m] = omega, -omega                       # (sin, cos)' = (O cos, -O sin)

    def flight(ys, ts, tau):
        z = np.concatenate([ys, [math.sin(omega * ts), math.cos(omega * ts)]])
        return (expm(aug * (tau - ts)) @ z)[:m]
    return flight


def entry_exit(model, split, ys, ts, t_in, scale):
    """From a flight state ys at ts: the entry (exact flight to V_T = 0, bisection below t_in, a
    time in contact) and the exit (scipy DOP853 at rtol 1e-13 with an event)."""
    vt = vt_of(model)
    flight = flight_of(model, split)
    lo, hi = ts, t_in
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if vt(mid, flight(ys, ts, mid)) > 0:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-16:
            break
    tau_e = hi
    y_e = flight(ys, ts, tau_e)

    def rhs(tau, y):
        return model.derivative(tau, y, True)

    def leave(tau, y):
        return vt(tau, y)
    leave.terminal, leave.direction = True, 1
    sol = solve_ivp(rhs, (tau_e, tau_e + 2.0), y_e, method="DOP853", rtol=1e-13,
                    atol=1e-17 * np.maximum(scale, 1e-3), events=leave, first_step=1e-6)
    tau_x = float(sol.t_events[0][0])
    return tau_e, y_e, tau_x, sol.y_events[0][0], vt(tau_e, y_e)


def tmafm_whole(model, split, overrides, run, states, first, scale, rtol, atol):
    """tmafm's flight_exact through the whole contact alone: started (tau = 0) from the exact
    flight state at tau_k = k pi, the last multiple of the drive period before the entry (the
    drive's phase there is that of tau = 0), run to 0.05 past the exit (in flight, exact); its
    end state against the reference: exact flight, scipy DOP853 at rtol 1e-13 through the
    contact, exact flight.  Returns the counters and the end errors (state, V_T)."""
    n = model.n_modes
    flight = flight_of(model, split)
    tau_k = math.floor(run.tau[first] / PERIOD) * PERIOD
    i = int(np.searchsorted(run.tau, tau_k)) - 1
    assert not run.contact[i:first].any(), "the state before the contact is not in flight"
    y_k = flight(states[i], run.tau[i], tau_k)
    tau_e, _, tau_x, y_x, _ = entry_exit(model, split, y_k, tau_k, run.tau[first], scale)
    t_end = tau_x + 0.05
    ref = flight(y_x, tau_x, t_end)
    cfg = tmafm.Config("fig2_n4", **{**overrides, "initial": {"a0": y_k[:n].tolist(), "adot0": y_k[n:].tolist()}},
                       solver={"method": "flight_exact", "tau_end": t_end - tau_k, "rtol": rtol, "atol": atol},
                       output={"sample_dtau": (t_end - tau_k) / 4})
    out = tmafm.run(cfg)
    assert abs(out.tau[-1] - (t_end - tau_k)) < 1e-12
    y = np.concatenate([out.a[-1], out.adot[-1]])
    return dict(out.counters), y, ref


def interpolate_work(points, target):
    """The least work at which a work-precision curve reaches an error: log-log interpolation
    between its points (the least work of any point at or below the target bounds it); None
    if no point reaches the target."""
    pts = sorted((w, e) for w, e in points if e is not None and e > 0)
    best = None
    for w, e in pts:
        if e <= target:
            best = w if best is None else min(best, w)
    for (w1, e1), (w2, e2) in zip(pts, pts[1:]):
        if e1 > target >= e2:
            x = (math.log(e1) - math.log(target)) / (math.log(e1) - math.log(e2))
            w = math.exp(math.log(w1) + x * (math.log(w2) - math.log(w1)))
            best = w if best is None else min(best, w)
    return best


def measures(y, ref, scale, tip, s_v):
    n = len(tip)
    return {"error": float(np.max(np.abs(y - ref) / scale)),
            "vt_error": float(abs(tip @ (y[:n] - ref[:n])) / s_v)}


def study(name, overrides):
    run, model, split, states, scale, first, last = prepare(name, overrides)
    n = model.n_modes
    t0, t1 = float(run.tau[first + 2]), float(run.tau[last - 2])
    y0 = states[first + 2]
    vt = vt_of(model)
    half = len(states) // 2
    s_v = max(abs(vt(tau, y)) for tau, y in zip(run.tau[half:], states[half:]))
    tip = model.tip
    print(f"{name}: inner interval {t0:.4f} .. {t1:.4f} ({t1 - t0:.3f})", file=sys.stderr)
    ref = rk_run(split, y0, np.linspace(t0, t1, REF_STEPS + 1), False)[0]
    res = {"scene": name, "n_modes": n, "t0": t0, "t1": t1, "scale": scale.tolist(), "s_v": s_v,
           "largest_eigenvalue_free": float(np.max(np.abs(np.linalg.eigvals(split.A))))}

    def err(y):
        return measures(y, ref, scale, tip, s_v)

    res["reference_vs_dop853_256"] = err(rk_run(split, y0, np.linspace(t0, t1, 257), False)[0])
    res["reference_vs_etd64"] = err(etd_run(split, "gauss", 6, "stagenewton", 1, y0, t0, t1, 64,
                                            scale, 1e-16)[0])
    res["reference_vs_run_sample"] = err(states[last - 2])
    jac = split.jacobian(0.5 * (t0 + t1), states[(first + last) // 2], scale)
    res["jacobian_singular_values_scaled"] = np.linalg.svd(
        jac * scale[None, :] / scale[:, None], compute_uv=False).tolist()

    # tmafm's own contact steps, and the DOP853 tableau on them over the inner interval
    tau_e, y_e, tau_x, y_x, vt_e = entry_exit(model, split, states[first - 1], run.tau[first - 1],
                                              run.tau[first], scale)
    res["entry"], res["exit"], res["entry_vt"] = tau_e, tau_x, vt_e
    res["real"] = {}
    for rtol, atol in ((1e-7, 1e-10), (1e-10, 1e-14)):
        starts = real_steps(overrides, tau_e, tau_x, rtol, atol)
        inner = steps_within(starts, tau_x, t0, t1)
        mesh = np.array([t0] + [t for t in starts if t0 < t < t1] + [t1])
        y, _ = rk_run(split, y0, mesh, False)
        counters, y_run, y_ref = tmafm_whole(model, split, overrides, run, states, first, scale, rtol, atol)
        res["real"][f"{rtol:g}"] = {"starts": starts, "whole_steps": len(starts), "inner_steps": inner,
                                    "rhs": 12 * inner, **err(y),
                                    "whole_run": {"counters": counters,
                                                  **measures(y_run, y_ref, scale, tip, s_v)}}
        print(f"  tmafm rtol {rtol:g}: {len(starts)} contact steps, {inner:.1f} inner; "
              f"dop853 on them: {err(y)}", file=sys.stderr)
    rows = []
    for method in ("dop853", "lawson"):
        for ns in RK_STEPS:
            y, evals = rk_run(split, y0, np.linspace(t0, t1, ns + 1), method == "lawson")
            if y is None:
                rows.append({"method": method, "steps": ns, "error": None, "vt_error": None})
                continue
            madds = ns * rk_madds(n, method == "lawson")
            rows.append({"method": method, "steps": ns, "rhs": evals, "work": evals, **err(y),
                         "equivalents": evals + madds / MADDS_PER_RHS[n]})
    for family, s, solver, rank, fixed in ETD_VARIANTS:
        label = etd_label(family, s, solver, rank, fixed)
        for ns in STEPS:
            full = etd_run(split, family, s, solver, rank, y0, t0, t1, ns, scale, 1e-15, fixed=fixed)
            if full is None:
                rows.append({"method": label, "steps": ns, "error": None, "vt_error": None})
                continue
            e_full = err(full[0])
            out = None
            if fixed is None:  # again, to 0.01 of the error the converged run reaches
                out = etd_run(split, family, s, solver, rank, y0, t0, t1, ns, scale,
                              max(1e-15, 0.01 * min(e_full["error"], e_full["vt_error"])))
            y, evals, jacs, sweeps = out if out is not None else full
            step_madds, sweep_madds = etd_madds(n, s, family == "lobatto", solver, rank)
            madds = ns * step_madds + sweeps * sweep_madds
            rows.append({"method": label, "steps": ns, "rhs": evals, "jacobians": jacs,
                         "sweeps": sweeps, "work": evals + jacs, **err(y),
                         "converged": e_full, "equivalents": evals + jacs + madds / MADDS_PER_RHS[n]})
            print(f"  {label} {ns}: {err(y)} (converged {e_full}), N {evals}, J {jacs}, "
                  f"sweeps/step {sweeps / ns:.2f}", file=sys.stderr)
    res["rows"] = rows

    # the whole contact, entry to exit, on uniform and graded steps
    def err_x(y):
        return measures(y, y_x, scale, tip, s_v)
    wrows = []
    for q in (1, 2, 3):
        for ns in STEPS[3:]:
            taus = graded(tau_e, tau_x, ns, q)
            ends = ns - steps_within(taus[:-1], taus[-1], t0, t1)  # steps outside the inner interval
            y, evals = rk_run(split, y_e, taus, False)
            if y is not None:
                wrows.append({"method": "dop853", "q": q, "steps": ns, "end_steps": ends, "work": evals,
                              "equivalents": evals + ns * rk_madds(n, False) / MADDS_PER_RHS[n], **err_x(y)})
            for family, s, solver, rank, fixed in WHOLE_VARIANTS:
                out = etd_run(split, family, s, solver, rank, y_e, tau_e, tau_x, ns, scale, 1e-14,
                              taus=taus, fixed=fixed)
                if out is not None:
                    step_madds, sweep_madds = etd_madds(n, s, family == "lobatto", solver, rank)
                    wrows.append({"method": etd_label(family, s, solver, rank, fixed), "q": q, "steps": ns,
                                  "end_steps": ends, "work": out[1] + out[2], "sweeps": out[3],
                                  "equivalents": out[1] + out[2] + (ns * step_madds + out[3] * sweep_madds)
                                  / MADDS_PER_RHS[n], **err_x(out[0])})
    res["whole"] = wrows
    return res


def etd_label(family, s, solver, rank, fixed=None):
    return (f"etd_{family}{s}_{solver}" + (f"{rank}" if solver != "picard" else "")
            + (f"_x{fixed}" if fixed else ""))


TARGETS = (("tmafm 1e-7", "1e-07"), ("tmafm 1e-10", "1e-10"), ("1e-10", 1e-10), ("1e-12", 1e-12),
           ("1e-13", 1e-13))


def summarize(results):
    lines = []
    for res in results:
        rows, real = res["rows"], res["real"]
        lines.append(f"\n{res['scene']}: inner {res['t0']:.3f}..{res['t1']:.3f}, contact "
                     f"{res['entry']:.5f}..{res['exit']:.5f}; tmafm's contact steps whole/inner: "
                     + ", ".join(f"rtol {k}: {v['whole_steps']}/{v['inner_steps']:.1f}" for k, v in real.items())
                     + "; reference against dop853 256: {:.1e}, etd 64: {:.1e}, the run's sample: {:.1e}".format(
                         res["reference_vs_dop853_256"]["error"], res["reference_vs_etd64"]["error"],
                         res["reference_vs_run_sample"]["error"]))
        for measure in ("error", "vt_error"):
            targets = []
            for label, t in TARGETS:
                value = real[t][measure] if isinstance(t, str) else t
                targets.append((f"{label} ({value:.1e})", value))
            lines.append(f"{measure}: steps: work (RHS, Newton's Jacobians as one RHS each) / with own "
                         "linear algebra (RHS equivalents): dop853's over this one's, at")
            lines.append("| method | " + " | ".join(lab for lab, _ in targets) + " |")
            lines.append("|---" * (len(targets) + 1) + "|")
            methods = sorted({r["method"] for r in rows}, key=lambda m: (m != "dop853", m != "lawson", m))
            for mth in methods:
                cells = []
                for _, target in targets:
                    w = interpolate_work([(r.get("work"), r[measure]) for r in rows if r["method"] == mth], target)
                    q = interpolate_work([(r.get("equivalents"), r[measure]) for r in rows if r["method"] == mth],
                                         target)
                    wd = interpolate_work([(r.get("work"), r[measure]) for r in rows if r["method"] == "dop853"],
                                          target)
                    qd = interpolate_work([(r.get("equivalents"), r[measure]) for r in rows
                                           if r["method"] == "dop853"], target)
                    steps = interpolate_work([(r["steps"], r[measure]) for r in rows if r["method"] == mth],
                                             target)
                    if w is None or wd is None:
                        cells.append("not reached" if w is None else f"{steps:.1f}: {w:.0f} / {q:.0f}")
                    else:
                        cells.append(f"{steps:.1f}: {w:.0f} / {q:.0f}: {wd / w:.2f}x / {qd / q:.2f}x")
                lines.append(f"| {mth} | " + " | ".join(cells) + " |")
        n = res["n_modes"]

        def tmafm_equivalents(c):
            return c["rhs_evaluations"] + ((c["contact_steps"] + c["rejected_steps"]) * rk_madds(n, False, True)
                                           / MADDS_PER_RHS[n])
        lines.append("whole contact, entry to exit: tmafm's own run through it alone (flight_exact from the "
                     "flight state at the period boundary before): " + "; ".join(
                         f"rtol {k}: {v['whole_run']['counters']['contact_steps']} contact steps, "
                         f"{v['whole_run']['counters']['rejected_steps']} rejected, "
                         f"{v['whole_run']['counters']['rhs_evaluations']} RHS "
                         f"({tmafm_equivalents(v['whole_run']['counters']):.0f} equivalents), "
                         f"error {v['whole_run']['error']:.1e}, V_T {v['whole_run']['vt_error']:.1e}"
                         for k, v in real.items()))
        for key, v in real.items():
            target = v["whole_run"]["vt_error"]
            cells = []
            for mth in sorted({r["method"] for r in res["whole"]}):
                for q in (1, 2, 3):
                    pts = [r for r in res["whole"] if r["method"] == mth and r["q"] == q]
                    st = interpolate_work([(r["steps"], r["vt_error"]) for r in pts], target)
                    if st is None:
                        continue
                    ends = interpolate_work([(r["end_steps"], r["vt_error"]) for r in pts], target)
                    w = interpolate_work([(r["work"], r["vt_error"]) for r in pts], target)
                    q_eq = interpolate_work([(r["equivalents"], r["vt_error"]) for r in pts], target)
                    cells.append(f"{mth} q={q}: {st:.1f} steps ({ends:.1f} at the ends), {w:.0f} / {q_eq:.0f}")
            lines.append(f"  at tmafm's V_T error of rtol {key} ({target:.1e}): " + "; ".join(cells))
        lines.append("whole contact, entry to exit: steps (of them outside the inner interval): error, "
                     "V_T error (work)")
        for mth in sorted({r["method"] for r in res["whole"]}):
            for q in (1, 2, 3):
                pts = [r for r in res["whole"] if r["method"] == mth and r["q"] == q]
                lines.append(f"  {mth} q={q}: " + ", ".join(
                    f"{r['steps']} ({r['end_steps']:.1f}): {r['error']:.1e}, {r['vt_error']:.1e} ({r['work']})"
                    for r in pts))
    for n in sorted({res["n_modes"] for res in results}):
        for s in (5, 6):
            table, sample = etd_side_madds(n, s)
            lines.append(f"left out, N = {n}, s = {s}: the weights of one step length {table} multiply-adds "
                         f"({table / MADDS_PER_RHS[n]:.1f} RHS equivalents) + {n * (s + 1)} complex "
                         f"exponentials; one dense sample {sample} ({sample / MADDS_PER_RHS[n]:.1f}) + {n}; "
                         f"dop853's stage algebra per adaptive step {rk_madds(n, False, True)} "
                         f"({rk_madds(n, False, True) / MADDS_PER_RHS[n]:.1f})")
    return "\n".join(lines)


def chart(results, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, len(results), figsize=(6.5 * len(results), 9.5), squeeze=False)
    show = ("dop853", "lawson", "etd_gauss6_stagenewton1", "etd_gauss6_stagenewton1_x3",
            "etd_gauss3_stagenewton1_x2", "etd_gauss6_picard")
    for col, res in enumerate(results):
        for row, measure in enumerate(("error", "vt_error")):
            ax = axes[row][col]
            for mth in show:
                pts = [r for r in res["rows"] if r["method"] == mth and r[measure] is not None]
                if not pts:
                    continue
                line, = ax.loglog([r["work"] for r in pts], [max(r[measure], 1e-17) for r in pts], "o-",
                                  label=mth, ms=3)
                ax.loglog([r["equivalents"] for r in pts], [max(r[measure], 1e-17) for r in pts], "--",
                          color=line.get_color(), lw=0.8)
            for key, mark in (("1e-07", "s"), ("1e-10", "D")):
                real = res["real"][key]
                ax.loglog([real["rhs"]], [real[measure]], mark, color="k", mfc="none",
                          label=f"dop853 on tmafm's steps, rtol {key}")
            ax.set_title(f"{res['scene']}: inner {res['t1'] - res['t0']:.2f} of a contact")
            ax.set_xlabel("work: right-hand sides (+ Newton's Jacobians); dashed: + own linear algebra")
            ax.set_ylabel("end error / component scale" if measure == "error" else "end V_T error / S_V")
            ax.grid(True, which="both", lw=0.3)
            ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="where to write etd_probe.json and .png (default studies/results/); "
                        "with --table, redraw the chart there")
    parser.add_argument("--table", help="print the summary of an existing JSON and stop")
    parser.add_argument("--scenes", nargs="*", default=list(SCENES))
    args = parser.parse_args()
    if args.table:
        results = json.loads(Path(args.table).read_text())["results"]
        print(summarize(results))
        if args.out:
            chart(results, Path(args.out) / "etd_probe.png")
        return
    results = [study(name, SCENES[name]) for name in args.scenes]
    out = Path(args.out or REPO / "studies" / "results")
    out.mkdir(parents=True, exist_ok=True)
    madds = {str(k): v for k, v in MADDS_PER_RHS.items()}
    (out / "etd_probe.json").write_text(json.dumps({"results": results, "madds_per_rhs": madds}, indent=1))
    chart(results, out / "etd_probe.png")
    print(summarize(results))


if __name__ == "__main__":
    main()
