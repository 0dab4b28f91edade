"""Stability where methods fail: the largest stable fixed RK4 step against N, out of contact
and in contact, set against the theory; a run just past the limit; and the step above which
the paper's scheme starts missing grazing contacts while the located methods miss none.

    /opt/tmafm-venv/bin/python studies/stability.py [--n-max 30]

Writes studies/results/stability.json and studies/results/stability.png.

Theory: RK4 is stable while |R(h lambda)| <= 1 for every eigenvalue lambda of the Jacobian,
R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24.  The Jacobian is taken by central differences of the
core's own right-hand side (tests/testcore.py: tmafm_testcore.model_terms), at a free state and at a state stuck
in DMT contact, so no physics is restated here.  |lambda_max| h <= 2.78 is the rule of thumb.
"""

import argparse
import json
import math
import tempfile
from pathlib import Path

import f90nml
import sys

import numpy as np

import tmafm
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from testcore import core as _core  # noqa: E402  (the test-only extension, tests/testcore.py)
from scenes import grazing_scene  # studies/scenes.py, this script's sibling

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "studies" / "results"
STEPS = 20000          # fixed steps per trial run
TOLERANCE = 0.01       # relative width of the bisection bracket


def jacobian(groups, tau, y, in_contact):
    """Central-difference Jacobian of the core's state derivative."""
    n = len(y) // 2
    with tempfile.NamedTemporaryFile("w", suffix=".nml", delete=False) as handle:
        path = handle.name
    f90nml.write(f90nml.Namelist(groups), path, force=True)
    try:
        cols = []
        for j in range(2 * n):
            h = 1e-7 * max(1e-6, abs(y[j]))
            plus, minus = y.copy(), y.copy()
            plus[j] += h
            minus[j] -= h
            f_plus = _core.model_terms(path, tau, plus[:n], plus[n:], in_contact)[4]
            f_minus = _core.model_terms(path, tau, minus[:n], minus[n:], in_contact)[4]
            cols.append((f_plus - f_minus) / (2 * h))
    finally:
        Path(path).unlink()
    return np.array(cols).T


def rk4_limit(eigenvalues):
    """Largest h with |R(h lambda)| <= 1 for all eigenvalues (bisection on each ray)."""
    def stable(h):
        z = h * eigenvalues
        return np.all(np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) <= 1 + 1e-12)
    lo, hi = 0.0, 10.0 / np.max(np.abs(eigenvalues))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def measured_limit(groups, guess):
    """Bisection on dtau: the largest step whose STEPS-step run does not blow up."""
    def survives(h):
        trial = {g: dict(v) for g, v in groups.items()}
        trial["solver"] = dict(trial.get("solver", {}), method="rk4_paper", dtau=h, contact_refine=1,
                               tau_end=STEPS * h)
        trial["output"] = {"sample_dtau": STEPS * h / 10}
        try:
            tmafm.run(trial)
            return True
        except tmafm.BlowUpError:
            return False
    lo, hi = guess / 2, guess * 2
    while not survives(lo):
        lo /= 2
    while survives(hi):
        hi *= 2
    while hi / lo - 1 > TOLERANCE:
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if survives(mid) else (lo, mid)
    return lo, hi


def free_case(n):
    groups = {"model": {"n_modes": n, "convention": "paper"}, "scene": {"delta_hat": 1.0},
              "initial": {"a0": [1e-6] * n, "adot0": [0.0] * n}}
    y = np.concatenate([np.full(n, 1e-6), np.zeros(n)])
    return groups, 0.0, y, False


def stuck_case(n):
    """Fig. 6 (DMT, paper): the tip sticks; take the state after 10 drive periods."""
    base = {"model": {"n_modes": n, "contact_law": "dmt", "convention": "paper"},
            "solver": {"method": "dopri5", "rtol": 1e-9, "atol": 1e-15}}
    settled = tmafm.run(base, solver={"tau_end": 10 * math.pi}, output={"sample_dtau": math.pi / 10})
    assert settled.vt[-20:].max() < 0, "the DMT tip did not stick"
    a, adot = settled.a[-1], settled.adot[-1]
    groups = {"model": dict(base["model"]), "initial": {"a0": list(map(float, a)), "adot0": list(map(float, adot))}}
    return groups, 0.0, np.concatenate([a, adot]), True


def stability_rows(n_max):
    rows = []
    for n in range(1, n_max + 1):
        row = {"n_modes": n}
        for label, case in (("free", free_case), ("contact", stuck_case)):
            groups, tau, y, in_contact = case(n)
            eig = np.linalg.eigvals(jacobian(groups, tau, y, in_contact))
            theory = rk4_limit(eig)
            lo, hi = measured_limit(groups, theory)
            row[label] = {"lambda_max": float(np.max(np.abs(eig))), "h_theory": theory,
                          "h_rule_2.78": 2.78 / float(np.max(np.abs(eig))),
                          "h_measured_stable": lo, "h_measured_unstable": hi}
        rows.append(row)
        print(f"N = {n}: free h {row['free']['h_measured_stable']:.3e} (theory {row['free']['h_theory']:.3e}),"
              f" contact h {row['contact']['h_measured_stable']:.3e} (theory {row['contact']['h_theory']:.3e})")
    return rows


