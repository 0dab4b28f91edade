"""What should the automatic N (&model n_modes = 0) compare?  docs/model-notes.md, item 14.

For Fig. 2 (Hertz, printed equations) and Fig. 7's DMT scene with the errata corrected, over
the default mode_horizon = 20, from fixed-N runs at the search's tolerances (dopri5, rtol 1e-10,
atol 1e-16) sampled 2^19 times:

1. max|V_T(N) - V_T(N+1)|/range(V_T(N+1)) on grids of 2^j intervals, taken at the samples (what
   the search did, on the output's grid) and located between them on the cubic Hermite
   interpolant of V_T and its rate (what it does now, on its own grid), each against the
   located value on the 2^19 grid; K = points per period of mode N+1 (beta_{N+1}^2).
2. The per-period located quantities of the observer (min V_T, max V_T, the first harmonic as
   a complex amplitude, the contact time) compared the same way, over the 6 whole drive periods
   in the horizon: how much of the difference they see.
3. The search itself (tmafm.Config(...).mode_search) with sample_dtau = 0.1 and 0.001.

Part 1 also for Fig. 2 with a contact 1000 times stiffer (alpha5 = 6.7665e-2).

    /opt/tmafm-venv/bin/python benchmarks/auto_n_grid.py

Writes benchmarks/auto_n_grid.json.
"""

import json
import math
from pathlib import Path

import numpy as np

import tmafm

REPO = Path(__file__).resolve().parent.parent
INPUTS = REPO / "inputs"
HORIZON = 20.0
FINE = 19
SOLVER = {"method": "dopri5", "rtol": 1e-10, "atol": 1e-16, "tau_end": HORIZON}
SCENES = {"fig2": (INPUTS / "fig2_n4.nml", {}, 1.65e-3),
          "dmt_consistent": (INPUTS / "fig7_dmt.nml", {"model": {"convention": "consistent"}}, 4e-3),
          # A contact 1000 times stiffer, whose frequencies in contact exceed beta_{N+1}^2: the
          # grid study only (no N agrees there, the search would run to 30 modes).
          "stiff_contact": (INPUTS / "fig2_n4.nml", {"scene": {"alpha5": 6.7665e-2}}, None)}
BETA = [1.8751040687119611, 4.694091132974175, 7.854757438237613] + \
    [(j - 0.5) * math.pi for j in range(4, 31)]


def overrides(scene, n):
    groups = {g: dict(v) for g, v in SCENES[scene][1].items()}
    groups.setdefault("model", {})["n_modes"] = n
    groups["initial"] = {"a0": [0.0] * n}
    return groups


def cubic_extrema(p0, p1, d0, d1, h):
    """Per interval, the least and greatest value of the cubic Hermite interpolant."""
    m0, m1 = h * d0, h * d1
    c2 = 3 * (p1 - p0) - 2 * m0 - m1
    c3 = 2 * (p0 - p1) + m0 + m1
    a, b, c = 3 * c3, 2 * c2, m0
    values = [p0, p1]
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = b * b - 4 * a * c
        q = -(b + np.copysign(np.sqrt(np.maximum(disc, 0)), b)) / 2
        # The quadratic's roots (a != 0), or the linear one's (a == 0).
        for root, real in ((q / a, (a != 0) & (disc >= 0)), (c / q, (a != 0) & (disc >= 0)),
                           (-c / b, a == 0)):
            inside = real & np.isfinite(root) & (root > 0) & (root < 1)
            s = np.where(inside, root, 0.0)
            values.append(np.where(inside, p0 + s * (m0 + s * (c2 + s * c3)), p0))
    values = np.array(values)
    return values.min(0), values.max(0)


def located(lower, upper, step):
    """Located max|dV_T|/range on every `step`-th sample."""
    s = slice(None, None, step)
    h = HORIZON / 2**FINE * step
    d, dd = upper.vt[s] - lower.vt[s], upper.vtdot[s] - lower.vtdot[s]
    lo, hi = cubic_extrema(d[:-1], d[1:], dd[:-1], dd[1:], h)
    vlo, vhi = cubic_extrema(upper.vt[s][:-1], upper.vt[s][1:], upper.vtdot[s][:-1],
                             upper.vtdot[s][1:], h)
    return max(hi.max(), -lo.min()) / (vhi.max() - vlo.min())


