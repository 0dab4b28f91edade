"""rk4_paper's Poincare jitter on the packaged inputs against the level the steady test
predicts for it (docs/model-notes.md, finding 15; tmafm_steady_state jitter_level).

    python benchmarks/steady_jitter.py --out benchmarks/steady_jitter.json [--basin]

Per input (its own rk4_paper settings):
- measured: over the last 50 of 200 periods (stop_at_steady=False), the largest
  max_i |P_j(i) - P_(j-p)(i)| relative to the orbit's size max |P|, p the run's own steady
  period (the core's verdict after 200 periods; else the one tmafm.observe stops at; else
  the located run's);
- measured_lags: the same at lags 1 and 2;
- level: the core's jitter level of the last point, relative to the same size (the floor the
  steady test uses): 2 (dtau + dtau/contact_refine) times the bound of the acceleration's jump
  at a switch, with the tip speed bounded from the point's modal energy;
- independent: the same formula with the jump measured at the switches themselves: a
  flight_exact run of the scene over its last two steady periods, the state at each located
  switch interpolated from samples T/4000 apart, the jump max_i |a''_i(contact) - a''_i(free)|
  from tmafm.Model.derivative in both phases;
- stop: the period at which tmafm.observe(name, max_periods=100) stops, its period and that of
  flight_exact, and the closest repeat it stopped on (relative);
- dtau_scaling: fig3's measured jitter at dtau = 2e-3, 1e-3, 5e-4 (first order: it halves);
- located: the located methods' wander at lags 1 and 2 (the same measure) where it is not
  round-off: fig6 with flight_exact at rtol 1e-7, 1e-8, 1e-9 (atol 1e-3 rtol) and fig3 with
  dop853 at the defaults;
- basin (with --basin): the CPU time (user+sys of this process, one thread) of a 40 x 40
  tmafm.basin of the Fig. 3 scene (a1(0) in [-5e-4, 5e-4], a1'(0) in [-1e-3, 1e-3], at most
  100 periods) with flight_exact and with rk4_paper, the periods run and the share of points
  that reached a steady state.
The measured jitter must stay below both levels (ratio < 1), or the test would never pass.
"""

import argparse
import json
import math
import time
import warnings

import numpy as np

import tmafm
from tmafm import Model

NAMES = ("fig2_n1", "fig2_n2", "fig2_n3", "fig2_n4", "fig3", "fig4a", "fig4c", "fig5a", "fig5c",
         "fig6", "fig7_dmt", "fig7_hertz", "physical_polystyrene")
PERIODS = 200
TAIL = 50


def independent_level(name: str, period: float, settings: dict) -> float:
    """2 (dtau jump_in + dtau/contact_refine jump_out), the jumps measured at the switches of
    a flight_exact run of the scene over its last two steady periods (absolute)."""
    located = tmafm.observe(name, max_periods=400, observables=(), solver={"method": "flight_exact"})
    m = located.periods + 2
    run = tmafm.run(name, solver={"method": "flight_exact", "tau_end": m * period},
                    output={"sample_dtau": period / 4000, "file": "/dev/null"})
    model = Model(name)
    n = run.a.shape[1]
    jump = {True: 0.0, False: 0.0}
    for switch in run.switches:
        if switch < (m - 2) * period:
            continue
        i = int(np.searchsorted(run.tau, switch))
        w = (switch - run.tau[i - 1]) / (run.tau[i] - run.tau[i - 1])
        y = np.concatenate([(1 - w) * run.a[i - 1] + w * run.a[i],
                            (1 - w) * run.adot[i - 1] + w * run.adot[i]])
        size = np.abs(model.derivative(switch, y, True) - model.derivative(switch, y, False))[n:].max()
        entering = bool(run.contact[i] == 1)
        jump[entering] = max(jump[entering], float(size))
    dtau = settings["dtau"]
    return 2 * (dtau * jump[True] + dtau / settings["contact_refine"] * jump[False]), located.period


