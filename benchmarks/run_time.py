"""Wall time of the tmafm executable (whole process) on a long fig2_n4 run.

    /opt/tmafm-venv/bin/python benchmarks/run_time.py [--periods 100] [--repeat 5]

Prints JSON: the median, min and max wall time over the repeats, with the step counters,
for the output written at the input's sample_dtau (0.01) and with output thinned to 1 sample
per tau unit (which isolates the integration from the text output).
"""

import argparse
import json
import math
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import f90nml

import tmafm

REPO = Path(__file__).resolve().parent.parent


def time_run(exe, nml, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run([exe, "-q", str(nml)], check=True)
        times.append(time.perf_counter() - start)
    return {"median_s": statistics.median(times), "min_s": min(times), "max_s": max(times)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--periods", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    exe = tmafm.executable()
    tau_end = args.periods * 2 * math.pi / 2.0  # the drive period is 2 pi / Omega, Omega = 2
    report = {"input": "inputs/fig2_n4.nml", "periods": args.periods, "tau_end": tau_end,
              "tmafm": tmafm.__version__}
    with tempfile.TemporaryDirectory() as scratch:
        for label, sample_dtau in (("sample_dtau_0.01", 0.01), ("sample_dtau_1", 1.0)):
            groups = f90nml.read(str(tmafm.inputs.path("fig2_n4")))
            groups["solver"]["tau_end"] = tau_end
            groups["output"]["sample_dtau"] = sample_dtau
            groups["output"]["file"] = str(Path(scratch) / f"{label}.dat")
            path = Path(scratch) / f"{label}.nml"
            groups.write(str(path), force=True)
            report[label] = time_run(exe, path, args.repeat)
        counters = tmafm.run(path).counters
    report["counters"] = counters
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
