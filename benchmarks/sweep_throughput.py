"""Sweep throughput: runs/s and periods/s of tmafm.sweep on the same grid, for the core's
OpenMP batch, a process pool and a Dask LocalCluster, each with 1 and 2 workers.

    /opt/tmafm-venv/bin/python benchmarks/sweep_throughput.py [--points 96] [--periods 30]

The grid: the Fig. 2 scene (inputs/fig2_n4.nml, N = 4, with flight_exact at rtol 1e-8: the
observers need dense output) over
scene.delta_hat x scene.alpha2, every run exactly --periods periods (stop_at_steady=False, so
every backend does the same work).  Times are wall-clock (the point of workers is wall time),
the median of 3 runs after a warm-up;
the process CPU time (user+sys, this process and its threads only) is recorded too.  Writes
benchmarks/results/sweep_throughput.json and .png; docs/performance.md quotes them.
"""

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

import tmafm

REPO = Path(__file__).resolve().parent.parent


def timed(label, call, runs, periods, workers, repeats=3):
    """The median of `repeats` timings (wall; the CPU of the same run)."""
    samples = []
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        ds = call()
        samples.append((time.perf_counter() - wall, time.process_time() - cpu))
    wall, cpu = sorted(samples)[len(samples) // 2]
    print(f"{label:>24s} workers={workers}: {wall:7.2f} s wall, {runs / wall:7.1f} runs/s, "
          f"{runs * periods / wall:9.0f} periods/s", flush=True)
    return ds, {"backend": label, "workers": workers, "wall_s": wall, "process_cpu_s": cpu,
                "runs_per_s": runs / wall, "periods_per_s": runs * periods / wall}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--points", type=int, default=96)
    parser.add_argument("--periods", type=int, default=30)
    args = parser.parse_args()
    n_alpha = 4
    axes = {"scene.delta_hat": np.linspace(0.0, 2e-3, args.points // n_alpha),
            "scene.alpha2": np.linspace(3e-4, 6e-4, n_alpha)}
    runs = axes["scene.delta_hat"].size * n_alpha
    kw = dict(max_periods=args.periods, stop_at_steady=False)
    base = tmafm.Config("fig2_n4", solver={"method": "flight_exact", "rtol": 1e-8})
    rows, reference = [], None
    # Warm up (imports of xarray and the core's first call) before any clock starts.
    tmafm.sweep(base, {"scene.delta_hat": [0.0]}, workers=1, max_periods=2)
    for workers in (1, 2):
        ds, row = timed("batch (OpenMP threads)", lambda: tmafm.sweep(
            base, axes, workers=workers, **kw), runs, args.periods, workers)
        rows.append(row)
        reference = ds if reference is None else reference
        assert bool((ds["amplitude"] == reference["amplitude"]).all())
        ds, row = timed("process pool", lambda: tmafm.sweep(
            base, axes, workers=workers, backend="processes", **kw), runs, args.periods,
            workers)
        rows.append(row)
        assert bool((ds["amplitude"] == reference["amplitude"]).all())
        from dask.distributed import Client, LocalCluster
        for processes in (False, True):
            label = "dask (processes)" if processes else "dask (threads)"
            with LocalCluster(n_workers=workers if processes else 1,
                              threads_per_worker=1 if processes else workers,
                              processes=processes, dashboard_address=None) as cluster, \
                    Client(cluster) as client:
                client.submit(lambda: 0).result()  # the cluster is up before the clock starts
                ds, row = timed(label, lambda: tmafm.sweep(base, axes, client=client, **kw),
                                runs, args.periods, workers)
            rows.append(row)
            assert bool((ds["amplitude"] == reference["amplitude"]).all())
    report = {"input": "inputs/fig2_n4.nml (N = 4), flight_exact at rtol 1e-8", "runs": runs,
              "periods_per_run": args.periods, "cpu_count": os.cpu_count(),
              "time": "wall clock, median of 3 (process_cpu_s: this process's user+sys only, "
                      "so not the pool's or the Dask processes' workers)", "rows": rows}
    out = REPO / "benchmarks" / "results" / "sweep_throughput.json"
    out.write_text(json.dumps(report, indent=1))
    chart(report, out.with_suffix(".png"))


def chart(report, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    labels = sorted({r["backend"] for r in report["rows"]}, key=[r["backend"] for r in
                                                                   report["rows"]].index)
    fig, ax = plt.subplots(figsize=(7, 3.6))
    width = 0.38
    for k, workers in enumerate((1, 2)):
        values = [next(r["periods_per_s"] for r in report["rows"] if r["backend"] == label
                       and r["workers"] == workers) for label in labels]
        ax.bar(np.arange(len(labels)) + (k - 0.5) * width, values, width,
               label=f"{workers} worker{'s' if workers > 1 else ''}")
    ax.set_xticks(np.arange(len(labels)), labels, fontsize=8)
    ax.set_ylabel("drive periods / s (wall)")
    ax.set_title(f"tmafm.sweep throughput: {report['runs']} runs x "
                 f"{report['periods_per_run']} periods, Fig. 2 scene N = 4", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
