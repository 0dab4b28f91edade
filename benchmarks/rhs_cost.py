"""Cost of one right-hand side and of whole runs: the core before the RHS/stage rework against
the working tree, in one run.

Builds the core at OLD_REV (default e9a82f9, main before the stage-phase and kernel rework)
and the working tree twice (with the working tree's meson.build, which turns on LTO, and with
-Db_lto=false, to separate the code from the flag), each in a temporary folder with meson
(buildtype=release), and measures with each:

- CPU ns per call of model%derivative (one sin/cos of Omega tau per call) and of
  model%derivative_at_phase (the phase given, as the pairs' stages now call it), out of and in
  contact, at N = 1, 3, 4, 8, 30 (benchmarks/rhs_cost_driver.f90; the best of 3 runs of
  200 000 calls; scene of the profile: alpha2 = 7e-4, theta = 0.2, Hertz, state with
  V_T = -1e-4 in contact);
- CPU time (user + sys) of whole `tmafm` processes on the two scenes of the speed work
  (benchmarks/period_cost.py): tilted_hertz_3 (N = 3, alpha2 = 7e-4, theta = 0.2,
  a0 = 2e-4, flight_exact at rtol 1e-7, atol 1e-10, 1000 periods, one sample per period) and
  fig2 (inputs/fig2_n4.nml, flight_exact defaults, 100 periods, sample_dtau 0.01), both to
  .npz; RUNS rounds, each round runs every build once (interleaved), median and minimum; and
  the run's counters (steps, contact steps, rejected steps, right-hand sides), which must not
  change;
- instructions of one tilted_hertz_3 process under `valgrind --tool=callgrind` (when valgrind
  is installed): a count the machine's load does not move;
- V_T evaluations per flight of flight_exact on Fig. 2 (N = 4, tau_end = 100, rtol 1e-10),
  an upper bound from the counters (see tests/test_rhs.py);
- CPU time of `tmafm --version`, the mean of 200 starts, and of /bin/true.

    python benchmarks/rhs_cost.py          # ~10 min on 2 cores; writes benchmarks/results/rhs_cost.json and .png

On a shared machine read the ratios within one run, not the milliseconds.
"""

from __future__ import annotations

import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from _builds import build, callgrind, export_revision, interleaved, link_flags, scene_file

REPO = Path(__file__).resolve().parent.parent
HERE = Path(__file__).resolve().parent
OLD_REV = os.environ.get("OLD_REV", "e9a82f9")
MODES = (1, 3, 4, 8, 30)
CALLS = 200_000
STARTS = 200
RUNS = int(os.environ.get("RUNS", "15"))

FLIGHTS = """
import sys, tmafm
r = tmafm.run(sys.argv[1], solver={"method": "flight_exact", "tau_end": 100.0, "rtol": 1e-10})
c = r.counters
flights = c["steps"] - c["contact_steps"]
print(flights, c["rhs_evaluations"] - 12 * (c["contact_steps"] + c["rejected_steps"]))
"""

#: scene -> (overrides of inputs/fig2_n4.nml); tau_end and sampling follow from periods.
PERIOD = math.pi   # Omega = 2
SCENES = {
    "tilted_hertz_3": ({"model": {"n_modes": 3, "convention": "paper"}, "scene": {"alpha2": 7e-4, "theta": 0.2},
                        "initial": {"a0": [2e-4, 0.0, 0.0]},
                        "solver": {"method": "flight_exact", "rtol": 1e-7, "atol": 1e-10,
                                   "tau_end": 1000 * PERIOD},
                        "output": {"sample_dtau": PERIOD}}),
    "fig2": ({"solver": {"method": "flight_exact", "tau_end": 100 * PERIOD},
              "output": {"sample_dtau": 0.01}}),
}



def kernel_costs(build_dir: Path, work: Path) -> dict:
    driver = work / "driver"
    subprocess.run(["gfortran", "-O3", "-fopenmp", "-o", str(driver), str(HERE / "rhs_cost_driver.f90"),
                    f"-I{build_dir / 'libtmafm_core.a.p'}", str(build_dir / "libtmafm_core.a"),
                    *link_flags(build_dir)], check=True)
    costs = {}
    for n in MODES:
        nml = work / f"n{n}.nml"
        nml.write_text(f"&model n_modes = {n}, convention = 'paper' /\n&scene alpha2 = 7e-4, theta = 0.2 /\n")
        runs = [subprocess.run([str(driver), str(nml), str(n), str(CALLS)], check=True,
                               capture_output=True, text=True).stdout.split() for _ in range(3)]
        costs[str(n)] = {key: min(float(r[k]) for r in runs) for k, key in
                         enumerate(("free_ns", "contact_ns", "free_at_phase_ns", "contact_at_phase_ns"), 1)}
    return costs


def flight_evaluations(source: Path, build_dir: Path, work: Path) -> float:
    package = work / "pkg" / "tmafm"
    package.mkdir(parents=True)
    for f in (source / "pywrap" / "tmafm").glob("*.py"):
        (package / f.name).symlink_to(f)
    for f in (build_dir / "pywrap").glob("*.so"):
        (package / f.name).symlink_to(f)
    for f in (build_dir / "pywrap").glob("_objects.py"):
        if not (package / f.name).exists():
            (package / f.name).symlink_to(f)
    env = dict(os.environ, PYTHONPATH=str(package.parent), TMAFM_EXE=str(build_dir / "tmafm"))
    out = subprocess.run([sys.executable, "-c", FLIGHTS, str(REPO / "inputs" / "fig2_n4.nml")],
                         check=True, capture_output=True, text=True, env=env, cwd=work).stdout
    flights, evaluations = map(int, out.split())
    return evaluations / flights


