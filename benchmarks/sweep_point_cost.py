"""CPU time per point of a sweep whose runs are as short as a sweep point can be (one drive
period of Fig. 2 with flight_exact), so what is measured is the Python and binding overhead of
a point: building its input, handing it to the core, reading the results back.

    python benchmarks/sweep_point_cost.py [--points 200] [--repeat 7]

Run it with two installs' interpreters to compare them (CPU time, process_time, the median and
the least of --repeat sweeps, after one warm-up); prints one JSON line.
"""

import argparse
import json
import statistics
import time

import numpy as np

import tmafm


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--points", type=int, default=200)
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    base = tmafm.Config("fig2_n4", solver={"method": "flight_exact"})
    axes = {"scene.delta_hat": np.linspace(0.0, 2e-4, args.points)}

    def one():
        start = time.process_time()
        tmafm.sweep(base, axes, workers=1, max_periods=1, stop_at_steady=False)
        return (time.process_time() - start) / args.points * 1e6

    one()
    samples = [one() for _ in range(args.repeat)]
    print(json.dumps({"tmafm": tmafm.__file__, "points": args.points,
                      "median_us_per_point": round(statistics.median(samples), 1),
                      "least_us_per_point": round(min(samples), 1)}))


if __name__ == "__main__":
    main()
