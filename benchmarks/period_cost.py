"""Cost per drive period of every method on four scenes, with the V_T error it buys, and tmafm
against scipy's solve_ivp (DOP853 with events) at equal error.

    /opt/tmafm-venv/bin/python benchmarks/period_cost.py [--periods 1000] [--skip-scipy]
    /opt/tmafm-venv/bin/python benchmarks/period_cost.py --out /tmp/pc --periods 50   # quick look
    /opt/tmafm-venv/bin/python benchmarks/period_cost.py --table benchmarks/results/period_cost.json
    /opt/tmafm-venv/bin/python benchmarks/period_cost.py --baseline OLD/build/tmafm \
        --baseline-label 'main at abc1234' --instructions --repeat 9    # before/after in one run

Cost: CPU time (user + sys) of the whole `tmafm` process over `periods` drive periods, one
output row per period, divided by the periods (the least of --repeat runs, default 3, for the
adaptive methods); every number comes from the same run of this script, so compare ratios.
Error: max |V_T - V_T_ref| over the first 20 periods, sampled every 0.05, against flight_exact
at rtol 1e-13, atol 1e-18.  The scipy peer (studies/scipy_peer.py) integrates 100 periods at
rtol 1e-10 (its call timed whole, in CPU time); tmafm is timed as a whole process at the
tolerance whose error is closest to the peer's
without exceeding it.  Writes period_cost.json and period_cost.png into --out (default
benchmarks/results/; the committed results are the default run).

--baseline PATH times another tmafm executable (a build of an earlier commit) in the same loop,
run for run interleaved with this one, so both see the same load of the shared machine; each
row then also holds baseline_us_per_period.  --instructions counts, under valgrind's callgrind,
the instructions per period of flight_exact at the two headline tolerances (and of the
baseline): unlike CPU time they do not depend on the machine's load.
"""

import argparse
import json
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import tmafm
from run_time import instructions

REPO = Path(__file__).resolve().parent.parent
PERIOD = math.pi  # 2 pi / Omega, Omega = 2 in every scene here
BASE = REPO / "inputs" / "fig2_n4.nml"

#: name -> (input file, overrides)
SCENES = {
    "fig2": ("fig2_n4.nml", {}),
    "tilted_hertz_3": ("fig2_n4.nml", {"model": {"n_modes": 3},
                                       "scene": {"alpha2": 7e-4, "theta": 0.2},
                                       "initial": {"a0": [2e-4, 0.0, 0.0]}}),
    "untilted_3_no_contact_damping": ("fig2_n4.nml", {"model": {"n_modes": 3},
                                                      "scene": {"alpha2": 7e-4, "theta": 0.0,
                                                                "alpha4": 0.0},
                                                      "initial": {"a0": [2e-4, 0.0, 0.0]}}),
    "dmt_fig7": ("fig7_dmt.nml", {}),
}
FIXED = {"rk4_paper": {"dtau": 2e-3}, "rk4_event": {"dtau": 2e-3}}
ADAPTIVE = ("dopri5", "dop853", "flight_exact")
#: (rtol, atol) settings of the adaptive methods: the profile's, the defaults, and a sweep in
#: half-decades (atol = rtol / 1000), so that "the loosest tolerance with error <= x" is resolved.
TOLERANCES = [(1e-10, 1e-14), (1e-7, 1e-10), (3e-6, 3e-9), (1e-6, 1e-9), (3e-7, 3e-10),
              (3e-8, 3e-11), (1e-8, 1e-11), (3e-9, 3e-12), (1e-9, 1e-12), (3e-10, 3e-13)]
#: Each process is timed this many times and the least CPU time is kept (the shared machine
#: only ever adds time).
REPEAT = 3
ERROR_PERIODS = 20


