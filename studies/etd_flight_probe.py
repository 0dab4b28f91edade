"""Would an exponential collocation (ETD) flight make flight_exact cheap with a force at a distance?
A measured probe for issue 29, item 5 (docs/performance.md, "Long-range forces in flight").

    python studies/etd_flight_probe.py [--out DIR]            # ~3 min CPU
    python studies/etd_flight_probe.py --table studies/results/etd_flight_probe.json

A study, not a method of tmafm.  The scene is benchmarks/longrange_flight.py's van der Waals
scene (inputs/tapping_polystyrene.nml, N = 3, contact_law = 'dmt_vdw', H = 1e-19 J, a0 = 0.165 nm),
started from the free steady orbit at Z = 25 nm (a DMT flight_exact run of 2000 periods), in two
regimes of the approach curve:
  tapping  Z = 12 nm, the first TAPPING_FLIGHTS flights (exit to the next entry, ~1.5 tau of the
           1.82 tau period) after 20 periods at Z = 12 nm (a flight_exact run at rtol 1e-12);
  free     Z = 25 nm and 21.8 nm (no contact; smallest gap 5.7 and 2.5 nm): three drive periods
           after ten.
Every flight is integrated from the same state (the rtol 1e-12 run's sample after the exit) to
the same end (its sample before the entry) by
  lawson   tmafm's flight_exact (the Lawson form of dop853, tmafm_lawson), started at the flight's
           state and drive phase (&physical drive_phase), one output sample at the end;
  etd      exponential collocation on s Lobatto or Gauss nodes c_i: over a step from (t_n, y_n),
           y(t_n + theta h) = the exact free flight + V eta(theta), the force N (model.derivative
           of the vdW scene less that of its DMT twin, which is the free system A y + b exactly)
           interpolated by the polynomial through its values at the nodes, and
           eta_k(theta) = h sum_j a_j(theta; lambda_k h) (V^-1 N_j)_k,
           a_j(theta; z) = sum_m L_jm theta^(m+1) m! phi_(m+1)(theta z), L the Lagrange
           coefficients; phi_k by its series for |z| < 4, by phi_k = (phi_(k-1) - 1/(k-1)!)/z
           else.  The stages by Picard sweeps from the previous step's polynomial extrapolated
           (the first step: N constant), until a sweep moves the end state by < 0.01 of the
           tolerance (the first sweep compared with the predictor's end state); the error
           estimate the end state's difference from the least-squares fit of one degree less
           (order s - 1: conservative), in the RMS norm over atol + rtol |y|max, the step from
           0.9 err^(-1/s) within [0.2, 4]; a step toward the surface or away from it limited to
           `reach` (V_T + eps)/|V_T'| (eps = &scene vdw_range; flight_exact's gap_reach is 0.5
           toward the surface);
  shaped   the same with the force's growth toward the surface factored out: N interpolated as
           (a/(a + b x))^2 q(x), q the polynomial through N_j (a/(a + b c_j))^-2, a + b x the
           gap V_T + eps along its tangent at the step's start (a = V_T + eps, b = h V_T'), the
           weights a_j the integrals of exp(lambda h (theta - x)) (a/(a + b x))^2 l_j(x) by
           48-point Gauss-Legendre (scalars per node and eigenvalue: no force evaluations).
Forces counts every evaluation of N (a rejected step's too).
Error: |V_T - V_T,ref| at the flight's end over the largest |V_T| of the rtol 1e-12 run, the
reference scipy's DOP853 at rtol 1e-13 (atol 1e-18) on the full right-hand side; atol = rtol/1000.
Cost: right-hand sides per flight (per period in the free regime): tmafm's rhs_evaluations for
the Lawson flight, the force evaluations for etd (its phi-functions and modal products, about a
stage's algebra per node and sweep, not counted).  At equal error: the least right-hand sides of
the rtols whose error is at most the target.  And where the Lawson flight's steps go on
benchmarks/longrange_flight.py's approach at rtol 1e-9 (curve_share).  Writes
etd_flight_probe.json into --out (default studies/results/) and prints the tables.
"""

import argparse
import json
import math
from pathlib import Path

