"""Cost of a long-range force in flight (issue 29, item 5): a van der Waals approach curve under
`flight_exact` (its flight by the Lawson form of dop853, tmafm_lawson) against the same curve
under `dop853`, and against the same scene with DMT (no force in flight) under `flight_exact`,
at equal V_T error against a tight reference, in one run.

    python benchmarks/longrange_flight.py                 # -> benchmarks/results/
    python benchmarks/longrange_flight.py --out /tmp/lr   # elsewhere

The scene is inputs/tapping_polystyrene.nml (k = 40 N/m, f0 = 300 kHz, Q = 400, A0 = 20 nm, R =
10 nm on polystyrene, N = 3), with &model contact_law = 'dmt_vdw' and &physical hamaker = 1e-19 J,
intermolecular_distance = 0.165 nm for the vdW curve, as it is ('dmt') for the DMT curve.  The
curve: Z = 25 nm down to 0 in 40 points, then back up (80 runs), PERIODS drive periods per point,
each point started from the last state of the previous one (the first from the free steady
orbit at Z = 25 nm: a DMT flight_exact run of 2000 periods), samples every T/64.

Each (scene, method) runs the curve at rtol = RTOLS (and EXTRA_RTOLS) (atol = rtol/1000: the tip's tolerance is
then about as large as atol, docs/performance.md "What rtol and atol mean"); its V_T error is the
largest |V_T - V_T,ref| over every sample of the 80 runs, over the largest |V_T,ref|.  The
reference of each scene is its curve under flight_exact at rtol 1e-13 (atol 1e-17); the vdW
curve under dop853 at rtol 1e-13 is compared with it too (`reference_check`), which bounds what
the reference can resolve.  Cost is CPU time (user + sys of this process) of the runs alone
(the configurations are built outside the clock), the least of REPEATS repeats, which go
round all the curves in turn.  The costs at
equal error are log-log interpolations of cost against error between the measured rtols, at
the errors in TARGETS.  Writes longrange_flight.json and longrange_flight.png (work-precision).
"""

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import tmafm
from tmafm._safefile import save_figure, write_text

REPO = Path(__file__).resolve().parent.parent
SCENE = "tapping_polystyrene"
VDW = {"hamaker": 1.0e-19, "intermolecular_distance": 0.165e-9}
Z = np.linspace(25e-9, 0.0, 40)
PERIODS = 40
RTOLS = (1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
#: dop853 needs tighter tolerances for the same error (its flight steps are set by the top mode).
EXTRA_RTOLS = {"vdw_dop853": (1e-12,)}
REFERENCE_RTOL = 1e-13
REPEATS = 3
#: The V_T errors (relative to the largest |V_T|) at which the costs are compared.
TARGETS = (1e-6, 1e-7, 1e-8)
CASES = {
    "vdw_flight_exact": ("dmt_vdw", "flight_exact"),
    "vdw_dop853": ("dmt_vdw", "dop853"),
    "dmt_flight_exact": ("dmt", "flight_exact"),
}


def cpu_seconds() -> float:
    """User + sys CPU seconds of this process (time.process_time: finer than os.times' ticks)."""
    return time.process_time()


def start_state():
    """The free steady orbit at Z = 25 nm (DMT, flight_exact, 2000 periods): its last state."""
    config = tmafm.Config(SCENE, solver={"method": "flight_exact", "rtol": 1e-12, "atol": 1e-16,
                                         "tau_end": 2000 * period()})
    result = config.run()
    return result.a[-1].copy(), result.adot[-1].copy()


def period() -> float:
    return 2 * math.pi / tmafm.Config(SCENE).scene["omega"]


def curve(law: str, method: str, rtol: float, atol: float, start) -> tuple:
    """The approach and retract: V_T of every run, the CPU seconds of the runs and their work
    counters summed."""
    a, adot = start
    t = period()
    physical = VDW if law == "dmt_vdw" else {}
    vts, cpu, counters = [], 0.0, {}
    for z in list(Z) + list(Z[::-1]):
        config = tmafm.Config(SCENE, model={"contact_law": law}, physical={**physical, "tip_sample_distance": z},
                              initial={"a0": list(a), "adot0": list(adot)},
                              solver={"method": method, "rtol": rtol, "atol": atol, "tau_end": PERIODS * t},
                              output={"sample_dtau": t / 64})
        before = cpu_seconds()
        result = config.run()
        cpu += cpu_seconds() - before
        vts.append(result.vt)
        counters = {k: counters.get(k, 0) + v for k, v in result.counters.items()}
        a, adot = result.a[-1].copy(), result.adot[-1].copy()
    return np.concatenate(vts), cpu, counters


def error(vt, reference) -> float:
    return float(np.max(np.abs(vt - reference)) / np.max(np.abs(reference)))


def at_error(points, target):
    """Cost at V_T error `target`: log-log interpolation between measured (error, cpu) points
    (None outside their range)."""
    points = sorted(points)
    for (e0, c0), (e1, c1) in zip(points, points[1:]):
        if e0 <= target <= e1 and e1 > e0:
            x = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(c0) + x * (math.log(c1) - math.log(c0)))
    return None


