"""Steps, rejections and right-hand sides per drive period of the adaptive methods, with the V_T
error they buy, for two or more `tmafm` executables side by side (e.g. main and a branch).

    python benchmarks/contact_steps.py --exe main=/path/build-main/tmafm --exe new=build-x/tmafm \
        --out /tmp/cs [--periods 1000] [--repeats 3] [--methods flight_exact dop853 dopri5] \
        [--instructions 100]
    python benchmarks/contact_steps.py --table benchmarks/results/contact_steps.json [--out DIR]  # DIR: redraw chart

The committed results compare the main branch before the `steps` work with it (quick
builds: `git archive <commit> | tar -x -C /tmp/before && cd /tmp/before && meson setup
build-main && ninja -C build-main tmafm`, and `meson setup build-x && ninja -C build-x tmafm`
in this checkout), run as
    /opt/tmafm-venv/bin/python benchmarks/contact_steps.py --exe main=/tmp/before/build-main/tmafm \
        --exe steps=build-x/tmafm --instructions 100 --methods flight_exact dop853 dopri5 --out benchmarks/results

Scenes: those of benchmarks/period_cost.py.  Counters: the `counters` of a run over `periods`
drive periods with one output row per period (npz), divided by the periods; contacts per
period = phase switches / 2.  Cost: CPU time (user + sys) of that whole process, the smallest
of `repeats` runs, the executables interleaved run by run so that they share the machine's
load; compare ratios within one run of this script.  Error: max |V_T - V_T_ref| over the first
20 periods, sampled every 0.05, against the FIRST executable's flight_exact at rtol 1e-13,
atol 1e-18, and its ratio to the per-step V_T tolerance atol + rtol S_V (S_V taken as the
reference's largest |V_T|).  With --instructions N, also the instructions of a whole process
over N periods under `valgrind --tool=callgrind` (CPU time on a shared machine is noisy;
this count is not).  Writes contact_steps.json and contact_steps.png into --out.
"""

import argparse
import json
import math
import re
import resource
import subprocess
import tempfile
from pathlib import Path

import f90nml
import numpy as np

REPO = Path(__file__).resolve().parent.parent
PERIOD = math.pi  # Omega = 2 in every scene here
ERROR_PERIODS = 20
#: name -> (input file, overrides): benchmarks/period_cost.py's scenes.
SCENES = {
    "tilted_hertz_3": ("fig2_n4.nml", {"model": {"n_modes": 3},
                                       "scene": {"alpha2": 7e-4, "theta": 0.2},
                                       "initial": {"a0": [2e-4, 0.0, 0.0]}}),
    "fig2": ("fig2_n4.nml", {}),
    "untilted_3": ("fig2_n4.nml", {"model": {"n_modes": 3},
                                   "scene": {"alpha2": 7e-4, "theta": 0.0, "alpha4": 0.0},
                                   "initial": {"a0": [2e-4, 0.0, 0.0]}}),
    "dmt_fig7": ("fig7_dmt.nml", {}),
}
TOLERANCES = [(1e-7, 1e-10), (1e-10, 1e-14)]
COUNTERS = ("steps", "contact_steps", "rejected_steps", "rhs_evaluations", "phase_switches")


def namelist(scene, solver, periods, sample_dtau, out_file):
    file, overrides = SCENES[scene]
    nml = {g: dict(v) for g, v in f90nml.read(str(REPO / "inputs" / file)).items()}
    for g, v in overrides.items():
        nml.setdefault(g, {}).update(v)
    nml["solver"] = {"method": solver["method"], "rtol": solver["rtol"], "atol": solver["atol"],
                     "tau_end": periods * PERIOD}
    nml["output"] = {"sample_dtau": sample_dtau, "file": str(out_file), "format": "npy"}
    return nml


def run(exe, nml, scratch):
    """(CPU seconds of the whole process, the npz archive's arrays)."""
    path = Path(scratch) / "run.nml"
    f90nml.write(f90nml.Namelist(nml), str(path), force=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([exe, "-q", str(path)], check=True, cwd=scratch)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    with np.load(nml["output"]["file"]) as z:
        return cpu, {k: z[k] for k in z.files}


def instructions(exe, nml, scratch):
    """Instructions of one whole tmafm process under callgrind."""
    path = Path(scratch) / "run.nml"
    f90nml.write(f90nml.Namelist(nml), str(path), force=True)
    out = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", exe, "-q",
                          str(path)], check=True, cwd=scratch, capture_output=True, text=True)
    return int(re.search(r"Collected\s*:\s*(\d+)", out.stderr).group(1))