def groups(scene, solver, periods, sample_dtau, out_file):
    file, overrides = SCENES[scene]
    import f90nml
    nml = {g: dict(v) for g, v in f90nml.read(str(REPO / "inputs" / file)).items()}
    for g, v in overrides.items():
        nml.setdefault(g, {}).update(v)
    nml.setdefault("solver", {}).update(solver, tau_end=periods * PERIOD)
    nml.setdefault("output", {}).update(sample_dtau=sample_dtau, file=str(out_file))
    return nml


#: The executables timed: "" is this build's; "baseline_" another one (--baseline), and what it is.
EXECUTABLES = {}
BASELINE_LABEL = None


def write_input(nml, scratch):
    """The namelist dict as a file in scratch, for the executables."""
    import f90nml
    path = Path(scratch) / "run.nml"
    f90nml.write(f90nml.Namelist(nml), str(path), force=True)
    return path


def process_cpu(nml, scratch, repeat=None):
    """CPU seconds (user + sys) of one whole process of each executable (EXECUTABLES, or this
    build's alone) on the namelist dict: the least of `repeat` runs, the executables taking
    turns run by run.  A dict prefix -> seconds."""
    path = write_input(nml, scratch)
    exes = EXECUTABLES or {"": tmafm.executable()}
    times = {prefix: [] for prefix in exes}
    for _ in range(REPEAT if repeat is None else repeat):
        for prefix, exe in exes.items():
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run([exe, "-q", str(path)], check=True, cwd=scratch)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            times[prefix].append((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))
    return {prefix: min(values) for prefix, values in times.items()}


def vt_error(scene, solver, reference):
    nml = groups(scene, solver, ERROR_PERIODS, 0.05, "unused.dat")
    result = tmafm.run(nml)
    return float(np.max(np.abs(result.vt - reference))), result.counters


#: The tolerances whose instructions --instructions counts: the default and the issue's rtol 1e-10.
HEADLINE = ((1e-7, 1e-10), (1e-10, 1e-14))


def study(periods, with_scipy, progress=print, methods=None, count_instructions=False):
    report = {"tmafm": tmafm.__version__, "periods": periods, "repeat": REPEAT,
              "cost": "CPU (user+sys) of the whole tmafm process / periods; one row per period",
              "error": f"max |V_T - V_T_ref| over {ERROR_PERIODS} periods, samples every 0.05; "
                       "ref flight_exact rtol 1e-13 atol 1e-18",
              "scenes": {}}
    if "baseline_" in EXECUTABLES:
        report["baseline"] = BASELINE_LABEL or EXECUTABLES["baseline_"]
    with tempfile.TemporaryDirectory() as scratch:
        for scene in SCENES:
            reference = tmafm.run(groups(scene, {"method": "flight_exact", "rtol": 1e-13, "atol": 1e-18},
                                         ERROR_PERIODS, 0.05, "unused.dat")).vt
            rows = []
            settings = [(m, dict(s)) for m, s in FIXED.items()]
            settings += [(m, {"rtol": r, "atol": a}) for m in ADAPTIVE for r, a in TOLERANCES]
            settings = [(m, s) for m, s in settings if methods is None or m in methods]
            for method, solver in settings:
                solver = {"method": method, **solver}
                error, counters = vt_error(scene, solver, reference)
                nml = groups(scene, solver, periods, PERIOD, "out.dat")
                cpu = process_cpu(nml, scratch, repeat=1 if method in FIXED else REPEAT)
                rows.append({**solver, "us_per_period": 1e6 * cpu[""] / periods, "vt_error": error,
                             "rhs_per_period_error_window": counters["rhs_evaluations"] / ERROR_PERIODS})
                if "baseline_" in cpu:
                    rows[-1]["baseline_us_per_period"] = 1e6 * cpu["baseline_"] / periods
                if count_instructions and method == "flight_exact" and (solver["rtol"], solver["atol"]) in HEADLINE:
                    path = write_input(nml, scratch)
                    for prefix, exe in (EXECUTABLES or {"": tmafm.executable()}).items():
                        rows[-1][prefix + "instructions_per_period"] = \
                            instructions([exe, "-q", str(path)]) / periods
                progress(f"{scene} {solver}: {rows[-1]['us_per_period']:.1f} us/period, error {error:.2e}")
            entry = {"input": SCENES[scene][0], "overrides": SCENES[scene][1], "rows": rows}
            cheapest = [r for r in rows if r["vt_error"] <= 1e-9]
            if cheapest:
                entry["cheapest_with_vt_error_le_1e-9"] = min(cheapest, key=lambda r: r["us_per_period"])
            report["scenes"][scene] = entry
        if with_scipy:
            report["scipy"] = scipy_comparison(scratch, progress)
    return report


