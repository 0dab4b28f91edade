"""Instructions (callgrind) of the exact flight's contact scan and of whole runs, for one or
more `tmafm` executables (e.g. main's build and this one), printed as JSON.

    python benchmarks/flight_scan.py build-main/tmafm build-x/tmafm [--cpu 5] [--png FILE]

Each executable is labelled in the chart by its folder (or its file name if not `tmafm`).

Scenes (benchmarks/period_cost.py SCENES), method flight_exact at rtol 1e-7, atol 1e-10:
untilted_3 and tilted_hertz_3 over 1000 periods with one sample per period, Fig. 2 over 100
periods with sample_dtau 0.01, all written as .npz.  Per executable and scene: the run's
instructions, those of flight_first_contact (inclusive), the counters, and the scan's V_T
evaluations per flight (rhs_evaluations less 12 per contact step, which leaves the contact
steps' dense-output stages in: an upper bound, as in docs/performance.md), and the inclusive
instructions of the output samples: flight_sample (the exact flight's state at a sample) and
trajectory_store_at_phase (the row, V_T and dV_T of every sample), each also per call.
--cpu N adds the least CPU time (user + sys) of N interleaved runs of each executable.
--png FILE draws the run's instructions per scene and the Fig. 2 split (chart next to the JSON:
benchmarks/results/flight_scan.png).
"""

import argparse
import json
import re
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import f90nml
import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "benchmarks"))
from period_cost import PERIOD, SCENES  # noqa: E402

RUNS = {"untilted_3": ("untilted_3_no_contact_damping", 1000, PERIOD),
        "tilted_hertz_3": ("tilted_hertz_3", 1000, PERIOD),
        "fig2": ("fig2", 100, 0.01)}


def write_scene(folder, name):
    scene, periods, dtau = RUNS[name]
    file, overrides = SCENES[scene]
    nml = {g: dict(v) for g, v in f90nml.read(str(REPO / "inputs" / file)).items()}
    for g, v in overrides.items():
        nml.setdefault(g, {}).update(v)
    nml["solver"] = {"method": "flight_exact", "rtol": 1e-7, "atol": 1e-10,
                     "tau_end": periods * PERIOD}
    nml["output"] = {"file": f"{name}.npz", "format": "npy", "sample_dtau": dtau}
    path = Path(folder) / f"{name}.nml"
    f90nml.write(f90nml.Namelist(nml), str(path), force=True)
    return path


def callgrind(exe, nml, folder):
    out = Path(folder) / "cg.out"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", exe, "-q",
                    str(nml)], check=True, cwd=folder, capture_output=True)
    # Run from the scratch folder: from inside the source tree callgrind_annotate keys some
    # functions by relative and some by absolute path and splits their counts.
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", str(out)], check=True,
                          capture_output=True, text=True, cwd=folder).stdout
    total = scan = 0
    for line in text.splitlines():
        if "PROGRAM TOTALS" in line:
            total = int(line.split()[0].replace(",", ""))
        if "flight_first_contact" in line and scan == 0:
            scan = int(line.split()[0].replace(",", ""))
    # Inclusive instructions of a function (its "*" line in the caller tree) and its calls
    # (the sum over its callers, the "<" lines above it).
    tree = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--tree=caller", str(out)],
                          check=True, capture_output=True, text=True, cwd=folder).stdout
    parts, calls = {}, {}
    callers = 0
    for line in tree.split("-- Auto-annotated source")[0].splitlines():
        if not line.strip():
            callers = 0
        elif " < " in line:
            count = re.search(r"\(([\d,]+)x\)", line)
            callers += int(count.group(1).replace(",", "")) if count else 0
        elif " *  " in line:
            for name in ("flight_sample", "trajectory_store_at_phase"):
                if re.search(rf"MOD_{name}(\.[a-z0-9.]+)? \[", line):
                    parts[name] = parts.get(name, 0) + int(line.split()[0].replace(",", ""))
                    calls[name] = calls.get(name, 0) + callers
    return total, scan, parts, calls


def cpu(exe, nml, folder):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([exe, "-q", str(nml)], check=True, cwd=folder)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("executables", nargs="+")
    parser.add_argument("--cpu", type=int, default=0)
    parser.add_argument("--png", default=None, help="also draw the chart here")
    args = parser.parse_args()
    args.executables = [str(Path(e).resolve()) for e in args.executables]
    result = {}
    with tempfile.TemporaryDirectory() as folder:
        for name in RUNS:
            nml = write_scene(folder, name)
            row = {}
            for exe in args.executables:
                total, scan, parts, calls = callgrind(exe, nml, folder)
                c = np.load(Path(folder) / f"{name}.npz")["counters"]
                steps, contact_steps, _, rhs, _ = (int(x) for x in c)
                flights = steps - contact_steps
                samples = {name: {"instructions": parts.get(name, 0), "calls": calls.get(name, 0),
                                  "per_call": parts.get(name, 0) / max(calls.get(name, 0), 1)}
                           for name in ("flight_sample", "trajectory_store_at_phase")}
                row[exe] = {"instructions": total, "first_contact": scan, "samples": samples,
                            "counters": [int(x) for x in c], "flights": flights,
                            "evaluations_per_flight": (rhs - 12 * contact_steps) / flights}
            for _ in range(args.cpu):
                for exe in args.executables:
                    t = cpu(exe, nml, folder)
                    row[exe]["cpu_s"] = min(row[exe].get("cpu_s", t), t)
            result[name] = row
    print(json.dumps(result, indent=1))
    if args.png:
        chart(result, args.png)


def chart(result, png):
    """Left: the run's instructions per scene and executable; right: Fig. 2 split into the
    flight scan, the flight samples, the sample store and the rest."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    exes = list(next(iter(result.values())))
    labels = [Path(e).name if Path(e).name != "tmafm" else Path(e).parent.name for e in exes]
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    width = 0.8 / len(exes)
    for i, exe in enumerate(exes):
        left.bar([k + i * width for k in range(len(result))],
                 [result[name][exe]["instructions"] / 1e6 for name in result], width,
                 label=labels[i])
    left.set_xticks([k + 0.4 - width / 2 for k in range(len(result))], list(result))
    left.set_ylabel("instructions of the run (M, callgrind)")
    left.legend()
    fig2 = result["fig2"]
    bottom = [0.0] * len(exes)
    for part in ("first_contact", "flight_sample", "trajectory_store_at_phase", "rest"):
        values = []
        for exe in exes:
            r = fig2[exe]
            known = {"first_contact": r["first_contact"],
                     "flight_sample": r["samples"]["flight_sample"]["instructions"],
                     "trajectory_store_at_phase":
                         r["samples"]["trajectory_store_at_phase"]["instructions"]}
            known["rest"] = r["instructions"] - sum(known.values())
            values.append(known[part] / 1e6)
        right.bar(labels, values, bottom=bottom, label=part)
        bottom = [b + v for b, v in zip(bottom, values)]
    right.set_ylabel("instructions (M)")
    right.set_title("fig2, 100 periods, 31 416 samples (npz)")
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == "__main__":
    main()