def study(exes, periods, repeats, methods, instruction_periods=0, progress=print):
    report = {"periods": periods, "repeats": repeats, "executables": dict(exes),
              "instruction_periods": instruction_periods,
              "cost": "smallest CPU (user+sys) of the whole tmafm process over the repeats / periods",
              "error": f"max |V_T - V_T_ref| over {ERROR_PERIODS} periods, samples every 0.05; "
                       f"ref: {exes[0][0]} flight_exact rtol 1e-13 atol 1e-18",
              "rows": []}
    with tempfile.TemporaryDirectory() as scratch:
        out = str(Path(scratch) / "out.npz")
        for scene in SCENES:
            ref_solver = {"method": "flight_exact", "rtol": 1e-13, "atol": 1e-18}
            _, ref = run(exes[0][1], namelist(scene, ref_solver, ERROR_PERIODS, 0.05, out), scratch)
            for method in methods:
                for rtol, atol in TOLERANCES:
                    solver = {"method": method, "rtol": rtol, "atol": atol}
                    # The per-step V_T tolerance (tmafm_error_scale), S_V ~ the largest |V_T|.
                    tolerance = atol + rtol * float(np.max(np.abs(ref["vt"])))
                    row = {"scene": scene, **solver, "vt_tolerance": tolerance}
                    for name, exe in exes:
                        _, arrays = run(exe, namelist(scene, solver, ERROR_PERIODS, 0.05, out), scratch)
                        error = float(np.max(np.abs(arrays["vt"] - ref["vt"])))
                        row[name] = {"vt_error": error, "vt_error_over_tolerance": error / tolerance}
                    long = namelist(scene, solver, periods, PERIOD, out)
                    for _ in range(repeats):
                        for name, exe in exes:
                            cpu, arrays = run(exe, long, scratch)
                            entry = row[name]
                            entry["cpu_us_per_period"] = min(entry.get("cpu_us_per_period", math.inf),
                                                             1e6 * cpu / periods)
                            counts = dict(zip(COUNTERS, (int(c) for c in arrays["counters"])))
                            entry.update({f"{k}_per_period": v / periods for k, v in counts.items()})
                    if instruction_periods:
                        short = namelist(scene, solver, instruction_periods, PERIOD, out)
                        for name, exe in exes:
                            row[name]["instructions_per_period"] = \
                                instructions(exe, short, scratch) / instruction_periods
                    report["rows"].append(row)
                    progress(line(row, [n for n, _ in exes]))
    return report


def line(row, names):
    parts = [f"{row['scene']:15s} {row['method']:12s} rtol {row['rtol']:.0e}"]
    for n in names:
        e = row[n]
        parts.append(f"{n}: {e['steps_per_period']:6.1f} st {e['rejected_steps_per_period']:5.2f} rej "
                     f"{e['rhs_evaluations_per_period']:6.0f} rhs {e['cpu_us_per_period']:6.1f} us "
                     f"err {e['vt_error']:.2e}"
                     + (f" {e['instructions_per_period'] / 1e3:.0f}k ins" if "instructions_per_period" in e else ""))
    return " | ".join(parts)


def plot(report, names, path):
    """Per row, the ratio of each later executable to the first: RHS evaluations and (if
    counted) instructions per period."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = report["rows"]
    base, others = names[0], names[1:]
    series = [(f"RHS {n}/{base}", n, "rhs_evaluations_per_period") for n in others]
    series += [(f"instructions {n}/{base}", n, "instructions_per_period") for n in others
               if "instructions_per_period" in rows[0][n]]
    fig, ax = plt.subplots(figsize=(max(6, 0.5 * len(rows)), 4.5))
    width = 0.8 / len(series)
    for i, (label, n, key) in enumerate(series):
        ax.bar([k + i * width for k in range(len(rows))], [r[n][key] / r[base][key] for r in rows],
               width, label=label)
    ax.axhline(1.0, color="0.3", lw=0.8)
    ax.set_ylim(0.8, 1.1)
    ax.set_xticks([k + 0.4 - width / 2 for k in range(len(rows))])
    ax.set_xticklabels([f"{r['scene']}\n{r['method']}\nrtol {r['rtol']:.0e}" for r in rows],
                       fontsize=6, rotation=90)
    ax.set_ylabel(f"per drive period, relative to {base}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def table(report):
    """The markdown table of docs/performance.md: the first two executables, before -> after."""
    a, b = list(report["executables"])[:2]
    lines = [f"| scene | method | rtol, atol | steps | rejected | RHS | instructions {b}/{a} | "
             f"CPU {b}/{a} | V_T error | error / tolerance |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in report["rows"]:
        x, y = r[a], r[b]
        ins = (f"{y['instructions_per_period'] / x['instructions_per_period']:.3f}"
               if "instructions_per_period" in x else "")
        lines.append(
            f"| {r['scene']} | `{r['method']}` | {r['rtol']:g}, {r['atol']:g} "
            f"| {x['steps_per_period']:.1f} → {y['steps_per_period']:.1f} "
            f"| {x['rejected_steps_per_period']:.2f} → {y['rejected_steps_per_period']:.2f} "
            f"| {x['rhs_evaluations_per_period']:.0f} → {y['rhs_evaluations_per_period']:.0f} | {ins} "
            f"| {y['cpu_us_per_period'] / x['cpu_us_per_period']:.2f} "
            f"| {x['vt_error']:.2e} → {y['vt_error']:.2e} "
            f"| {x['vt_error_over_tolerance']:.1f} → {y['vt_error_over_tolerance']:.1f} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", action="append", help="NAME=PATH, two or more")
    parser.add_argument("--table", type=Path, help="print the markdown table of a JSON and stop")
    parser.add_argument("--periods", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--methods", nargs="+", default=["flight_exact"])
    parser.add_argument("--scenes", nargs="+", default=list(SCENES))
    parser.add_argument("--instructions", type=int, default=0, metavar="N",
                        help="also count instructions over N periods under callgrind")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    if args.table:
        report = json.loads(args.table.read_text())
        print(table(report))
        if args.out:
            plot(report, list(report["executables"]), args.out / "contact_steps.png")
        return
    if not args.exe or len(args.exe) < 2 or args.out is None:
        parser.error("--exe NAME=PATH twice or more, and --out, are required")
    exes = [tuple(e.split("=", 1)) for e in args.exe]
    exes = [(n, str(Path(p).resolve())) for n, p in exes]
    for name in [s for s in SCENES if s not in args.scenes]:
        del SCENES[name]
    report = study(exes, args.periods, args.repeats, args.methods, args.instructions)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "contact_steps.json").write_text(json.dumps(report, indent=1))
    plot(report, [n for n, _ in exes], args.out / "contact_steps.png")
    print(f"wrote {args.out / 'contact_steps.json'} and {args.out / 'contact_steps.png'}")


if __name__ == "__main__":
    main()
