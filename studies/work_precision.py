"""Work-precision study: error in V_T over tau in [0, tau_end] against wall time and against
right-hand-side evaluations, for every tmafm method and for scipy's solve_ivp with events on
a numpy right-hand side (the peer a Python user would write, studies/scipy_peer.py).

    /opt/tmafm-venv/bin/python studies/work_precision.py                  # full study (~15 min)
    /opt/tmafm-venv/bin/python studies/work_precision.py --out /tmp/wp --quick   # one scene
                                                              # (never into the committed folder)
    /opt/tmafm-venv/bin/python studies/work_precision.py --summarize studies/results/work_precision.json

Writes work_precision.json and work_precision.png into --out (default studies/results).  The
reference of each scene is flight_exact at rtol 1e-12; it is cross-checked against scipy
DOP853 with events at rtol 1e-12, and the difference is recorded.  Ratios at equal error are
interpolated in log-log.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path

import numpy as np

import tmafm
from tmafm import __version__, run
from tmafm._safefile import save_figure, write_text

from scipy_peer import ScipyPeer  # studies/scipy_peer.py, this script's sibling

REPO = Path(__file__).resolve().parent.parent

__all__ = ["study", "summarize", "plot", "main", "TARGET_ERRORS"]

TARGET_ERRORS = (1e-6, 1e-8, 1e-10)
SCENES = {"fig2": "fig2_n4.nml", "fig6": "fig6.nml", "fig7": "fig7_hertz.nml"}

TMAFM_SWEEPS = {
    "rk4_paper": ("dtau", [1.6e-2, 8e-3, 4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4]),
    "rk4_event": ("dtau", [1.6e-2, 8e-3, 4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4]),
    "dopri5": ("rtol", [1e-2, 1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]),
    "dop853": ("rtol", [1e-2, 1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]),
    "flight_exact": ("rtol", [1e-2, 1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]),
}
SCIPY_SWEEPS = {
    "scipy_RK45": ("RK45", [1e-3, 1e-4, 1e-6, 1e-8, 1e-10]),
    "scipy_DOP853": ("DOP853", [1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]),
    "scipy_Radau": ("Radau", [1e-3, 1e-4, 1e-6, 1e-8]),
    "scipy_LSODA": ("LSODA", [1e-3, 1e-4, 1e-6, 1e-8, 1e-10]),
}


def _best_time(fn, repeat):
    best, out = math.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def _time_at(points, target):
    """Interpolated time (or evaluations) at error `target`, log-log; None if not reached."""
    pts = sorted((p for p in points if p["error"] > 0), key=lambda p: p["error"])
    for lo, hi in zip(pts, pts[1:]):
        if lo["error"] <= target <= hi["error"]:
            w = (math.log(target) - math.log(lo["error"])) / (math.log(hi["error"]) - math.log(lo["error"]))
            return {key: math.exp(math.log(lo[key]) + w * (math.log(hi[key]) - math.log(lo[key])))
                    for key in ("seconds", "rhs_evaluations")}
    return None


def study(inputs: Path, scenes=SCENES, conventions=("paper", "consistent"), tau_end=20.0,
          sample_dtau=0.01, repeat=3, progress=print) -> dict:
    """Run the whole study and return the report (also what goes into the JSON)."""
    report = {"tmafm": __version__, "machine": platform.machine(), "python": platform.python_version(),
              "tau_end": tau_end, "sample_dtau": sample_dtau, "error": "max |V_T - V_T_ref| over the samples",
              "seconds": f"best of {repeat} in-process wall times (tmafm.run, or the scipy peer)",
              "scenes": {}}
    for scene, file in scenes.items():
        for convention in conventions:
            key = f"{scene}_{convention}"
            path = inputs / file
            common = dict(model={"convention": convention}, output={"sample_dtau": sample_dtau})
            reference = run(path, **common, solver={"method": "flight_exact", "tau_end": tau_end,
                                                    "rtol": 1e-12, "atol": 1e-20}).vt
            peer = ScipyPeer(path, **common)
            check = peer.solve(tau_end, sample_dtau, "DOP853", 1e-12, 1e-20)
            entry = {"input": f"inputs/{file}", "convention": convention,
                     "reference": "flight_exact rtol 1e-12 atol 1e-20",
                     "reference_vs_scipy_DOP853_1e-12": float(np.max(np.abs(check["vt"] - reference))),
                     "switches": int(len(check["switches"])), "methods": {}}
            for method, (knob, values) in TMAFM_SWEEPS.items():
                points = []
                for value in values:
                    solver = {"method": method, "tau_end": tau_end, knob: value}
                    if knob == "rtol":
                        solver["atol"] = value * 1e-6
                    try:
                        seconds, result = _best_time(lambda: run(path, **common, solver=solver), repeat)
                    except Exception as exc:  # a step past the stability limit: record it
                        points.append({knob: value, "failed": str(exc)})
                        continue
                    points.append({knob: value, "seconds": seconds,
                                   "rhs_evaluations": result.counters["rhs_evaluations"],
                                   "error": float(np.max(np.abs(result.vt - reference)))})
                entry["methods"][method] = points
                progress(f"{key} {method} done")
            for name, (scipy_method, rtols) in SCIPY_SWEEPS.items():
                points = []
                for rtol in rtols:
                    out = peer.solve(tau_end, sample_dtau, scipy_method, rtol, rtol * 1e-6)
                    points.append({"rtol": rtol, "seconds": out["seconds"],
                                   "rhs_evaluations": out["rhs_evaluations"],
                                   "error": float(np.max(np.abs(out["vt"] - reference)))})
                entry["methods"][name] = points
                progress(f"{key} {name} done")
            entry["at_equal_error"] = _equal_error(entry["methods"])
            report["scenes"][key] = entry
    return report


def paper_scheme_at_its_step(entry: dict, dtau: float = 2e-3) -> dict:
    """The paper's scheme at its own step against (a) rk4_event at the same step and (b) the
    fastest measured tmafm run at least as accurate."""
    paper = next(p for p in entry["methods"]["rk4_paper"] if p.get("dtau") == dtau and "error" in p)
    event = next(p for p in entry["methods"]["rk4_event"] if p.get("dtau") == dtau and "error" in p)
    candidates = [(p["seconds"], name, p) for name, pts in entry["methods"].items()
                  if not name.startswith("scipy") for p in pts
                  if "error" in p and p["error"] <= paper["error"]]
    seconds, name, best = min(candidates, key=lambda c: c[0])
    knob = "dtau" if "dtau" in best else "rtol"
    return {"rk4_paper_error": paper["error"], "rk4_paper_seconds": paper["seconds"],
            "rk4_event_error_same_step": event["error"],
            "error_ratio_paper_to_event_same_step": paper["error"] / event["error"],
            "fastest_as_accurate": {"method": name, knob: best[knob], "error": best["error"],
                                    "seconds": seconds},
            "time_ratio_paper_to_fastest_as_accurate": paper["seconds"] / seconds}


def summarize(report: dict) -> dict:
    """The headline ratios: per scene, scipy DOP853 against tmafm's best at equal error, and
    the paper's scheme at its own step."""
    out = {}
    for key, entry in report["scenes"].items():
        row = {"paper_scheme": paper_scheme_at_its_step(entry)}
        for target, eq in entry["at_equal_error"].items():
            row[f"scipy_DOP853_over_best_at_{target}"] = eq["time_ratio_to_best"].get("scipy_DOP853")
            row[f"best_at_{target}"] = eq["best_tmafm_method"]
        out[key] = row
    return out


