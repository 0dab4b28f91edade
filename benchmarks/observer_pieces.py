"""flight_exact's observer on short flight pieces: with thermal noise a flight is cut at every
point of the noise grid (the fastest mode's period/32), and the observer integrates and scans
each piece (tmafm_flight_observables).  This compares the package installed in this
interpreter (head) with an earlier revision (base), in one run:

    /opt/tmafm-venv/bin/python benchmarks/observer_pieces.py --base c2dc51b [--repeats 5] \\
        [--instructions] [--out benchmarks/results]

The base revision is exported and installed into a temporary folder (pip --target, about two
minutes); --base-dir DIR takes such a folder instead.  The cases (tmafm.observe,
stop_at_steady=False, every observable):
- noisy_flight_exact, noisy_dop853: inputs/tapping_polystyrene.nml with &solver thermal_noise = 1,
  noise_seed = 3, 400 drive periods (out of contact: every flight is cut at the grid);
- quiet_polystyrene: the same input without noise on flight_exact, 4000 periods;
- quiet_fig2_n3: inputs/fig2_n3.nml on flight_exact, 1000 periods (two contacts a period).
Each case runs in a process of its own, base and head alternately, --repeats times; its CPU
time (user + sys) is the least.  With --instructions each also runs once under valgrind's
callgrind, counting the core's batch only (--toggle-collect observe_batch; deterministic for a
build and machine).  Writes observer_pieces.json and observer_pieces.png into --out.  Timed on
a shared machine: read the ratios within one run (head/base, flight_exact/dop853), not the
absolute times.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
NOISE = {"thermal_noise": 1, "noise_seed": 3}
#: name -> (input, solver overrides, periods)
CASES = {
    "noisy_flight_exact": ("tapping_polystyrene", {"method": "flight_exact", **NOISE}, 400),
    "noisy_dop853": ("tapping_polystyrene", {"method": "dop853", **NOISE}, 400),
    "quiet_polystyrene": ("tapping_polystyrene", {"method": "flight_exact"}, 4000),
    "quiet_fig2_n3": ("fig2_n3", {"method": "flight_exact"}, 1000),
}


def child(name: str) -> None:
    """Run one case in this process; print its CPU seconds and last amplitude as JSON."""
    import tmafm
    scene, solver, periods = CASES[name]
    start = resource.getrusage(resource.RUSAGE_SELF)
    obs = tmafm.observe(scene, max_periods=periods, stop_at_steady=False, solver=solver)
    end = resource.getrusage(resource.RUSAGE_SELF)
    cpu = (end.ru_utime - start.ru_utime) + (end.ru_stime - start.ru_stime)
    print(json.dumps({"cpu_s": cpu, "periods": int(obs.periods),
                      "amplitude": float(obs.per_period["amplitude"][-1])}))


def environment(package_dir: Path | None) -> dict:
    env = dict(os.environ)
    if package_dir is not None:
        env["PYTHONPATH"] = str(package_dir)
    return env


def run_child(name: str, package_dir: Path | None) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", name], env=environment(package_dir),
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def instructions(name: str, package_dir: Path | None) -> int:
    """The core batch's instructions of one case under callgrind."""
    done = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
                           "--toggle-collect=__tmafm_batch_MOD_observe_batch*", sys.executable, __file__,
                           "--child", name], env=environment(package_dir), check=True, capture_output=True,
                          text=True)
    return int(re.search(r"Collected : (\d+)", done.stderr).group(1))


def install_revision(rev: str, into: Path) -> Path:
    """Revision `rev` of this repository, built and installed into into/pkg (pip --target)."""
    source = into / "src"
    source.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(source)], input=archive, check=True)
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-build-isolation", "--no-deps",
                    "--target", str(into / "pkg"), str(source)], check=True, capture_output=True)
    return into / "pkg"


def chart(report: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(CASES)
    fig, ax = plt.subplots(figsize=(8, 4))
    width = 0.38
    for k, build in enumerate(("base", "head")):
        values = [report["cases"][n][build]["cpu_s"] for n in names]
        ax.bar([i + (k - 0.5) * width for i in range(len(names))], values, width,
               label=f"{build} ({report[build]})")
    ax.set_xticks(range(len(names)), names, fontsize=8)
    ax.set_ylabel("CPU time of tmafm.observe (s, user + sys)")
    ax.set_title("flight_exact's observer on the noise grid's flight pieces")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", help="the earlier revision (exported and installed)")
    parser.add_argument("--base-dir", type=Path, help="a folder with the earlier build installed")
    parser.add_argument("--head", default="HEAD", help="the revision the installed package was built from "
                        "(recorded only)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--instructions", action="store_true")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child(args.child)
        return 0
    if (args.base is None) == (args.base_dir is None):
        parser.error("give one of --base REV and --base-dir DIR")
    with tempfile.TemporaryDirectory() as work:
        base_dir = args.base_dir or install_revision(args.base, Path(work))
        builds = {"base": base_dir, "head": None}
        cases = {name: {b: {"cpu_s": float("inf")} for b in builds} for name in CASES}
        for _ in range(args.repeats):
            for name in CASES:
                for build, folder in builds.items():
                    got = run_child(name, folder)
                    row = cases[name][build]
                    row["cpu_s"] = min(row["cpu_s"], got["cpu_s"])
                    row["periods"], row["amplitude"] = got["periods"], got["amplitude"]
        if args.instructions:
            for name in CASES:
                for build, folder in builds.items():
                    cases[name][build]["instructions"] = instructions(name, folder)
    for name, row in cases.items():
        row["cpu_head_over_base"] = row["head"]["cpu_s"] / row["base"]["cpu_s"]
        if args.instructions:
            row["instructions_head_over_base"] = row["head"]["instructions"] / row["base"]["instructions"]
        print(name, json.dumps(row), flush=True)
    report = {"base": args.base or str(args.base_dir), "head": args.head, "repeats": args.repeats,
              "note": "CPU time user+sys, least of repeats, shared machine: read ratios", "cases": cases,
              "flight_exact_over_dop853_noisy": {
                  b: cases["noisy_flight_exact"][b]["cpu_s"] / cases["noisy_dop853"][b]["cpu_s"] for b in builds}}
    print(json.dumps(report["flight_exact_over_dop853_noisy"]))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "observer_pieces.json").write_text(json.dumps(report, indent=1) + "\n")
    chart(report, args.out / "observer_pieces.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
