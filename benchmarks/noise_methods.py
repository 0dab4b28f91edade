"""The methods with thermal noise (docs/model.md §21): error against CPU time on one realisation.

    /opt/tmafm-venv/bin/python benchmarks/noise_methods.py [--out DIR] [--repeats 3]

Every method integrates the same held force (one seed, one grid), so their trajectories differ by
their errors alone.  The reference is dop853 at rtol = 1e-13; flight_exact at rtol = 1e-13 is
checked against it (its flights are exact, its contacts dop853's).  For each method (dopri5,
dop853, flight_exact) and rtol in 1e-6, 1e-8, 1e-10 (atol = rtol 1e-4):

- the error: the largest |a_j - a_j ref| over the samples and modes, over the largest |a_j ref|;
- the CPU time (user + sys, the least of --repeats runs) of `tmafm.run` (the trajectory) and of
  `tmafm.observe` (the per-period observables, stop_at_steady=False) over the same time.

The scenes:
- free: inputs/thermal_air.nml driven at f0 to 1 nm (k = 2 N/m, 70 kHz, Q = 20, one mode,
  never in contact), 200 drive periods;
- tapping: inputs/tapping_polystyrene.nml (three modes, k = 40 N/m, 300 kHz, Q = 400, DMT with
  contact damping) at Z = 15 nm with its 20 nm free amplitude and the thermal noise of 298.15 K,
  its first 300 periods (ring-up from rest, then tapping).

Writes noise_methods.json and noise_methods.png (error against CPU, one panel a scene) into --out
(default benchmarks/results/).  Timed on a shared machine: read the ratios between methods in one
run, not the absolute times.
"""

import argparse
import json
import resource
from pathlib import Path

import f90nml
import numpy as np

import tmafm

REPO = Path(__file__).resolve().parent.parent
METHODS = ("dopri5", "dop853", "flight_exact")
RTOLS = (1e-6, 1e-8, 1e-10)


def cpu():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def groups(name):
    out = {k: dict(v) for k, v in f90nml.read(str(REPO / "inputs" / f"{name}.nml")).items()}
    out.pop("output", None)
    return out


def scenes():
    free = groups("thermal_air")
    free["physical"]["free_amplitude"] = 1e-9
    del free["physical"]["drive_amplitude"]
    tapping = groups("tapping_polystyrene")
    tapping["physical"]["tip_sample_distance"] = 15e-9
    tapping["physical"]["temperature"] = 298.15
    tapping["solver"]["thermal_noise"] = 1
    return {"free": (tmafm.Config(free), 200), "tapping": (tmafm.Config(tapping), 300)}


def timed(repeats, call):
    best, result = np.inf, None
    for _ in range(repeats):
        start = cpu()
        result = call()
        best = min(best, cpu() - start)
    return best, result


def measure(config, periods, repeats):
    omega = config.scene["omega"]
    tau_end = periods * 2 * np.pi / omega
    sample = 2 * np.pi / omega / 64

    def run(method, rtol):
        return tmafm.run(config, solver={"method": method, "rtol": rtol, "atol": rtol * 1e-4,
                                         "tau_end": tau_end, "noise_seed": 3},
                         output={"sample_dtau": sample})

    ref = run("dop853", 1e-13)
    scale = np.abs(ref.a).max()
    exact_ref = run("flight_exact", 1e-13)
    rows = []
    for method in METHODS:
        for rtol in RTOLS:
            t_run, traj = timed(repeats, lambda: run(method, rtol))  # noqa: B023
            t_obs, _ = timed(repeats, lambda: tmafm.observe(  # noqa: B023
                config, solver={"method": method, "rtol": rtol, "atol": rtol * 1e-4, "noise_seed": 3},
                max_periods=periods, stop_at_steady=False))
            rows.append({"method": method, "rtol": rtol, "error": float(np.abs(traj.a - ref.a).max() / scale),
                         "cpu_run_s": t_run, "cpu_observe_s": t_obs,
                         "contacts": int(np.count_nonzero(np.diff(traj.contact.astype(int)) == 1))})
            print(json.dumps(rows[-1]), flush=True)
    return {"periods": periods, "tau_end": tau_end,
            "reference": "dop853, rtol 1e-13",
            "flight_exact_1e-13_against_reference": float(np.abs(exact_ref.a - ref.a).max() / scale),
            "rows": rows}


def ratios(rows):
    """CPU of dop853 and dopri5 over flight_exact's at each rtol (run and observe)."""
    out = {}
    for rtol in RTOLS:
        by = {r["method"]: r for r in rows if r["rtol"] == rtol}
        for other in ("dop853", "dopri5"):
            for kind in ("run", "observe"):
                out[f"{other}_over_flight_exact_{kind}_{rtol:g}"] = \
                    by[other][f"cpu_{kind}_s"] / by["flight_exact"][f"cpu_{kind}_s"]
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    report = {"note": "CPU time user+sys, least of repeats, shared machine: read ratios", "scenes": {}}
    for name, (config, periods) in scenes().items():
        print(f"# {name}", flush=True)
        result = measure(config, periods, args.repeats)
        result["ratios"] = ratios(result["rows"])
        report["scenes"][name] = result
        print(json.dumps(result["ratios"]), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "noise_methods.json").write_text(json.dumps(report, indent=1) + "\n")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, (name, result) in zip(axes, report["scenes"].items()):
        for method, marker in zip(METHODS, "os^"):
            rows = [r for r in result["rows"] if r["method"] == method]
            ax.loglog([r["cpu_observe_s"] for r in rows], [max(r["error"], 1e-16) for r in rows],
                      marker=marker, label=f"{method} (observe)")
            ax.loglog([r["cpu_run_s"] for r in rows], [max(r["error"], 1e-16) for r in rows],
                      marker=marker, linestyle=":", color=ax.lines[-1].get_color(), label=f"{method} (run)")
        ax.set_title(f"{name}: {result['periods']} periods with thermal noise")
        ax.set_xlabel("CPU time (s, user + sys)")
        ax.set_ylabel("max |a - a_ref| / max |a_ref|")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.out / "noise_methods.png", dpi=110)


if __name__ == "__main__":
    main()
