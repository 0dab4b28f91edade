"""Instructions (callgrind) of the exact flight's contact scan and of whole runs, for one or
more `tmafm` executables (e.g. main's build and this one), printed as JSON.

    python benchmarks/flight_scan.py build-main/tmafm build-x/tmafm [--cpu 5]

Scenes (benchmarks/period_cost.py SCENES), method flight_exact at rtol 1e-7, atol 1e-10:
untilted_3 and tilted_hertz_3 over 1000 periods with one sample per period, Fig. 2 over 100
periods with sample_dtau 0.01, all written as .npz.  Per executable and scene: the run's
instructions, those of flight_first_contact (inclusive), the counters, and the scan's V_T
evaluations per flight (rhs_evaluations less 12 per contact step, which leaves the contact
steps' dense-output stages in: an upper bound, as in docs/performance.md).  --cpu N adds
the least CPU time (user + sys) of N interleaved runs of each executable.
"""

import argparse
import json
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
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", str(out)], check=True,
                          capture_output=True, text=True).stdout
    total = scan = 0
    for line in text.splitlines():
        if "PROGRAM TOTALS" in line:
            total = int(line.split()[0].replace(",", ""))
        if "flight_first_contact" in line and scan == 0:
            scan = int(line.split()[0].replace(",", ""))
    return total, scan


def cpu(exe, nml, folder):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([exe, "-q", str(nml)], check=True, cwd=folder)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("executables", nargs="+")
    parser.add_argument("--cpu", type=int, default=0)
    args = parser.parse_args()
    args.executables = [str(Path(e).resolve()) for e in args.executables]
    result = {}
    with tempfile.TemporaryDirectory() as folder:
        for name in RUNS:
            nml = write_scene(folder, name)
            row = {}
            for exe in args.executables:
                total, scan = callgrind(exe, nml, folder)
                c = np.load(Path(folder) / f"{name}.npz")["counters"]
                steps, contact_steps, _, rhs, _ = (int(x) for x in c)
                flights = steps - contact_steps
                row[exe] = {"instructions": total, "first_contact": scan,
                            "counters": [int(x) for x in c], "flights": flights,
                            "evaluations_per_flight": (rhs - 12 * contact_steps) / flights}
            for _ in range(args.cpu):
                for exe in args.executables:
                    t = cpu(exe, nml, folder)
                    row[exe]["cpu_s"] = min(row[exe].get("cpu_s", t), t)
            result[name] = row
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
