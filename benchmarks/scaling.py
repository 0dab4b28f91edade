"""Cost per simulated drive period against the number of modes N (1..30), per method, with
the log-log slope.  Scene: Fig. 2 (Hertz, `paper`), 5 drive periods from rest.

    /opt/tmafm-venv/bin/python benchmarks/scaling.py [--n-max 30] [--repeat 3]

Fixed-step methods use dtau = min(2e-3, 0.9 * 2.78 / beta_N^2): the paper's step while it is
stable, and the stability limit beyond (so their cost includes the stiffness N brings).
Adaptive methods run at rtol 1e-8, atol 1e-11.  Writes benchmarks/results/scaling.json and .png.
"""

import argparse
import json
import math
import time
from pathlib import Path

import sys

import numpy as np

import tmafm
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from testcore import core as _core  # noqa: E402  (the test-only extension, tests/testcore.py)

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
PERIODS = 5
METHODS = ("rk4_paper", "rk4_event", "dopri5", "dop853", "flight_exact")


def fixed_step(n):
    beta = _core.modes(n, np.array([1.0]), 0)[0]
    return min(2e-3, 0.9 * 2.78 / beta[-1] ** 2)


def cost(n, method, repeat):
    solver = {"method": method, "tau_end": PERIODS * math.pi}
    if method in ("rk4_paper", "rk4_event"):
        solver["dtau"] = fixed_step(n)
    else:
        solver.update(rtol=1e-8, atol=1e-11)
    groups = dict(model={"n_modes": n}, initial={"a0": [0.0] * n}, solver=solver,
                  output={"sample_dtau": 0.05})
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        result = tmafm.run("fig2_n4", **groups)
        best = min(best, time.perf_counter() - start)
    return {"seconds_per_period": best / PERIODS, "rhs_per_period": result.counters["rhs_evaluations"] / PERIODS,
            "steps_per_period": result.counters["steps"] / PERIODS,
            **({"dtau": solver["dtau"]} if "dtau" in solver else {})}


def slope(ns, values, n_from=4):
    ns, values = np.array(ns), np.array(values)
    keep = ns >= n_from
    return float(np.polyfit(np.log(ns[keep]), np.log(values[keep]), 1)[0])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-max", type=int, default=30)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    ns = list(range(1, args.n_max + 1))
    report = {"tmafm": tmafm.__version__, "periods": PERIODS, "scene": "inputs/fig2_n4.nml (paper, Hertz)",
              "seconds": f"best of {args.repeat} in-process wall times of tmafm.run", "methods": {}}
    for method in METHODS:
        rows = []
        for n in ns:
            rows.append({"n_modes": n, **cost(n, method, args.repeat)})
            print(f"{method} N = {n}: {rows[-1]['seconds_per_period'] * 1e3:.2f} ms per period")
        report["methods"][method] = {
            "rows": rows,
            "loglog_slope_time_N>=4": slope(ns, [r["seconds_per_period"] for r in rows]),
            "loglog_slope_rhs_N>=4": slope(ns, [r["rhs_per_period"] for r in rows]),
        }
    (OUT / "scaling.json").write_text(json.dumps(report, indent=1))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.2))
    for method, entry in report["methods"].items():
        rows = entry["rows"]
        ax.loglog(ns, [r["seconds_per_period"] for r in rows], "o-",
                  label=f"{method} (slope {entry['loglog_slope_time_N>=4']:.2f})")
        ax2.loglog(ns, [r["rhs_per_period"] for r in rows], "o-",
                   label=f"{method} (slope {entry['loglog_slope_rhs_N>=4']:.2f})")
    ax.set_ylabel("wall time per drive period (s)")
    ax2.set_ylabel("right-hand-side evaluations per drive period")
    for a in (ax, ax2):
        a.set_xlabel("number of modes N")
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=8)
        a.set_title("Fig. 2 scene, 5 periods; slopes fitted for N >= 4")
    fig.tight_layout()
    fig.savefig(OUT / "scaling.png", dpi=110)
    print(json.dumps({m: {k: v for k, v in e.items() if k != "rows"} for m, e in report["methods"].items()}, indent=1))
    print(f"wrote {OUT / 'scaling.json'} and {OUT / 'scaling.png'}")


if __name__ == "__main__":
    main()
