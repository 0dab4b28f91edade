"""CPU time of plain runs (no observer) and of observed runs, in one process: with every
observable (the default), with each observable group alone, and with none (the Poincare
points, contact time and count only: what a basin map needs).

    python benchmarks/observe_overhead.py --out benchmarks/results/observe_overhead.json \
        --png benchmarks/results/observe_overhead.png

Plain runs keep their samples as before; an observed run keeps none and computes the per-period
observables of docs/observables.md (``observables=``: tmafm.observe.OBSERVABLE_GROUPS).  Prints
and writes the CPU seconds (process_time) of each, best of `repeat`, for each method, over the
same number of drive periods, and each variant's ratio to the plain run.
"""

import argparse
import importlib
import json
import math
import time

import tmafm

observe_module = importlib.import_module("tmafm.observe")

PERIODS = 200
METHODS = ("rk4_paper", "dopri5", "dop853", "flight_exact")
#: The observed variants: label -> observables= (None: all).
VARIANTS = {"all": None, **{g: [g] for g in observe_module.OBSERVABLE_GROUPS}, "none": []}


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
        row = {"plain_run_cpu_s": plain}
        for label, observables in VARIANTS.items():
            observed = best(lambda: tmafm.observe("fig3", solver={"method": method},
                                                  max_periods=PERIODS, stop_at_steady=False,
                                                  observables=observables))
            row[f"observed_{label}_cpu_s"] = observed
            row[f"ratio_{label}"] = observed / plain
        rows[method] = row
        print(f"{method:13s} plain {plain:.3f} s  " + "  ".join(
            f"{label} {row[f'ratio_{label}']:.2f}x" for label in VARIANTS), flush=True)
    if args.out:
        with open(args.out, "w") as handle:
            json.dump({"periods": PERIODS, "input": "fig3", "variants": {
                k: "all" if v is None else v for k, v in VARIANTS.items()}, "rows": rows,
                "command": "python benchmarks/observe_overhead.py --out "
                           "benchmarks/results/observe_overhead.json --png "
                           "benchmarks/results/observe_overhead.png",
                "time": "CPU s (process_time), best of 3, one process"}, handle, indent=1)
    if args.png:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        labels = ["plain"] + list(VARIANTS)
        width = 0.8 / len(labels)
        fig, ax = plt.subplots(figsize=(8, 3.8))
        for j, label in enumerate(labels):
            key = "plain_run_cpu_s" if label == "plain" else f"observed_{label}_cpu_s"
            ax.bar([i + (j - len(labels) / 2 + 0.5) * width for i in range(len(METHODS))],
                   [rows[m][key] for m in METHODS], width, label=label)
        ax.set_xticks(list(range(len(METHODS))), METHODS)
        ax.set_yscale("log")
        ax.set_ylabel("CPU s (best of 3)")
        ax.set_title(f"fig3, {PERIODS} drive periods: plain run (samples T/100) and observed "
                     f"runs by observables=", fontsize=9)
        ax.legend(fontsize=7, ncol=4)
        fig.tight_layout()
        fig.savefig(args.png, dpi=100)


if __name__ == "__main__":
    main()
