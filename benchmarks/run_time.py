"""CPU time of the tmafm executable (whole process) on a 100-period Fig. 2 run.

    /opt/tmafm-venv/bin/python benchmarks/run_time.py [--periods 100] [--repeat 5]
        [--baseline PATH [--baseline-label TEXT]] [--instructions] [--out benchmarks/results/run_time.json]

Runs inputs/fig2_n4.nml (N = 4) for `periods` drive periods at the input's sampling
(sample_dtau = 0.01), with the paper's scheme (rk4_paper, as the input asks) and with
flight_exact at its default tolerance, each writing the text format and the binary `.npz`
format. The time is the CPU time (user + sys) of the child process, from getrusage, so it
counts start-up, reading, integration and writing, and not the other load of a shared machine.
Each configuration is repeated and the cases are interleaved; the JSON holds the median, the
minimum and the maximum, and the counters of each run.

--baseline PATH times a second executable (e.g. a build of another commit: `meson setup
build-main && ninja -C build-main tmafm` in its checkout) in the same interleaved loop, so that
before and after see the same load; the JSON gets baseline_* entries and the ratio of medians.
--instructions also counts the instructions of one run of each case (and of the baseline)
under `valgrind --tool=callgrind`: unlike CPU time on a shared machine they do not vary.
"""

import argparse
import json
import math
import re
import resource
import shutil
import statistics
import subprocess
import tempfile
from pathlib import Path

import tmafm

CASES = [(method, fmt) for method in ("rk4_paper", "flight_exact") for fmt in ("text", "npy")]


def child_cpu(command) -> float:
    """CPU seconds (user + sys) of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def instructions(command) -> int:
    """Instructions executed by one run of `command` (valgrind's callgrind, whole process)."""
    proc = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
                           *command], check=True, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    return int(re.search(r"Collected\s*:\s*(\d+)", proc.stderr).group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--periods", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--baseline", default=None, help="another tmafm executable to time alongside")
    parser.add_argument("--baseline-label", default=None,
                        help="what the baseline is (e.g. 'main at e9a82f9'), stored in the JSON")
    parser.add_argument("--instructions", action="store_true",
                        help="also count instructions under valgrind (one run per case)")
    parser.add_argument("--out", default=None, help="also write the JSON here")
    args = parser.parse_args()
    exes = {"": tmafm.executable()}
    if args.baseline:
        exes["baseline_"] = str(Path(args.baseline).resolve())
    if args.instructions and shutil.which("valgrind") is None:
        parser.error("--instructions needs valgrind on PATH")
    base = tmafm.Config("fig2_n4")
    omega = base.scene["omega"]
    tau_end = args.periods * 2 * math.pi / omega
    report = {"input": "fig2_n4", "periods": args.periods, "tau_end": tau_end,
              "tmafm": tmafm.__version__, "clock": "CPU time (user + sys) of the whole process",
              "executable": exes[""], "cases": {}}
    if args.baseline:
        report["baseline"] = args.baseline_label or exes["baseline_"]
    times = {(prefix, case): [] for prefix in exes for case in CASES}
    with tempfile.TemporaryDirectory() as scratch:
        inputs = {}
        for method, fmt in CASES:
            name = f"{method}_{fmt}"
            target = Path(scratch) / (name + (".npz" if fmt == "npy" else ".dat"))
            config = tmafm.Config("fig2_n4", solver={"method": method, "tau_end": tau_end},
                                  output={"format": fmt, "file": str(target)})
            path = Path(scratch) / f"{name}.nml"
            config.write(path)
            inputs[(method, fmt)] = path
            result = config.run()
            report["cases"][name] = {"method": method, "format": fmt,
                                     "counters": result.counters, "rows": len(result.tau)}
        for _ in range(args.repeat):
            for case in CASES:
                for prefix, exe in exes.items():
                    times[(prefix, case)].append(child_cpu([exe, "-q", str(inputs[case])]))
        if args.instructions:
            for case in CASES:
                for prefix, exe in exes.items():
                    report["cases"][f"{case[0]}_{case[1]}"][prefix + "instructions"] = \
                        instructions([exe, "-q", str(inputs[case])])
    for (prefix, (method, fmt)), values in times.items():
        entry = report["cases"][f"{method}_{fmt}"]
        entry.update({prefix + "median_s": statistics.median(values),
                      prefix + "min_s": min(values), prefix + "max_s": max(values)})
    if args.baseline:
        for entry in report["cases"].values():
            entry["baseline_over_this"] = entry["baseline_median_s"] / entry["median_s"]
    text = json.dumps(report, indent=2)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