import numpy as np
from numpy.polynomial import legendre
from scipy.integrate import solve_ivp

import tmafm

REPO = Path(__file__).resolve().parent.parent
SCENE = "tapping_polystyrene"
VDW = {"hamaker": 1.0e-19, "intermolecular_distance": 0.165e-9}
RTOLS = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
#: (family, nodes s, reach toward the surface, reach away from it, shaped)
VARIANTS = (("lobatto", 6, 0.5, 0.5, False), ("lobatto", 8, 1.0, 1.0, False), ("gauss", 6, 1.0, 1.0, False),
            ("gauss", 6, 0.8, 3.0, True))
#: Gauss-Legendre points of the shaped flight's weights
SHAPE_X, SHAPE_W = legendre.leggauss(48)
#: the regimes: (name, Z, kind)
REGIMES = (("tapping_12nm", 12e-9, "tapping"), ("free_25nm", 25e-9, "free"), ("free_21.8nm", 21.8e-9, "free"))
TAPPING_FLIGHTS = 8
FREE_PERIODS = 3
#: errors at which the costs are compared
TARGETS = (1e-7, 1e-8, 1e-9, 1e-10)
#: a sweep stops once it moves the end state by less than this fraction of the tolerance
SWEEP_TOL = 0.01
MAX_SWEEPS = 10
#: gap below which a step counts as "near the surface" (m)
NEAR = 5e-9


class Split:
    """The vdW scene in flight as y' = A y + b(tau) + N(tau, y): A, b from the DMT twin, whose
    flight is free; the exact free flight in modal coordinates of A = V Lambda V^-1."""

    def __init__(self, z):
        physical = {**VDW, "tip_sample_distance": z}
        self.vdw = tmafm.Model(tmafm.Config(SCENE, model={"contact_law": "dmt_vdw"}, physical=physical))
        self.dmt = tmafm.Model(tmafm.Config(SCENE, physical={"tip_sample_distance": z}))
        n = self.n = self.vdw.n_modes
        m = 2 * n
        scene = self.vdw.scene
        self.omega, self.alpha2, self.offset, self.eps = (scene["omega"], scene["alpha2"], scene["delta_hat"],
                                                          scene["vdw_range"])
        self.z = z
        self.length = z / scene["delta_hat"]
        mass, damping, stiffness, _ = self.dmt.matrices(0.0, np.zeros(n), False)
        self.A = np.block([[np.zeros((n, n)), np.eye(n)],
                           [-np.linalg.solve(mass, stiffness), -np.linalg.solve(mass, damping)]])
        self.lam, self.V = np.linalg.eig(self.A)
        self.Vi = np.linalg.inv(self.V)
        b_cos = self.dmt.derivative(0.0, np.zeros(m), False)
        b_sin = self.dmt.derivative(math.pi / (2 * self.omega), np.zeros(m), False)
        # y_p = u sin + v cos: A u + b_sin = -omega v, A v + b_cos = omega u
        big = np.block([[self.A, self.omega * np.eye(m)], [-self.omega * np.eye(m), self.A]])
        uv = np.linalg.solve(big, -np.concatenate([b_sin, b_cos]))
        self.u, self.v = uv[:m], uv[m:]
        self.evaluations = 0

    def particular(self, t):
        return self.u * math.sin(self.omega * t) + self.v * math.cos(self.omega * t)

    def force(self, t, y):
        self.evaluations += 1
        return self.vdw.derivative(t, y, False) - self.dmt.derivative(t, y, False)

    def full(self, t, y):
        return self.vdw.derivative(t, y, False)

    def gap(self, t, y):
        """V_T and its rate."""
        n = self.n
        return (self.vdw.tip @ y[:n] + self.alpha2 * math.sin(self.omega * t) + self.offset,
                self.vdw.tip @ y[n:] + self.alpha2 * self.omega * math.cos(self.omega * t))

    def state(self, t0, y0, theta, h, eta):
        """The exact free flight from (t0, y0) over theta h plus V eta."""
        w = np.exp(self.lam * theta * h) * (self.Vi @ (y0 - self.particular(t0))) + eta
        return self.particular(t0 + theta * h) + (self.V @ w).real


