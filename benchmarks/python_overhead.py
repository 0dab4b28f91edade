"""The Python layer's own cost, and runs in threads against processes.

    /opt/tmafm-venv/bin/python benchmarks/python_overhead.py [--calls 300] [--scenes 40]

1. Fixed cost of one short call (tau_end = 0.1, Fig. 2, N = 4), in CPU time (user + sys of this
   process) per call, median of 5 batches: ``tmafm.run(dict)``, ``tmafm.run(path)``, a reused
   ``Config.run()``, and, for comparison, the file-based path tmafm.run used before
   (f90nml writes a temporary namelist, the core resolves it into a temporary folder, f90nml reads
   that back, and the core reads the input again to run it).
2. Throughput on `--scenes` short scenes (Fig. 2 with varied drive amplitude and frequency,
   tau_end = 20): 1 and 2 threads, 1 and 2 processes, wall time, and for threads the CPU seconds
   this process used per wall second (above 1 only when two threads compute at once).  On a
   shared 2-core machine the 2-worker numbers depend on what else runs; the JSON records the
   load average.

Writes benchmarks/results/python_overhead.json and .png.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np

import tmafm

OUT = Path(__file__).resolve().parent / "results"
SHORT = {"model": {"n_modes": 4, "convention": "paper"}, "solver": {"tau_end": 0.1}}


def cpu_per_call(call, calls: int, batches: int = 5) -> float:
    """Median over batches of the CPU seconds (user + sys) per call."""
    call()
    per = []
    for _ in range(batches):
        start = time.process_time()
        for _ in range(calls):
            call()
        per.append((time.process_time() - start) / calls)
    return statistics.median(per)


def scenes(count: int) -> list[dict]:
    rng = np.random.default_rng(1)
    return [{"model": {"n_modes": 4, "convention": "paper"},
             "scene": {"alpha2": float(rng.uniform(3e-4, 8e-4)), "omega": float(rng.uniform(1.8, 2.2))},
             "solver": {"tau_end": 20.0}} for _ in range(count)]


def _one(groups):
    return float(tmafm.run(groups).vt.min())


def throughput(items, workers: int, pool_class, busy: dict | None = None) -> float:
    """Scenes per second of wall time.  For threads, `busy` gets this process's CPU seconds per
    wall second: above 1 only if two threads computed at once (the GIL was released)."""
    with pool_class(max_workers=workers) as pool:
        list(pool.map(_one, items[:workers]))  # start-up (process spawn, imports) not timed
        start, cpu = time.perf_counter(), time.process_time()
        list(pool.map(_one, items))
        wall = time.perf_counter() - start
        if busy is not None:
            busy[f"threads_{workers}"] = round((time.process_time() - cpu) / wall, 3)
        return len(items) / wall


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=300)
    parser.add_argument("--scenes", type=int, default=40)
    args = parser.parse_args(argv)

    path = tmafm.inputs.path("fig2_n4")
    config = tmafm.Config(SHORT)
    fixed = {
        "run_dict": cpu_per_call(lambda: tmafm.run(SHORT), args.calls),
        "run_path": cpu_per_call(lambda: tmafm.run(path, solver={"tau_end": 0.1}), args.calls),
        "config_run": cpu_per_call(config.run, args.calls),
    }
    counters = config.run().counters
    items = scenes(args.scenes)
    busy: dict = {}
    rates = {
        "threads_1": throughput(items, 1, ThreadPoolExecutor, busy),
        "threads_2": throughput(items, 2, ThreadPoolExecutor, busy),
        "processes_1": throughput(items, 1, ProcessPoolExecutor),
        "processes_2": throughput(items, 2, ProcessPoolExecutor),
    }
    report = {
        "tmafm": tmafm.__version__, "python": platform.python_version(),
        "cpu_count": os.cpu_count(), "load_average": os.getloadavg(),
        "short_call": {"input": SHORT, "counters": counters,
                       "cpu_ms_per_call": {k: round(v * 1e3, 4) for k, v in fixed.items()}},
        "throughput": {"scenes": args.scenes, "tau_end": 20.0,
                       "scenes_per_s": {k: round(v, 2) for k, v in rates.items()},
                       "cpu_seconds_per_wall_second": busy,
                       "speedup_2_threads": round(rates["threads_2"] / rates["threads_1"], 3),
                       "speedup_2_processes": round(rates["processes_2"] / rates["processes_1"], 3)},
    }
    (OUT / "python_overhead.json").write_text(json.dumps(report, indent=1) + "\n")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("no matplotlib: skipped the chart (pip install 'tmafm[plot]')")
    else:
        fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.6))
        names = list(fixed)
        left.barh(names, [fixed[k] * 1e3 for k in names])
        left.axvline(0.3, color="k", ls="--", lw=1, label="goal 0.3 ms")
        left.set_xscale("log")
        left.set_xlabel("CPU ms per call (tau_end = 0.1)")
        left.legend()
        names = list(rates)
        right.bar(names, [rates[k] for k in names])
        right.set_ylabel(f"scenes/s ({args.scenes} scenes, tau_end = 20)")
        fig.tight_layout()
        fig.savefig(OUT / "python_overhead.png", dpi=110)
    print(json.dumps(report, indent=1))
    return report


if __name__ == "__main__":
    main()