def measure(name: str) -> dict:
    config = tmafm.Config(name)
    settings = config.to_dict()["solver"]
    period = 2 * math.pi / config.scene["omega"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        long = tmafm.observe(name, max_periods=PERIODS, stop_at_steady=False, observables=())
        stop = tmafm.observe(name, max_periods=100, observables=())
        independent, located_period = independent_level(name, period, settings)
    points = long.poincare
    size = float(np.abs(points[-(TAIL + 8):]).max())
    lag = long.period or stop.period or located_period or 1
    measured = float((np.abs(points[-TAIL:] - points[-TAIL - lag:-lag]).max(axis=1)).max() / size)
    level = long.evidence["jitter"]
    lags = [float((np.abs(points[-TAIL:] - points[-TAIL - q:-q]).max(axis=1)).max() / size)
            for q in (1, 2)]
    row = {"method": settings["method"], "dtau": settings["dtau"],
           "contact_refine": settings["contact_refine"], "lag": lag,
           "measured": measured, "measured_lags": lags, "level": level,
           "independent": independent / size,
           "ratio_level": measured / level if level else None,
           "ratio_independent": measured * size / independent if independent else None,
           "stop_periods": stop.periods, "stop_period": stop.period,
           "stop_closest": stop.evidence["closest"], "located_period": located_period}
    return row


def basin_costs() -> dict:
    """CPU time of a 40 x 40 basin map of the Fig. 3 scene with each method."""
    out = {}
    for method in ("flight_exact", "rk4_paper"):
        config = tmafm.Config("fig3", solver={"method": method})
        start = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
            data = tmafm.basin(config, a1=np.linspace(-5e-4, 5e-4, 40),
                               adot1=np.linspace(-1e-3, 1e-3, 40), workers=1, max_periods=100)
        cpu = time.process_time() - start
        out[method] = {"cpu_s": cpu, "mean_periods": float(data["periods"].mean()),
                       "steady_share": float((data["period"] > 0).mean())}
        print(f"basin 40 x 40 {method}: {cpu:.1f} s CPU, {out[method]['mean_periods']:.1f} "
              f"periods a point, {out[method]['steady_share']:.3f} steady", flush=True)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="write the table as JSON here")
    parser.add_argument("--basin", action="store_true", help="time a 40 x 40 basin map too")
    parser.add_argument("names", nargs="*", default=NAMES)
    args = parser.parse_args()
    table = {}
    print(f"{'input':22s} {'lag':>3s} {'measured':>9s} {'level':>9s} {'indep.':>9s} "
          f"{'m/level':>7s} {'m/indep':>7s}  stop (period, located)")
    for name in args.names:
        row = measure(name)
        table[name] = row
        ratio = lambda x: "   -   " if x is None else f"{x:7.3f}"  # noqa: E731
        print(f"{name:22s} {row['lag']:3d} {row['measured']:9.2e} {row['level']:9.2e} "
              f"{row['independent']:9.2e} {ratio(row['ratio_level'])} "
              f"{ratio(row['ratio_independent'])}  {row['stop_periods']:3d} "
              f"({row['stop_period']}, {row['located_period']})", flush=True)
    scaling = {}
    for dtau in (2e-3, 1e-3, 5e-4):
        run = tmafm.observe("fig3", max_periods=PERIODS, stop_at_steady=False, observables=(),
                            solver={"dtau": dtau})
        points = run.poincare
        scaling[dtau] = float(np.abs(points[-TAIL:] - points[-TAIL - 1:-1]).max()
                              / np.abs(points[-(TAIL + 8):]).max())
    print("fig3 measured jitter by dtau:", {k: f"{v:.2e}" for k, v in scaling.items()})
    located = {}
    for name, method, rtol in (("fig6", "flight_exact", 1e-7), ("fig6", "flight_exact", 1e-8),
                               ("fig6", "flight_exact", 1e-9), ("fig3", "dop853", 1e-7)):
        solver = {"method": method, "rtol": rtol, "atol": 1e-3 * rtol}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
            run = tmafm.observe(name, max_periods=PERIODS, stop_at_steady=False, observables=(),
                                solver=solver)
        points = run.poincare
        size = np.abs(points[-(TAIL + 8):]).max()
        located[f"{name} {method} rtol {rtol:g}"] = [
            float(np.abs(points[-TAIL:] - points[-TAIL - lag:-lag]).max() / size) for lag in (1, 2)]
    print("located methods' wander at lags 1, 2:",
          {k: [f"{x:.1e}" for x in v] for k, v in located.items()})
    basins = basin_costs() if args.basin else None
    if args.out:
        with open(args.out, "w") as handle:
            json.dump({"inputs": table, "dtau_scaling": scaling, "located": located,
                       "basin": basins}, handle, indent=1)
            handle.write("\n")


if __name__ == "__main__":
    main()