def _equal_error(methods: dict) -> dict:
    table = {}
    for target in TARGET_ERRORS:
        costs = {name: _time_at([p for p in pts if "error" in p], target) for name, pts in methods.items()}
        tmafm_costs = {n: c for n, c in costs.items() if c and not n.startswith("scipy")}
        if not tmafm_costs:
            continue
        best = min(tmafm_costs, key=lambda n: tmafm_costs[n]["seconds"])
        row = {"best_tmafm_method": best, "seconds": {n: c["seconds"] if c else None for n, c in costs.items()},
               "time_ratio_to_best": {n: (c["seconds"] / tmafm_costs[best]["seconds"]) if c else None
                                      for n, c in costs.items()},
               "rhs_ratio_to_best": {n: (c["rhs_evaluations"] / tmafm_costs[best]["rhs_evaluations"]) if c else None
                                     for n, c in costs.items()}}
        table[f"{target:.0e}"] = row
    return table


STYLE = {"rk4_paper": ("tab:red", "o", "-"), "rk4_event": ("tab:orange", "s", "-"),
         "dopri5": ("tab:blue", "^", "-"), "dop853": ("tab:cyan", "v", "-"),
         "flight_exact": ("tab:green", "D", "-"),
         "scipy_RK45": ("tab:gray", "v", "--"), "scipy_DOP853": ("black", "P", "--"),
         "scipy_Radau": ("tab:purple", "x", "--"), "scipy_LSODA": ("tab:brown", "*", "--")}


