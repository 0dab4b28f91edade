"""dop853's steady test on a free orbit of a high-Q lever against dopri5 and flight_exact
(issue 27, "Accuracy of the steady test"; tmafm_method_adaptive dop853_mode_reach and
dopri5_mode_reach).

    python benchmarks/steady_dop853.py [--out benchmarks/results/steady_dop853.json]

tapping_polystyrene (N = 3, Q3 ~ 7000; rtol 1e-9, atol 1e-13 as the input gives them) 25 nm
from the sample, so the tip never touches it: tmafm.observe(..., max_periods=6000,
steady_tol=1e-8, observables=()) per method, and the same at the default tolerances with N = 4
(dop853, dopri5 and flight_exact). Last, fig3 with dop853 at the defaults (300 periods at most,
steady_tol 1e-6), whose points fell into a two-period cycle of the step pattern. For each: the
period found (0: none), the periods run, the closest repeat (relative to the orbit's size), the
mean step of 200 tau of the same run times omega_N (flight_exact: one flight counts one step),
the largest period-to-period change of each state component over the last 50 periods, and the
CPU time (user + sys of this process).
"""

import argparse
import json
import resource
import warnings

import numpy as np

import tmafm

CASES = [
    ("flight_exact", {}, {}),
    ("dopri5", {}, {}),
    ("dop853", {}, {}),
    ("dop853", {"rtol": 1e-7, "atol": 1e-10}, {"n_modes": 4}),
    ("dopri5", {"rtol": 1e-7, "atol": 1e-10}, {"n_modes": 4}),
    ("flight_exact", {"rtol": 1e-7, "atol": 1e-10}, {"n_modes": 4}),
]
#: fig3 (in contact once a period) with dop853 at the default tolerances and steady_tol.
FIG3 = ("fig3", {"method": "dop853"}, 300)


def _cpu():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def measure(method, solver, model, max_periods=6000):
    """One observed free run; its period, periods run, closest repeat, component jitter, CPU."""
    start = _cpu()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        obs = tmafm.observe("tapping_polystyrene", max_periods=max_periods, steady_tol=1e-8,
                            solver={"method": method, **solver}, model=model, observables=())
    cpu = _cpu() - start
    points = obs.poincare
    # The mean step of 200 tau of the same run, in units of 1/omega_N (omega_N = beta_N^2, what
    # the caps dop853_mode_reach and dopri5_mode_reach bound).
    config = tmafm.Config("tapping_polystyrene", solver={"method": method, "tau_end": 200.0, **solver},
                          model=model)
    omega_n = float(np.asarray(config.model()._f.beta)[config.n_modes - 1]) ** 2
    mean_h_omega = 200.0 / config.run().counters["steps"] * omega_n
    jitter = np.abs(np.diff(points[-50:], axis=0)).max(axis=0)
    return {"method": method, "solver": solver, "model": model, "period": int(obs.period),
            "periods_run": len(points) - 1, "closest": obs.evidence["closest"],
            "mean_h_omega_n": round(mean_h_omega, 4),
            "component_jitter": [float(x) for x in jitter], "cpu_s": round(cpu, 3)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="write the rows as JSON here")
    args = parser.parse_args(argv)
    rows = [measure(*case) for case in CASES]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.UnsteadyWarning)
        start = _cpu()
        obs = tmafm.observe(FIG3[0], solver=FIG3[1], max_periods=FIG3[2])
    rows.append({"input": FIG3[0], "method": "dop853", "solver": {}, "model": {},
                 "period": int(obs.period), "periods_run": len(obs.poincare) - 1,
                 "closest": obs.evidence["closest"], "cpu_s": round(_cpu() - start, 3)})
    for row in rows:
        print(f"{row['method']:13s} {str(row['solver']):32s} {str(row['model']):16s} "
              f"period {row['period']} after {row['periods_run']} periods, closest "
              f"{row['closest']:.3g}, mean h omega_N {row.get('mean_h_omega_n', '-')}, CPU {row['cpu_s']} s")
    if args.out:
        with open(args.out, "w") as handle:
            json.dump(rows, handle, indent=1)
            handle.write("\n")


if __name__ == "__main__":
    main()
