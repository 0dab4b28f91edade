"""Evidence for the basin map's settings (docs/sweeps.md, "Basin maps: speed and robustness"):

1. The steady-state test's period budget on the Fig. 4 scene: on random initial states, the
   period where the test stops a run, the first period whose Poincare point lies within
   steady_tol of the run's own attractor (its point after 80 periods), the contraction per
   period, and how far apart the attractor's points of different runs lie (the integration's
   floor, in units of steady_tol): why a known attractor is recognised at the labels'
   tolerance, not at steady_tol.
2. The labels' robustness to the integration tolerance: labels at the benchmark's rtol (1e-8)
   against a 100x tighter rtol (1e-10), on every 10th point of the benchmark's 200 x 200 Fig. 4
   grid and on a bistable map (inputs/sweeps/bistable_n2.nml's scene at delta_hat = 3e-3).
3. Labels with known-attractor stops against labels of full runs, on the same maps.
4. The 3 points of the 200 x 200 benchmark map where full runs find no period within 100
   periods (label -1; the known-attractor stops label them 0): how close they stay to the
   attractor, how much their Poincare points still jitter, and whether a 100x tighter rtol
   finds their period.

    python studies/basin_labels.py --json studies/results/basin_labels.json
"""

import argparse
import importlib
import json
from pathlib import Path

import numpy as np

import tmafm

observe_module = importlib.import_module("tmafm.observe")
REPO = Path(__file__).resolve().parent.parent


def budget(points: int, tol: float) -> dict:
    fig4 = tmafm.Config("fig4a", solver={"method": "flight_exact", "rtol": 1e-8})
    rng = np.random.default_rng(1)
    states = np.zeros((points, 6))
    states[:, 0] = rng.uniform(-1e-3, 1e-3, points)
    states[:, 3] = rng.uniform(-2e-3, 2e-3, points)
    configs = [tmafm.Config(fig4, initial={"a0": s[:3].tolist(), "adot0": s[3:].tolist()})
               for s in states]
    runs = tmafm.observe_batch(configs, threads=2, max_periods=80, stop_at_steady=False,
                               observables=())
    stop, within, ratio, ends = [], [], [], []
    for run in runs:
        points_ = run.poincare
        size = np.max(np.abs(points_[-4:]))
        distance = np.max(np.abs(points_ - points_[-1]), axis=1) / size
        step = np.max(np.abs(np.diff(points_, axis=0)), axis=1)
        stop.append(next(m for m in range(4, 81)
                         if observe_module.steady_period(points_[:m + 1], 8, tol, 3) > 0))
        within.append(int(np.argmax(distance <= tol)))
        ratio.append(float(np.median(step[5:20] / step[4:19])))
        ends.append(points_[-1])
    ends = np.array(ends)
    size = np.max(np.abs(ends))
    spread = np.max(np.abs(ends - np.median(ends, axis=0)), axis=1) / size / tol
    wait = np.array(stop) - np.array(within)
    return {"input": "inputs/fig4a.nml", "rtol": 1e-8, "steady_tol": tol, "points": points,
            "test_stops_at_period_mean": float(np.mean(stop)),
            "first_period_within_steady_tol_mean": float(np.mean(within)),
            "periods_the_test_waits_after_that": {str(int(k)): int(v) for k, v in
                                                   zip(*np.unique(wait, return_counts=True))},
            "periods_the_test_waits_mean": float(np.mean(wait)),
            "median_contraction_per_period": float(np.median(ratio)),
            "attractor_point_spread_over_runs_in_steady_tol": {
                "median": float(np.median(spread)), "max": float(np.max(spread))}}


#: The benchmark map's points (a1(0), a1'(0)) without a period in 100 periods (--no-known).
NO_PERIOD = [(0.0006281407035175881, 1.0050251256281569e-05),
             (0.0006281407035175881, 3.0150753768844272e-05),
             (0.0006281407035175881, 5.0251256281406975e-05)]


def floor(tight: float) -> list:
    out = []
    fig4 = tmafm.Config("fig4a", solver={"method": "flight_exact", "rtol": 1e-8})
    attractor = observe_module.observe_states(fig4, np.zeros((1, 6)), observables=(),
                                              stop_at_steady=False, max_periods=80).orbit[0, -1]
    size = np.max(np.abs(attractor))
    for a1, adot1 in NO_PERIOD:
        row = {"a1": a1, "adot1": adot1}
        for rtol in (1e-8, tight):
            config = tmafm.Config(fig4, solver={"method": "flight_exact", "rtol": rtol},
                                  initial={"a0": [a1, 0.0, 0.0], "adot0": [adot1, 0.0, 0.0]})
            run = tmafm.observe(config, max_periods=300, stop_at_steady=False, observables=())
            points_ = run.poincare
            distance = np.max(np.abs(points_ - attractor), axis=1) / size
            step = np.max(np.abs(np.diff(points_, axis=0)), axis=1) / size
            found = next((m for m in range(4, 301)
                          if observe_module.steady_period(points_[:m + 1], 8, 1e-6, 3) > 0), 0)
            row[f"rtol_{rtol:g}"] = {
                "first_period_the_test_finds_a_period": found,
                "max_distance_to_attractor_periods_30_300": float(distance[30:].max()),
                "max_step_periods_30_300": float(step[29:].max())}
        out.append(row)
        print(row, flush=True)
    return out


def maps(tight: float) -> dict:
    out = {}
    scenes = {
        "fig4_every_10th_of_200x200": (
            tmafm.Config("fig4a", solver={"method": "flight_exact"}),
            np.linspace(-1e-3, 1e-3, 200)[::10], np.linspace(-2e-3, 2e-3, 200)[::10],
            dict(max_periods=100)),
        "bistable_n2_delta_3e-3": (
            tmafm.Config(str(REPO / "inputs" / "sweeps" / "bistable_n2.nml"),
                         scene={"delta_hat": 3e-3}),
            np.linspace(-4e-3, 2e-3, 13), np.linspace(-8e-3, 8e-3, 13),
            dict(max_periods=300, steady_tol=1e-4, tol=1e-2)),
    }
    for name, (base, a1, adot1, options) in scenes.items():
        labels = {}
        row = {"grid": [len(a1), len(adot1)], "options": options}
        for rtol in (1e-8, tight):
            config = tmafm.Config(base, solver={"method": "flight_exact", "rtol": rtol})
            for known in (False, True):
                ds = tmafm.basin(config, a1=a1, adot1=adot1, workers=2, known_attractors=known,
                                 **options)
                key = f"rtol_{rtol:g}_{'known' if known else 'full'}"
                labels[key] = ds["attractor"].values
                row[key] = {"attractors": int(ds.attrs["attractors"]),
                            "points_per_label": {str(int(k)): int(v) for k, v in zip(
                                *np.unique(ds["attractor"].values, return_counts=True))},
                            "periods_run": int(ds["periods"].sum())}
                print(name, key, row[key], flush=True)
        reference = labels["rtol_1e-08_full"]
        row["labels_equal_to_rtol_1e-08_full"] = {
            key: bool(np.array_equal(value, reference)) for key, value in labels.items()}
        out[name] = row
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--json", default=str(REPO / "studies" / "results" / "basin_labels.json"))
    parser.add_argument("--points", type=int, default=60)
    args = parser.parse_args()
    report = {"budget": budget(args.points, 1e-6), "no_period_points": floor(1e-10),
              "maps": maps(1e-10),
              "command": "python studies/basin_labels.py --json studies/results/basin_labels.json"}
    print(json.dumps(report["budget"], indent=1))
    Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
