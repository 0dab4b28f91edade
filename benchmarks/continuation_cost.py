"""CPU time of a continuation against the brute-force sweep it replaces, in one run: a branch
of 200 points of inputs/sweeps/bistable_n2.nml in delta_hat from 8e-3 towards 0 (through both
folds of its period-1 branch) against the 201-point approach/retract sweep over the same
interval (tmafm.approach, 402 warm-started runs).

    /opt/tmafm-venv/bin/python benchmarks/continuation_cost.py [--repeat 3]

Both on one core (workers=1), CPU time (process_time), the least of --repeat after a warm-up;
prints one JSON line and writes benchmarks/results/continuation_cost.json.
"""

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

import tmafm

REPO = Path(__file__).resolve().parent.parent
BISTABLE = str(REPO / "inputs" / "sweeps" / "bistable_n2.nml")


def _cpu(function):
    start = time.process_time()
    out = function()
    return time.process_time() - start, out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    grid = np.linspace(8e-3, 0.0, 201)

    def sweep():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
            return tmafm.approach(BISTABLE, delta_hat=grid, workers=1)

    def branch():
        return tmafm.continuation(BISTABLE, "scene.delta_hat", 8e-3, 0.0, max_points=200,
                                  switch=False, workers=1)

    sweep()
    branch()
    sweeps, branches = [], []
    for _ in range(args.repeat):
        t, s = _cpu(sweep)
        sweeps.append(t)
        t, b = _cpu(branch)
        branches.append(t)
    labels = [str(x) for x in b["label"].values if str(x) not in ("", "start", "end")]
    folds = [float(v) for v, x in zip(b["scene.delta_hat"].values, b["label"].values)
             if x == "fold"]
    out = {"command": "benchmarks/continuation_cost.py", "repeat": args.repeat,
           "sweep_points": int(2 * grid.size), "sweep_cpu_s": round(min(sweeps), 3),
           "branch_points": int(b.sizes["point"]), "branch_cpu_s": round(min(branches), 3),
           "ratio_branch_over_sweep": round(min(branches) / min(sweeps), 3),
           "branch_special_points": labels, "branch_folds": folds,
           "sweep_periods_run": int(s["periods"].sum())}
    print(json.dumps(out))
    (REPO / "benchmarks" / "results" / "continuation_cost.json").write_text(
        json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