def phis(z, p):
    """phi_0 .. phi_p of a complex array z (series for |z| < 4, the recurrence else)."""
    out = np.zeros((p + 1,) + z.shape, complex)
    out[0] = np.exp(z)
    small = np.abs(z) < 4.0
    safe = np.where(small, 1.0, z)
    for k in range(1, p + 1):
        series = np.zeros(z.shape, complex)
        term = np.ones(z.shape, complex) / math.factorial(k)
        for j in range(60):
            series += term
            term = term * z / (k + j + 1)
        out[k] = np.where(small, series, (out[k - 1] - 1.0 / math.factorial(k - 1)) / safe)
    return out


def nodes_of(family, s):
    if family == "gauss":
        return (legendre.leggauss(s)[0] + 1) / 2
    inner = legendre.Legendre.basis(s - 1).deriv().roots()
    return np.concatenate([[0.0], (np.sort(inner.real) + 1) / 2, [1.0]])


def fit(nodes, degree):
    """L[j, k]: the polynomial of the given degree fitted (least squares; interpolating when
    degree = len(nodes) - 1) to values N_j at the nodes is sum_k (sum_j L[j, k] N_j) x^k."""
    return np.linalg.pinv(np.vander(nodes, degree + 1, increasing=True)).T


def weights(split, theta, h, lag):
    """a_j(theta; lambda h) per node j and eigenvalue: (s, m)."""
    degree = lag.shape[1] - 1
    ph = phis(split.lam * theta * h, degree + 1)
    return np.array([sum(lag[j, k] * theta ** (k + 1) * math.factorial(k) * ph[k + 1] for k in range(degree + 1))
                     for j in range(lag.shape[0])])


def shaped_weights(split, theta, h, lag, a, b):
    """a_j(theta; lambda h) of the shaped flight: the integral over [0, theta] of
    exp(lambda h (theta - x)) (a/(a + b x))^2 l_j(x), by Gauss-Legendre on SHAPE_POINTS points."""
    x = (SHAPE_X + 1) / 2 * theta
    weight = SHAPE_W / 2 * theta * (a / (a + b * x)) ** 2
    poly = np.vander(x, lag.shape[1], increasing=True) @ lag.T            # (points, s): l_j(x)
    turn = np.exp(np.outer(theta - x, split.lam * h))                      # (points, m)
    return np.einsum("q,qj,qm->jm", weight, poly, turn)


def etd_flight(split, y0, t0, t1, rtol, atol, scale, family, s, reach_in, reach_out, shaped):
    """One flight by adaptive exponential collocation: the end state and the counts.  Shaped:
    the force is interpolated as (a/(a + b x))^2 q(x), q the polynomial, a + b x the gap V_T + eps
    along the step's tangent at its start (a = V_T + eps, b = h V_T')."""
    c = nodes_of(family, s)
    lag, low = fit(c, s - 1), fit(c, s - 2)
    t, y, h = t0, y0.copy(), 0.05
    steps = rejected = sweeps = near_steps = 0
    previous = None                      # (coefficients of q in x = sigma / h, h, a, b) of the last step
    n_start = None
    while t < t1 - 1e-13 * max(1.0, abs(t1)):
        vt, rate = split.gap(t, y)
        reach = reach_in if rate < 0 else reach_out
        h = min(h, reach * (vt + split.eps) / abs(rate), t1 - t)
        a, b = (vt + split.eps, rate * h) if shaped else (1.0, 0.0)
        shape = (a / (a + b * c)) ** 2
        if n_start is None:
            n_start = split.force(t, y)
        if previous is None:
            nj = np.array([n_start] * s)
        else:
            coef, h_old, a_old, b_old = previous
            x = (h_old + c * h) / h_old
            nj = ((a_old / (a_old + b_old * x)) ** 2)[:, None] * (np.vander(x, len(coef), increasing=True) @ coef)
        if c[0] == 0.0:
            nj[0] = n_start
        if shaped:
            w_nodes = [shaped_weights(split, ci, h, lag, a, b) for ci in c]
            w_end, w_low = shaped_weights(split, 1.0, h, lag, a, b), shaped_weights(split, 1.0, h, low, a, b)
        else:
            w_nodes = [weights(split, ci, h, lag) if ci > 0 else None for ci in c]
            w_end, w_low = weights(split, 1.0, h, lag), weights(split, 1.0, h, low)
        tol = atol + rtol * scale
        modal = (split.Vi @ (nj / shape[:, None]).T).T
        end = split.state(t, y, 1.0, h, h * (w_end * modal).sum(0))
        for _ in range(MAX_SWEEPS):
            new = nj.copy()
            for i, ci in enumerate(c):
                if ci > 0:
                    new[i] = split.force(t + ci * h, split.state(t, y, ci, h, h * (w_nodes[i] * modal).sum(0)))
            nj, modal = new, (split.Vi @ (new / shape[:, None]).T).T
            sweeps += 1
            end_new = split.state(t, y, 1.0, h, h * (w_end * modal).sum(0))
            moved = np.max(np.abs(end_new - end) / tol)
            end = end_new
            if moved < SWEEP_TOL:
                break
        lower = split.state(t, y, 1.0, h, h * (w_low * modal).sum(0))
        err = math.sqrt(np.mean(((end - lower) / tol) ** 2))
        factor = 0.9 * max(err, 1e-12) ** (-1.0 / s)
        if err <= 1:
            previous = (lag.T @ (nj / shape[:, None]), h, a, b)
            near_steps += vt * split.length < NEAR
            t, y, steps = t + h, end, steps + 1
            n_start = None
            h *= min(4.0, max(0.2, factor))
        else:
            rejected += 1
            h *= min(1.0, max(0.2, factor))
    return y, dict(steps=steps, rejected=rejected, sweeps=sweeps, near_steps=near_steps)