def start_cost(exe: str) -> float:
    """Mean CPU ms (user + sys) of one `exe --version`, fork and exec included."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    for _ in range(STARTS):
        subprocess.run([exe, "--version"], capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu / STARTS * 1e3


def run_costs(builds: dict[str, Path], work: Path) -> dict:
    """Whole-process CPU of each scene with each build, RUNS interleaved rounds."""
    result = {}
    for name in SCENES:
        nml = scene_file(name, SCENES[name], work)
        seconds, counters = interleaved(builds, nml, RUNS)
        result[name] = {label: {"median_ms": 1e3 * statistics.median(seconds[label]),
                                "min_ms": 1e3 * min(seconds[label]),
                                "counters": counters[label]} for label in builds}
        if name == "tilted_hertz_3":
            for label, build_dir in builds.items():
                result[name][label]["instructions"] = callgrind([str(build_dir / "tmafm"), "-q", str(nml)],
                                                                nml.parent)
    return result


def chart(data: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.4))
    curves = (("old", "free_ns", "--", "o"), ("old", "contact_ns", "--", "s"),
              ("new", "free_ns", "-", "o"), ("new", "contact_ns", "-", "s"),
              ("new", "free_at_phase_ns", ":", "o"), ("new", "contact_at_phase_ns", ":", "s"))
    for key, phase, style, marker in curves:
        rhs = data["builds"][key]["rhs"]
        left.loglog(MODES, [rhs[str(n)][phase] for n in MODES], style, marker=marker,
                    label=f"{key} ({data['builds'][key]['source']}), {phase[:-3].replace('_', ' ')}")
    left.set_xlabel("modes N")
    left.set_ylabel("CPU ns per right-hand side")
    left.set_xticks(MODES, [str(n) for n in MODES])
    left.set_title("model%derivative (one sin/cos per call) and derivative_at_phase")
    left.legend(fontsize=7)
    labels = list(data["builds"])
    width = 0.8 / len(labels)
    for k, label in enumerate(labels):
        values = [data["runs"][scene][label]["median_ms"] for scene in SCENES]
        bars = right.bar([j + k * width for j in range(len(SCENES))], values, width, label=label)
        right.bar_label(bars, fmt="%.0f", fontsize=7)
    right.set_xticks([j + width * (len(labels) - 1) / 2 for j in range(len(SCENES))], list(SCENES))
    right.set_ylabel(f"CPU ms per process (median of {RUNS}, interleaved)")
    right.set_title("whole runs: tilted_hertz_3 1000 periods, fig2 100 periods")
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        old_src = export_revision(OLD_REV, tmp / "old-src")
        variants = {"old": (OLD_REV, old_src, []),
                    "new_no_lto": ("working tree, -Db_lto=false", REPO, ["-Db_lto=false"]),
                    "new": ("working tree", REPO, [])}
        builds, results = {}, {}
        for key, (label, source, options) in variants.items():
            work = tmp / key
            work.mkdir()
            build(source, work / "build", options)
            builds[key] = work / "build"
            results[key] = {"source": label, "options": options, "lapack": link_flags(work / "build")}
            results[key]["rhs"] = kernel_costs(work / "build", work)
            results[key]["evaluations_per_flight"] = flight_evaluations(source, work / "build", work)
            results[key]["start_ms"] = start_cost(str(work / "build" / "tmafm"))
            print(json.dumps(results[key]), flush=True)
        (tmp / "runs").mkdir()
        runs = run_costs(builds, tmp / "runs")
    data = {"builds": results, "runs": runs, "calls": CALLS, "starts": STARTS, "rounds": RUNS,
            "start_ms_bin_true": start_cost("/bin/true"),
            "command": "python benchmarks/rhs_cost.py"}
    (HERE / "results" / "rhs_cost.json").write_text(json.dumps(data, indent=1) + "\n")
    chart(data, HERE / "results" / "rhs_cost.png")
    old, new = results["old"]["rhs"], results["new"]["rhs"]
    for n in MODES:
        o, w = old[str(n)], new[str(n)]
        print(f"N = {n:2d}: derivative free {o['free_ns']:7.1f} -> {w['free_ns']:7.1f} ns, "
              f"contact {o['contact_ns']:7.1f} -> {w['contact_ns']:7.1f} ns; at phase "
              f"free {o['free_at_phase_ns']:7.1f} -> {w['free_at_phase_ns']:7.1f} ns, "
              f"contact {o['contact_at_phase_ns']:7.1f} -> {w['contact_at_phase_ns']:7.1f} ns")
    for scene, by_build in runs.items():
        base = by_build["old"]["median_ms"]
        print(scene, ", ".join(f"{k}: {v['median_ms']:.1f} ms (x{base / v['median_ms']:.2f}, "
                               f"min {v['min_ms']:.1f}) {v['counters']}" for k, v in by_build.items()))


if __name__ == "__main__":
    main()