def scipy_comparison(scratch, progress, periods=100, scene="tilted_hertz_3"):
    """scipy DOP853 with events at rtol 1e-10 on `periods` periods, against tmafm at equal error."""
    sys.path.insert(0, str(REPO / "studies"))  # the peer is a study, not part of the package
    from scipy_peer import ScipyPeer
    sample = 0.05
    reference = tmafm.run(groups(scene, {"method": "flight_exact", "rtol": 1e-13, "atol": 1e-18},
                                 periods, sample, "unused.dat")).vt
    peer = ScipyPeer(groups(scene, {}, periods, sample, "unused.dat"))
    start = time.process_time()
    out = peer.solve(periods * PERIOD, sample, "DOP853", 1e-10, 1e-16)
    scipy_cpu = time.process_time() - start
    n = min(len(out["vt"]), len(reference))
    scipy_error = float(np.max(np.abs(out["vt"][:n] - reference[:n])))
    progress(f"scipy DOP853 rtol 1e-10: {scipy_cpu:.1f} s CPU, error {scipy_error:.2e}")
    best = None
    for method in ("flight_exact", "dop853"):
        for rtol, atol in sorted(TOLERANCES, reverse=True):
            solver = {"method": method, "rtol": rtol, "atol": atol}
            result = tmafm.run(groups(scene, solver, periods, sample, "unused.dat"))
            error = float(np.max(np.abs(result.vt - reference)))
            if error <= scipy_error:
                cpu = process_cpu(groups(scene, solver, periods, sample, "out.dat"), scratch)[""]
                if best is None or cpu < best["cpu_s"]:
                    best = {**solver, "cpu_s": cpu, "vt_error": error}
                break
    return {"scene": scene, "periods": periods, "sample_dtau": sample,
            "scipy_DOP853_rtol_1e-10": {"cpu_s": scipy_cpu, "vt_error": scipy_error,
                                        "rhs_evaluations": out["rhs_evaluations"]},
            "tmafm_at_equal_error": best,
            "ratio": scipy_cpu / best["cpu_s"] if best else None,
            "how": "scipy: CPU of the whole peer.solve call; tmafm: CPU of the whole process "
                   "(start-up, input, output file included), at the loosest tolerance whose "
                   "error does not exceed scipy's"}