def variant_label(family, s, reach_in, reach_out, shaped):
    reach = f"{reach_in}" if reach_in == reach_out else f"{reach_in}_{reach_out}"
    return f"etd_{family}{s}_reach{reach}" + ("_shaped" if shaped else "")


def lawson_flight(split, y0, t0, t1, rtol):
    """tmafm's flight_exact (the Lawson flight) from (t0, y0) to t1: the end state and counters."""
    n = split.n
    phase = math.remainder(split.omega * t0, 2 * math.pi)
    config = tmafm.Config(SCENE, model={"contact_law": "dmt_vdw"},
                          physical={**VDW, "tip_sample_distance": split.z, "drive_phase": phase},
                          initial={"a0": list(y0[:n]), "adot0": list(y0[n:])},
                          solver={"method": "flight_exact", "rtol": rtol, "atol": rtol / 1000, "tau_end": t1 - t0},
                          output={"sample_dtau": t1 - t0})
    shifted = tmafm.Model(config)
    assert np.allclose(shifted.derivative(0.1, y0, False), split.full(t0 + 0.1, y0), rtol=1e-9, atol=0), \
        "drive_phase does not shift the drive to the flight's start"
    result = tmafm.run(config)
    assert all(s >= t1 - t0 - 1e-12 for s in result.switches), "the Lawson flight met the surface"
    return np.concatenate([result.a[-1], result.adot[-1]]), result.counters


def free_orbit():
    period = 2 * math.pi / tmafm.Config(SCENE).scene["omega"]
    result = tmafm.run(tmafm.Config(SCENE, physical={"tip_sample_distance": 25e-9},
                                    solver={"method": "flight_exact", "rtol": 1e-12, "atol": 1e-16,
                                            "tau_end": 2000 * period}))
    return result.a[-1].copy(), result.adot[-1].copy(), period


