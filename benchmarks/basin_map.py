"""A basin map of the Fig. 4 scene (inputs/fig4a.nml, N = 3) and an approach/retract curve,
timed: how long a 200 x 200 grid of initial states a1(0) x a1'(0) takes, each run stopped at
steady state, at an attractor found before (tmafm.basin's default; --no-known turns it off)
or after 100 periods, and which share of the time is spent outside the core (building the
states, the Dataset, labelling the attractors).

    /opt/tmafm-venv/bin/python benchmarks/basin_map.py [--n 200] [--workers 2] [--rtol 1e-8]
        [--steady-tol 1e-6] [--no-known] [--approach-points 200]
        [--json benchmarks/results/basin_map.json]

Times are wall clock (the target is wall time on 2 cores); 'in_core_wall_s' is the wall time
spent inside the core's batches (tmafm.observe.observe_states and observe_batch: integrating,
GIL released).  xarray and dask.array are imported before the clock starts (about 2 s the
first time a Dataset is built in a process: not the map's cost; 'imports_s' records it).  The
machine's load average is recorded before and after.  Writes
benchmarks/results/basin_map.json and .png (the map).  The basin runs flight_exact at --rtol.
"""

import argparse
import importlib
import json
import os
import time
from pathlib import Path

import numpy as np

import tmafm
from tmafm.sweeps import plots as sweepplots

observe_module = importlib.import_module("tmafm.observe")

REPO = Path(__file__).resolve().parent.parent


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--approach-points", type=int, default=200)
    parser.add_argument("--rtol", type=float, default=1e-8)
    parser.add_argument("--steady-tol", type=float, default=1e-6)
    parser.add_argument("--no-known", action="store_true",
                        help="run every point to its own steady state (no known-attractor stop)")
    parser.add_argument("--json", default=str(REPO / "benchmarks" / "results" / "basin_map.json"))
    args = parser.parse_args()

    inside = {"wall_s": 0.0, "periods": 0, "runs": 0}
    original = observe_module.observe_batch
    original_states = observe_module.observe_states

    def counted(configs, **kw):
        start = time.perf_counter()
        out = original(configs, **kw)
        inside["wall_s"] += time.perf_counter() - start
        inside["periods"] += sum(o.periods for o in out)
        inside["runs"] += len(out)
        return out

    def counted_states(config, states, **kw):
        start = time.perf_counter()
        out = original_states(config, states, **kw)
        inside["wall_s"] += time.perf_counter() - start
        inside["periods"] += int(out.periods.sum())
        inside["runs"] += len(out.periods)
        return out

    observe_module.observe_batch = counted
    observe_module.observe_states = counted_states
    start = time.perf_counter()
    import dask.array  # noqa: F401  (xarray imports it the first time it builds a Variable)
    import xarray  # noqa: F401
    imports = time.perf_counter() - start
    a1 = np.linspace(-1e-3, 1e-3, args.n)
    adot1 = np.linspace(-2e-3, 2e-3, args.n)
    load_before = os.getloadavg()
    wall, cpu = time.perf_counter(), time.process_time()
    fig4 = tmafm.Config("fig4a", solver={"method": "flight_exact", "rtol": args.rtol})
    ds = tmafm.basin(fig4, a1=a1, adot1=adot1, workers=args.workers, max_periods=100,
                     steady_tol=args.steady_tol, known_attractors=not args.no_known)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    load_after = os.getloadavg()
    counts = {int(k): int((ds["attractor"].values == k).sum()) for k in
              np.unique(ds["attractor"].values)}
    periods = {int(k): int((ds["period"].values == k).sum()) for k in
               np.unique(ds["period"].values)}
    basin = {"input": "inputs/fig4a.nml", "method": "flight_exact", "rtol": args.rtol,
             "steady_tol": args.steady_tol, "grid": [args.n, args.n],
             "a1_range": [float(a1[0]), float(a1[-1])],
             "adot1_range": [float(adot1[0]), float(adot1[-1])], "workers": args.workers,
             "max_periods": 100, "wall_s": wall, "process_cpu_s": cpu, "imports_s": imports,
             "in_core_wall_s": inside["wall_s"],
             "outside_core_fraction": 1 - inside["wall_s"] / wall,
             "periods_run": inside["periods"], "runs": inside["runs"],
             "periods_per_grid_point": inside["periods"] / args.n ** 2,
             "process_cpu_us_per_period": 1e6 * cpu / inside["periods"],
             "runs_per_s": args.n ** 2 / wall,
             "known_attractors": not args.no_known,
             "stopped_at_known_attractor": int(ds["stopped_known"].sum())
             if "stopped_known" in ds else 0,
             "coarse_stride": ds.attrs.get("coarse_stride"),
             "observables": ds.attrs.get("observe_observables", "all"),
             "load_average_1min_before_after": [load_before[0], load_after[0]],
             "attractors": int(ds.attrs["attractors"]), "points_per_label": counts,
             "failures": int(ds.attrs["failures"]),
             "points_per_period": periods}
    print(json.dumps(basin, indent=1), flush=True)
    sweepplots.plot_basin(ds, Path(args.json).with_suffix(".png"))

    inside.update(wall_s=0.0, periods=0, runs=0)
    deltas = np.linspace(8e-3, 0.0, args.approach_points // 2)
    observe_module.observe_batch = original
    wall, cpu = time.perf_counter(), time.process_time()
    curve = tmafm.approach(str(REPO / "inputs" / "sweeps" / "bistable_n2.nml"), delta_hat=deltas,
                           workers=1, max_periods=200)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    approach = {"input": "inputs/sweeps/bistable_n2.nml", "points": 2 * deltas.size,
                "delta_hat_range": [float(deltas[0]), float(deltas[-1])], "max_periods": 200,
                "wall_s": wall, "process_cpu_s": cpu,
                "periods_run": int(curve["periods"].sum()),
                "jumps": {d: [float(x) for x in deltas[curve["jump"].sel(direction=d).values
                                                       .astype(bool)]]
                          for d in ("approach", "retract")}}
    print(json.dumps(approach, indent=1))
    report = {"basin": basin, "approach_retract": approach, "cpu_count": os.cpu_count(),
              "time": "wall clock; process_cpu_s is this process's user+sys",
              "command": "python benchmarks/basin_map.py " + " ".join(
                  f"--{k.replace('_', '-')} {v}" for k, v in vars(args).items()
                  if k not in ("json", "no_known")) + (" --no-known" if args.no_known else "")}
    Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