def sampled(lower, upper, step):
    s = slice(None, None, step)
    return np.abs(upper.vt[s] - lower.vt[s]).max() / np.ptp(upper.vt[s])


def grid_study(scene):
    base = SCENES[scene][0]
    runs = {n: tmafm.run(base, solver=SOLVER, output={"sample_dtau": HORIZON / 2**FINE},
                         **overrides(scene, n)) for n in range(1, 8)}
    rows = []
    for n in range(1, 7):
        reference = located(runs[n], runs[n + 1], 1)
        period = 2 * math.pi / BETA[n] ** 2
        for j in range(7, FINE - 1):
            step = 2 ** (FINE - j)
            rows.append({"n": n, "intervals": 2**j, "K": period / (HORIZON / 2**j),
                         "reference": reference,
                         "located_error": located(runs[n], runs[n + 1], step) / reference - 1,
                         "sampled_error": sampled(runs[n], runs[n + 1], step) / reference - 1})
    return rows


def worst(rows, low, high):
    chosen = [r for r in rows if low <= r["K"] < high]
    return {key: max(abs(r[key]) for r in chosen) for key in ("located_error", "sampled_error")}


def observer_study(scene):
    base = SCENES[scene][0]
    periods = int(HORIZON // math.pi)
    obs = {n: tmafm.observe(base, max_periods=periods, stop_at_steady=False, harmonics=1,
                            solver={"method": "dopri5", "rtol": 1e-10, "atol": 1e-16},
                            **overrides(scene, n)).per_period for n in range(1, 8)}
    rows = []
    for n in range(1, 7):
        lo, up = obs[n], obs[n + 1]
        span = np.max(up["max_gap"]) - np.min(up["min_gap"])
        first = lambda o: o["amplitude"] * np.exp(1j * np.radians(o["phase"]))  # noqa: E731
        rows.append({"n": n,
                     "min_vt": float(np.abs(up["min_gap"] - lo["min_gap"]).max() / span),
                     "max_vt": float(np.abs(up["max_gap"] - lo["max_gap"]).max() / span),
                     "first_harmonic": float(np.abs(first(up) - first(lo)).max() / span),
                     "contact_time": float(np.abs(up["contact_time"] - lo["contact_time"]).max())})
    return rows


def search(scene):
    base, groups, mode_tol = SCENES[scene]
    out = {}
    for dtau in (0.1, 0.001):
        model = dict(groups.get("model", {}), n_modes=0, mode_tol=mode_tol)
        config = tmafm.Config(base, model=model, initial={"a0": [0.0]},
                              output={"sample_dtau": dtau})
        s = config.mode_search
        out[str(dtau)] = {"n_modes": s["n_modes"], "differences": s["differences"]}
    return out


def main():
    report = {"horizon": HORIZON, "fine_intervals": 2**FINE, "solver": SOLVER, "scenes": {}}
    for scene in SCENES:
        rows = grid_study(scene)
        entry = {"grid": rows,
                 "worst": {"K in [4, 8)": worst(rows, 4, 8), "K in [8, 16)": worst(rows, 8, 16),
                           "K >= 16": worst(rows, 16, math.inf)}}
        report["scenes"][scene] = entry
        print(scene)
        for label, w in entry["worst"].items():
            print(f"  {label}: located {w['located_error']:.1e}, sampled {w['sampled_error']:.1e}")
        if SCENES[scene][2] is None:
            continue
        entry["observer"], entry["search"] = observer_study(scene), search(scene)
        references = [r["reference"] for r in rows if r["intervals"] == 128]
        seen = [max(o["min_vt"], o["max_vt"], o["first_harmonic"]) / ref
                for o, ref in zip(entry["observer"], references)]
        entry["observer_share"] = [min(seen), max(seen)]
        print(f"  the per-period quantities see {min(seen):.2f} to {max(seen):.2f} of max|dV_T|")
        for r, o in zip([r for r in rows if r["intervals"] == 128], entry["observer"]):
            print(f"  N={o['n']}: max|dV_T|/range {r['reference']:.4e}; per period: min V_T "
                  f"{o['min_vt']:.2e}, max V_T {o['max_vt']:.2e}, first harmonic "
                  f"{o['first_harmonic']:.2e}, contact time {o['contact_time']:.2e}")
        for dtau, s in entry["search"].items():
            print(f"  search, sample_dtau = {dtau}: N = {s['n_modes']}, {s['differences']}")
    (REPO / "benchmarks" / "auto_n_grid.json").write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