def failure_demo():
    """A run 5 % past the measured free limit for N = 4: the documented error, no output."""
    groups, *_ = free_case(4)
    lo, hi = measured_limit(groups, 0.02)
    h = 1.05 * hi
    groups["solver"] = {"method": "rk4_paper", "dtau": h, "tau_end": STEPS * h}
    try:
        tmafm.run(groups)
        return {"dtau": h, "error": None}
    except tmafm.BlowUpError as exc:
        return {"dtau": h, "error_type": type(exc).__name__, "error": str(exc)}


def grazing_study():
    scene = grazing_scene(depth=1e-9)
    exact = tmafm.run(scene, solver={"method": "flight_exact", "tau_end": 10 * math.pi,
                                     "rtol": 1e-12, "atol": 1e-18})
    expected = len(exact.switches) // 2
    rows = []
    for dtau in (1e-4, 2e-4, 5e-4, 1e-3, 1.5e-3, 2e-3, 3e-3, 4e-3, 8e-3):
        row = {"dtau": dtau}
        for method in ("rk4_paper", "rk4_event"):
            r = tmafm.run(scene, solver={"method": method, "dtau": dtau, "tau_end": 10 * math.pi})
            row[method] = int(r.counters["phase_switches"]) // 2
        rows.append(row)
        print(f"grazing dtau {dtau:.1e}: rk4_paper finds {row['rk4_paper']}, "
              f"rk4_event {row['rk4_event']} of {expected}")
    missing = [r["dtau"] for r in rows if r["rk4_paper"] < expected]
    durations = exact.switches[1::2] - exact.switches[0::2]
    return {"contacts": expected, "contact_duration_min": float(durations.min()),
            "contact_duration_max": float(durations.max()), "rows": rows,
            "rk4_paper_first_dtau_missing": min(missing) if missing else None,
            "rk4_event_misses_any": any(r["rk4_event"] != expected for r in rows)}


def plot(report, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = report["stability"]
    n = [r["n_modes"] for r in rows]
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.2))
    for label, color in (("free", "tab:blue"), ("contact", "tab:red")):
        ax.semilogy(n, [r[label]["h_measured_stable"] for r in rows], "o", color=color,
                    label=f"{label}: largest stable step (measured)")
        ax.semilogy(n, [r[label]["h_theory"] for r in rows], "-", color=color,
                    label=f"{label}: theory |R(h lambda)| = 1")
        ax.semilogy(n, [r[label]["h_rule_2.78"] for r in rows], ":", color=color,
                    label=f"{label}: 2.78/|lambda_max|")
    ax.axhline(2e-3, color="k", lw=0.8, ls="--", label="paper's dtau = 2e-3")
    ax.axhline(2e-3 / 16, color="0.5", lw=0.8, ls="--", label="paper's contact step dtau/16")
    ax.set_xlabel("number of modes N")
    ax.set_ylabel("RK4 step dtau")
    ax.set_title("Fixed-step RK4 stability (free: no contact; contact: Fig. 6 DMT, stuck)")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    g = report["grazing"]
    dt = [r["dtau"] for r in g["rows"]]
    ax2.semilogx(dt, [r["rk4_paper"] for r in g["rows"]], "o-", color="tab:red", label="rk4_paper")
    ax2.semilogx(dt, [r["rk4_event"] for r in g["rows"]], "s--", color="tab:orange", label="rk4_event")
    ax2.axhline(g["contacts"], color="tab:green", label="exact (flight_exact)")
    ax2.axvline(g["contact_duration_min"], color="0.6", ls=":", label="shortest contact")
    ax2.set_xlabel("step dtau")
    ax2.set_ylabel("contacts found in 10 drive periods")
    ax2.set_title("Grazing scene (contacts ~1.4e-3 long)")
    ax2.legend(fontsize=8)
    ax2.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-max", type=int, default=30)
    args = parser.parse_args()
    report = {"tmafm": tmafm.__version__, "steps_per_trial": STEPS, "bisection_tolerance": TOLERANCE,
              "stability": stability_rows(args.n_max), "failure_past_limit": failure_demo(),
              "grazing": grazing_study()}
    (OUT / "stability.json").write_text(json.dumps(report, indent=1))
    plot(report, OUT / "stability.png")
    print(json.dumps(report["failure_past_limit"], indent=1))
    print(f"wrote {OUT / 'stability.json'} and {OUT / 'stability.png'}")


if __name__ == "__main__":
    main()