def plot(report: dict, path: Path) -> None:
    """Error against seconds and against RHS evaluations, one row per scene."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(report["scenes"].items())
    fig, axes = plt.subplots(len(rows), 3, figsize=(16, 3.4 * len(rows)), squeeze=False)
    for (key, entry), (ax_t, ax_f, ax_tol) in zip(rows, axes):
        # What the tolerance means: the V_T error each rtol buys (atol = 1e-6 rtol).
        for name in ("dopri5", "dop853", "flight_exact"):
            ok = [p for p in entry["methods"].get(name, []) if "error" in p and p["error"] > 0]
            if ok:
                color, marker, line = STYLE[name]
                ax_tol.loglog([p["rtol"] for p in ok], [p["error"] for p in ok], line, color=color,
                              marker=marker, label=name)
        span = [1e-12, 1e-2]
        ax_tol.loglog(span, span, ":", color="0.5", label="error = rtol")
        ax_tol.loglog(span, [1e-3 * x for x in span], "--", color="0.7", label="error = 1e-3 rtol")
        ax_tol.set_xlabel("rtol (atol = 1e-6 rtol)")
        ax_tol.set_ylabel("max |V_T error| (gap units)")
        ax_tol.set_title(f"{key}: V_T error against the tolerance")
        ax_tol.grid(True, which="both", alpha=0.3)
        ax_tol.legend(fontsize=7)
        for name, points in entry["methods"].items():
            ok = [p for p in points if "error" in p and p["error"] > 0]
            if not ok:
                continue
            color, marker, line = STYLE.get(name, ("k", ".", "-"))
            err = [p["error"] for p in ok]
            ax_t.loglog([p["seconds"] for p in ok], err, line, color=color, marker=marker, label=name)
            ax_f.loglog([p["rhs_evaluations"] for p in ok], err, line, color=color, marker=marker, label=name)
        for ax, xlabel in ((ax_t, "wall time (s)"), (ax_f, "right-hand-side evaluations")):
            ax.set_xlabel(xlabel)
            ax.set_ylabel("max |V_T error| (gap units)")
            ax.set_title(f"{key}: {entry['input']}, tau <= {report['tau_end']:g}")
            ax.grid(True, which="both", alpha=0.3)
            for target in TARGET_ERRORS:
                ax.axhline(target, color="0.8", lw=0.8, zorder=0)
    axes[0][0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def main(argv=None) -> None:
    """Command line: regenerate work_precision.json and work_precision.png."""
    parser = argparse.ArgumentParser(description="tmafm work-precision study")
    parser.add_argument("--out", type=Path, default=REPO / "studies" / "results")
    parser.add_argument("--inputs", type=Path, default=tmafm.inputs.folder(),
                        help="folder of the figure inputs")
    parser.add_argument("--quick", action="store_true", help="Fig. 2 in `paper` only, one repeat")
    parser.add_argument("--tau-end", type=float, default=20.0)
    parser.add_argument("--summarize", type=Path, help="print the headline ratios of an existing JSON and stop")
    args = parser.parse_args(argv)
    if args.summarize:
        print(json.dumps(summarize(json.loads(args.summarize.read_text())), indent=1))
        return
    if args.quick and (args.out / "work_precision.json").exists() and not (args.out / ".quick").exists():
        parser.error(f"--quick would overwrite the full results in {args.out}: pass another --out")
    scenes = {"fig2": SCENES["fig2"]} if args.quick else SCENES
    conventions = ("paper",) if args.quick else ("paper", "consistent")
    report = study(args.inputs, scenes, conventions, tau_end=args.tau_end, repeat=1 if args.quick else 3)
    report["summary"] = summarize(report)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.quick:
        write_text(args.out / ".quick", "this folder holds a --quick run\n")
    write_text(args.out / "work_precision.json", json.dumps(report, indent=1))
    plot(report, args.out / "work_precision.png")
    print(json.dumps(report["summary"], indent=1))
    print(f"wrote {args.out / 'work_precision.json'} and {args.out / 'work_precision.png'}")


if __name__ == "__main__":
    main()
