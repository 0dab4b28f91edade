"""CPU time of plain runs (no observer) and of observed runs, in one process.

    python benchmarks/observe_overhead.py --out benchmarks/observe_overhead.json \
        --png benchmarks/observe_overhead.png

Plain runs keep their samples as before; an observed run keeps none and computes the per-period
observables of docs/observables.md.  Prints and writes the CPU seconds (process_time) of each,
best of `repeat`, for each method, over the same number of drive periods.
"""

import argparse
import json
import math
import time

import tmafm

PERIODS = 200
METHODS = ("rk4_paper", "dopri5", "dop853", "flight_exact")


def best(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t = time.process_time()
        fn()
        times.append(time.process_time() - t)
    return min(times)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default=None)
    parser.add_argument("--png", default=None)
    args = parser.parse_args()
    T = math.pi
    rows = {}
    for method in METHODS:
        solver = {"method": method, "tau_end": PERIODS * T}
        plain = best(lambda: tmafm.run("fig3", solver=solver, output={"sample_dtau": T / 100}))
        observed = best(lambda: tmafm.observe("fig3", solver={"method": method},
                                              max_periods=PERIODS, stop_at_steady=False))
        rows[method] = {"plain_run_cpu_s": plain, "observed_run_cpu_s": observed,
                        "ratio": observed / plain}
        print(f"{method:13s} plain {plain:.3f} s  observed {observed:.3f} s  ratio {observed / plain:.2f}")
    if args.out:
        with open(args.out, "w") as handle:
            json.dump({"periods": PERIODS, "input": "fig3", "rows": rows}, handle, indent=1)
    if args.png:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        x = range(len(METHODS))
        fig, ax = plt.subplots(figsize=(6, 3.5))
        ax.bar([i - 0.2 for i in x], [rows[m]["plain_run_cpu_s"] for m in METHODS], 0.4,
               label="plain run (samples T/100)")
        ax.bar([i + 0.2 for i in x], [rows[m]["observed_run_cpu_s"] for m in METHODS], 0.4,
               label="observed run (no samples)")
        ax.set_xticks(list(x), METHODS)
        ax.set_yscale("log")
        ax.set_ylabel("CPU s (best of 3)")
        ax.set_title(f"fig3, {PERIODS} drive periods")
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.png, dpi=100)


if __name__ == "__main__":
    main()