LABELS = {"vdw_flight_exact": "vdW, `flight_exact`", "vdw_dop853": "vdW, `dop853`",
          "dmt_flight_exact": "DMT, `flight_exact`"}


def table_rows(report) -> list:
    """docs/performance.md's two tables (benchmarks/check_docs.py reads them from here): each
    curve's V_T error and CPU per rtol, and the costs and ratios at equal error."""
    rows = []
    for name, runs in report["runs"].items():
        for r in runs:
            c = r["counters"]
            rows.append(f"| {LABELS[name]} | {r['rtol']:.0e} | {r['error']:.2e} | {r['cpu_s']:.3f} | "
                        f"{c['steps'] - c['contact_steps']:,} | {c['contact_steps']:,} | {c['rejected_steps']:,} |")
    for target, entry in report["at_error"].items():
        cost = entry["cpu_s"]
        cells = [f"{cost[n]:.3f}" if cost[n] else "not reached" for n in LABELS]
        ratios = [f"{entry[k]:.2f}" if k in entry else "-" for k in ("ratio_to_dmt_flight_exact", "ratio_to_dop853")]
        rows.append(f"| {float(target):.0e} | " + " | ".join(cells + ratios) + " |")
    return rows


def plot(report, path: Path) -> None:
    from tmafm._extras import require
    plt = require("matplotlib.pyplot", "plot")
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for name, rows in report["runs"].items():
        ax.loglog([r["error"] for r in rows], [r["cpu_s"] for r in rows], "o-", label=LABELS[name].replace("`", ""))
        for r in rows:
            ax.annotate(f"{r['rtol']:.0e}", (r["error"], r["cpu_s"]), fontsize=6, xytext=(3, 3),
                        textcoords="offset points")
    ax.set_xlabel("V_T error / max|V_T| over the curve (80 runs)")
    ax.set_ylabel("CPU s (runs only)")
    ax.set_title(f"Approach + retract, 40 Z, {PERIODS} periods each (tapping_polystyrene)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = start_state()
    curve("dmt", "flight_exact", 1e-7, 1e-10, start)  # warm-up
    references = {law: curve(law, "flight_exact", REFERENCE_RTOL, REFERENCE_RTOL * 1e-4, start)[0]
                  for law in ("dmt_vdw", "dmt")}
    check = curve("dmt_vdw", "dop853", REFERENCE_RTOL, REFERENCE_RTOL * 1e-4, start)[0]
    # The repeats go round every curve in turn, so that a spell of load on the shared machine
    # falls on all of them alike; each curve keeps its least CPU.
    plan = [(name, rtol) for name in CASES for rtol in RTOLS + EXTRA_RTOLS.get(name, ())]
    measured = {key: {"costs": []} for key in plan}
    for _ in range(REPEATS):
        for name, rtol in plan:
            law, method = CASES[name]
            vt, cpu, counters = curve(law, method, rtol, rtol / 1000, start)
            measured[(name, rtol)].update(error=error(vt, references[law]), counters=counters)
            measured[(name, rtol)]["costs"].append(cpu)
    runs = {name: [] for name in CASES}
    for name, rtol in plan:
        m = measured[(name, rtol)]
        runs[name].append({"rtol": rtol, "atol": rtol / 1000, "error": m["error"], "cpu_s": min(m["costs"]),
                           "cpu_s_all": m["costs"], "counters": m["counters"]})
        print(name, runs[name][-1])
    at_targets = {}
    for target in TARGETS:
        cost = {name: at_error([(r["error"], r["cpu_s"]) for r in rows], target) for name, rows in runs.items()}
        entry = {"cpu_s": cost}
        if cost["vdw_flight_exact"] and cost["dmt_flight_exact"]:
            entry["ratio_to_dmt_flight_exact"] = cost["vdw_flight_exact"] / cost["dmt_flight_exact"]
        if cost["vdw_flight_exact"] and cost["vdw_dop853"]:
            entry["ratio_to_dop853"] = cost["vdw_flight_exact"] / cost["vdw_dop853"]
        at_targets[f"{target:.0e}"] = entry
        print(target, entry)
    report = {
        "command": "python benchmarks/longrange_flight.py",
        "scene": f"inputs/{SCENE}.nml; vdW: contact_law 'dmt_vdw', &physical hamaker = 1e-19, "
                 "intermolecular_distance = 0.165e-9",
        "z_nm": [float(z) * 1e9 for z in Z], "periods_per_point": PERIODS, "runs_per_curve": 2 * len(Z),
        "reference_rtol": REFERENCE_RTOL,
        "reference_check": {"dop853_vs_flight_exact_vdw": error(check, references["dmt_vdw"])},
        "repeats": REPEATS, "runs": runs, "at_error": at_targets,
    }
    write_text(args.out / "longrange_flight.json", json.dumps(report, indent=1) + "\n")
    plot(report, args.out / "longrange_flight.png")
    print("\n".join(table_rows(report)))


if __name__ == "__main__":
    main()