def plot(report, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scenes = list(report["scenes"].items())
    fig, axes = plt.subplots(1, len(scenes), figsize=(4.2 * len(scenes), 4), squeeze=False)
    colors = {"rk4_paper": "tab:red", "rk4_event": "tab:orange", "dopri5": "tab:blue",
              "dop853": "tab:purple", "flight_exact": "tab:green"}
    for ax, (name, entry) in zip(axes[0], scenes):
        for method, color in colors.items():
            rows = sorted((r for r in entry["rows"] if r["method"] == method and r["vt_error"] > 0),
                          key=lambda r: r["vt_error"])
            if rows:
                ax.loglog([r["us_per_period"] for r in rows], [r["vt_error"] for r in rows], "o-",
                          color=color, label=method)
        ax.axhline(1e-9, color="0.7", lw=0.8)
        ax.set_xlabel("CPU per drive period (µs)")
        ax.set_ylabel("max |V_T error| (gap units)")
        ax.set_title(name, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def table(report):
    """The markdown tables of docs/performance.md, from a report."""
    lines = []
    rows = [r for entry in report["scenes"].values() for r in entry["rows"]]
    counted = [k for k in ("instructions_per_period", "baseline_instructions_per_period")
               if any(k in r for r in rows)]
    extra_head = " µs, baseline |" if "baseline" in report else ""
    extra_head += "".join(f" {k.replace('_', ' ')} |" for k in counted)
    extra_rule = "---|" * (extra_head.count("|"))
    if "baseline" in report:
        lines += [f"baseline: {report['baseline']}", ""]
    for name, entry in report["scenes"].items():
        lines += [f"**{name}** (`inputs/{entry['input']}` with {json.dumps(entry['overrides'])})", "",
                  "| method | setting | µs per period | V_T error |" + extra_head, "|---|---|---|---|" + extra_rule]
        for r in entry["rows"]:
            setting = f"dtau {r['dtau']:g}" if "dtau" in r else f"rtol {r['rtol']:g}, atol {r['atol']:g}"
            extra = ""
            if "baseline" in report:
                extra = f" {r['baseline_us_per_period']:.0f} |"
            if counted:
                extra += "".join(f" {r[k] / 1e3:.0f} k |" if k in r else " |" for k in counted)
            lines.append(f"| `{r['method']}` | {setting} | {r['us_per_period']:.0f} | {r['vt_error']:.1e} |"
                         + extra)
        lines.append("")
    if "scipy" in report:
        s = report["scipy"]
        peer, best = s["scipy_DOP853_rtol_1e-10"], s["tmafm_at_equal_error"]
        lines.append(f"scipy DOP853 (rtol 1e-10), {s['periods']} periods of {s['scene']}: "
                     f"{peer['cpu_s']:.2f} s CPU, V_T error {peer['vt_error']:.1e}; tmafm "
                     f"`{best['method']}` at rtol {best['rtol']:g}, atol {best['atol']:g}: "
                     f"{best['cpu_s']:.3f} s CPU (whole process), error {best['vt_error']:.1e}; "
                     f"ratio {s['ratio']:.0f}x")
    return "\n".join(lines)


def main():
    global REPEAT, BASELINE_LABEL
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", type=Path, help="print the markdown tables of a JSON and stop")
    parser.add_argument("--periods", type=int, default=1000)
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results")
    parser.add_argument("--skip-scipy", action="store_true")
    parser.add_argument("--repeat", type=int, default=REPEAT,
                        help="time each adaptive run this many times and keep the least")
    parser.add_argument("--methods", nargs="+", choices=list(FIXED) + list(ADAPTIVE),
                        help="only these methods (a partial run must go to --out)")
    parser.add_argument("--baseline", type=Path, help="another tmafm executable, timed interleaved")
    parser.add_argument("--baseline-label", help="what the baseline is, stored in the JSON")
    parser.add_argument("--instructions", action="store_true",
                        help="count instructions per period (callgrind) at the headline tolerances")
    args = parser.parse_args()
    if args.table:
        print(table(json.loads(args.table.read_text())))
        return
    if args.out.resolve() == (REPO / "benchmarks" / "results").resolve() and (args.periods != 1000 or args.methods):
        parser.error("a shortened or partial run must not overwrite the committed results: pass --out")
    if args.instructions and shutil.which("valgrind") is None:
        parser.error("--instructions needs valgrind on PATH")
    if args.baseline:
        if not os.access(args.baseline, os.X_OK):
            parser.error(f"--baseline {args.baseline}: not an executable file")
        EXECUTABLES.update({"": tmafm.executable(), "baseline_": str(args.baseline.resolve())})
        BASELINE_LABEL = args.baseline_label
    REPEAT = args.repeat
    report = study(args.periods, not args.skip_scipy, methods=args.methods,
                   count_instructions=args.instructions)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "period_cost.json").write_text(json.dumps(report, indent=1))
    plot(report, args.out / "period_cost.png")
    print(f"wrote {args.out / 'period_cost.json'} and {args.out / 'period_cost.png'}")


if __name__ == "__main__":
    main()