def flights_of(split, kind, start, period):
    """The flights of a regime: [(t0, y0, t1)], the states' scale and the largest |V_T|."""
    a, adot = start
    periods = 2 + 20 + TAPPING_FLIGHTS if kind == "tapping" else 10
    result = tmafm.run(tmafm.Config(SCENE, model={"contact_law": "dmt_vdw"},
                                    physical={**VDW, "tip_sample_distance": split.z},
                                    initial={"a0": list(a), "adot0": list(adot)},
                                    solver={"method": "flight_exact", "rtol": 1e-12, "atol": 1e-16,
                                            "tau_end": periods * period},
                                    output={"sample_dtau": period / 1000}))
    ys = np.hstack([result.a, result.adot])
    taus = np.asarray(result.tau)
    scale = np.max(np.abs(ys[len(taus) // 2:]), axis=0)
    s_v = float(np.max(np.abs(result.vt)))
    if kind == "free":
        assert len(result.switches) == 0
        return [(float(taus[-1]), ys[-1], float(taus[-1]) + FREE_PERIODS * period)], scale, s_v
    switches = np.asarray(result.switches)
    contact = np.asarray(result.contact)
    out = []
    for k in range(len(switches) - 1):
        first = np.searchsorted(taus, switches[k]) + 1
        last = np.searchsorted(taus, switches[k + 1]) - 1
        if taus[first] > 20 * period and contact[first] == 0 and last > first + 10:
            out.append((float(taus[first]), ys[first], float(taus[last])))
    return out[:TAPPING_FLIGHTS], scale, s_v


def at_error(runs, target):
    """The least right-hand sides of the runs whose error is at most target (the
    work-precision front; the flight-end errors do not fall monotonically with rtol), or None."""
    costs = [r["rhs"] for r in runs if r["error"] <= target]
    return min(costs) if costs else None


def curve_share(start, period, rtol=1e-9):
    """Where the Lawson flight's steps go on benchmarks/longrange_flight.py's approach (Z = 25 nm
    to 0 in 40 points, 40 periods each, each from the last state of the one before): its flight
    steps at the points without contact and at those with."""
    a, adot = start
    free = tapping = free_points = 0
    for z in np.linspace(25e-9, 0.0, 40):
        result = tmafm.run(tmafm.Config(SCENE, model={"contact_law": "dmt_vdw"},
                                        physical={**VDW, "tip_sample_distance": z},
                                        initial={"a0": list(a), "adot0": list(adot)},
                                        solver={"method": "flight_exact", "rtol": rtol, "atol": rtol / 1000,
                                                "tau_end": 40 * period},
                                        output={"sample_dtau": period / 64}))
        a, adot = result.a[-1].copy(), result.adot[-1].copy()
        c = result.counters
        if c["phase_switches"] == 0:
            free += c["steps"]
            free_points += 1
        else:
            tapping += c["steps"] - c["contact_steps"]
    return {"rtol": rtol, "free_points": free_points, "free_flight_steps": free, "tapping_flight_steps": tapping}


def study():
    a, adot, period = free_orbit()
    report = {"regimes": {}, "curve_share": curve_share((a, adot), period)}
    print(report["curve_share"], flush=True)
    for name, z, kind in REGIMES:
        split = Split(z)
        flights, scale, s_v = flights_of(split, kind, (a, adot), period)
        per = len(flights) if kind == "tapping" else FREE_PERIODS
        references = [solve_ivp(split.full, (t0, t1), y0, method="DOP853", rtol=1e-13, atol=1e-18).y[:, -1]
                      for t0, y0, t1 in flights]
        runs = {"lawson": []}
        for rtol in RTOLS:
            totals, errors = {}, []
            for (t0, y0, t1), ref in zip(flights, references):
                end, counters = lawson_flight(split, y0, t0, t1, rtol)
                totals = {k: totals.get(k, 0) + v for k, v in counters.items()}
                errors.append(abs(split.vdw.tip @ (end - ref)[:split.n]) / s_v)
            runs["lawson"].append(dict(rtol=rtol, steps=totals["steps"] / per, rejected=totals["rejected_steps"] / per,
                                       rhs=totals["rhs_evaluations"] / per, error=max(errors)))
        for variant in VARIANTS:
            label = variant_label(*variant)
            runs[label] = []
            for rtol in RTOLS:
                split.evaluations = 0
                totals, errors = {}, []
                for (t0, y0, t1), ref in zip(flights, references):
                    end, counts = etd_flight(split, y0, t0, t1, rtol, rtol / 1000, scale, *variant)
                    totals = {k: totals.get(k, 0) + v for k, v in counts.items()}
                    errors.append(abs(split.vdw.tip @ (end - ref)[:split.n]) / s_v)
                runs[label].append(dict(rtol=rtol, steps=totals["steps"] / per, rejected=totals["rejected"] / per,
                                        sweeps_per_step=totals["sweeps"] / (totals["steps"] + totals["rejected"]),
                                        near_steps=totals["near_steps"] / per, rhs=split.evaluations / per,
                                        error=max(errors)))
        report["regimes"][name] = {"z_nm": z * 1e9, "kind": kind, "count": per,
                                   "flight_lengths": [t1 - t0 for t0, _, t1 in flights], "runs": runs}
        print_regime(name, report["regimes"][name], flush=True)
    return report


def equal_error(regime):
    """Right-hand sides at each target error, per method, and the Lawson flight's over each."""
    rows = []
    for target in TARGETS:
        costs = {label: at_error(runs, target) for label, runs in regime["runs"].items()}
        rows.append((target, costs))
    return rows


def table_rows(regime):
    """A regime's table (docs/performance.md; benchmarks/check_docs.py reads it from here)."""
    rows = ["| method | rtol | V_T error | steps | of them at gaps < 5 nm | rejected | right-hand sides |",
            "|---|---|---|---|---|---|---|"]
    for label, runs in regime["runs"].items():
        for r in runs:
            near = f"{r['near_steps']:.1f}" if "near_steps" in r else "-"
            rows.append(f"| {label} | {r['rtol']:.0e} | {r['error']:.2e} | {r['steps']:.1f} | {near} | "
                        f"{r['rejected']:.1f} | {r['rhs']:.0f} |")
    return rows


LABELS = {"lawson": "Lawson (tmafm)", "etd_lobatto6_reach0.5": "ETD Lobatto 6, reach 0.5",
          "etd_lobatto8_reach1.0": "ETD Lobatto 8, reach 1", "etd_gauss6_reach1.0": "ETD Gauss 6, reach 1",
          "etd_gauss6_reach0.8_3.0_shaped": "shaped ETD Gauss 6, reach 0.8/3"}
REGIME_LABELS = {"tapping_12nm": "tapping, Z = 12 nm, per flight", "free_25nm": "free, Z = 25 nm, per period",
                 "free_21.8nm": "free, Z = 21.8 nm, per period"}


def summary_rows(report):
    """docs/performance.md's table: right-hand sides at equal error per regime and method, and
    the Lawson flight's over the best ETD variant's (benchmarks/check_docs.py reads it from here)."""
    labels = list(LABELS)
    rows = ["| regime | V_T error ≤ | " + " | ".join(LABELS[k] for k in labels) + " | Lawson / best ETD |",
            "|---" * (len(labels) + 3) + "|"]
    for name, regime in report["regimes"].items():
        for target, costs in equal_error(regime):
            cells = [f"{costs[k]:.0f}" if costs[k] is not None else "not reached" for k in labels]
            etd = [costs[k] for k in labels[1:] if costs[k] is not None]
            ratio = f"{costs['lawson'] / min(etd):.2f}" if etd and costs["lawson"] else "-"
            rows.append(f"| {REGIME_LABELS[name]} | {target:.0e} | " + " | ".join(cells) + f" | {ratio} |")
    return rows


def print_regime(name, regime, flush=False):
    unit = "flight" if regime["kind"] == "tapping" else "period"
    print(f"\n{name} (Z = {regime['z_nm']:.1f} nm), per {unit}:")
    for line in table_rows(regime):
        print(line)
    for target, costs in equal_error(regime):
        lawson = costs["lawson"]
        cells = ", ".join(f"{k} {v:.0f}" + (f" ({lawson / v:.2f}x fewer)" if lawson and v else "")
                          for k, v in costs.items() if v is not None)
        print(f"at error {target:.0e}: {cells}", flush=flush)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "studies" / "results")
    parser.add_argument("--table", type=Path, help="print the tables of a saved JSON and stop")
    args = parser.parse_args()
    if args.table:
        report = json.loads(args.table.read_text())
        for name, regime in report["regimes"].items():
            print_regime(name, regime)
        print("\n" + "\n".join(summary_rows(report)))
        return
    report = study()
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "etd_flight_probe.json").write_text(json.dumps(report, indent=1) + "\n")
    print("\n" + "\n".join(summary_rows(report)))


if __name__ == "__main__":
    main()
