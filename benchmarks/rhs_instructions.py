"""Instructions per right-hand side and per whole run: an older commit against the working tree.

Builds the core at OLD_REV (default c023ff6) and the working tree (buildtype=release, the
tree's meson options, so LTO on), each in a temporary folder, and measures with each:

- instructions per call of model%derivative_at_phase (the phase given, as the pairs' stages call
  it) and of model%derivative (one sin/cos of Omega tau per call), out of and in contact, at
  N = 1, 2, 3, 4, 5, 8, 30: benchmarks/rhs_cost_driver.f90 with one KIND at a time under
  `valgrind --tool=callgrind`, (I(R2) - I(R1)) / (R2 - R1) for R1 = 1000 and R2 = 11000 calls, so
  start-up and set-up cancel (scene of rhs_cost.py: alpha2 = 7e-4, theta = 0.2, Hertz,
  V_T = -1e-4 in contact);
- instructions of whole `tmafm` processes (callgrind) on the two inputs of issue 8's targets,
  with the run counters, which must not change: tilted_hertz_3 (N = 3, alpha2 = 7e-4,
  theta = 0.2, a0 = 2e-4, flight_exact at rtol 1e-10, atol 1e-14, 200 periods, one sample per
  period) and fig2 (inputs/fig2_n4.nml, flight_exact defaults, 100 periods, sample_dtau 0.01),
  both to .npz;
- CPU time (user + sys) of those processes, RUNS interleaved rounds (default 21), median and
  the median of the per-round ratios old / new.

    python benchmarks/rhs_instructions.py     # ~5 min on 2 cores; writes benchmarks/results/rhs_instructions.json, .png

Instruction counts do not move with the machine's load; on a shared machine read the CPU
ratios, not the milliseconds.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import tempfile
from pathlib import Path

from _builds import TARGET_RUNS, build, callgrind, export_revision, interleaved, link_flags, scene_file

REPO = Path(__file__).resolve().parent.parent
HERE = Path(__file__).resolve().parent
OLD_REV = os.environ.get("OLD_REV", "c023ff6")
MODES = (1, 2, 3, 4, 5, 8, 30)
KINDS = {1: "free", 2: "contact", 3: "free_at_phase", 4: "contact_at_phase"}
CALLS = (1000, 11000)
RUNS = int(os.environ.get("RUNS", "21"))
SCENES = TARGET_RUNS



def kernel_instructions(build_dir: Path, work: Path) -> dict:
    driver = work / "driver"
    subprocess.run(["gfortran", "-O3", "-fopenmp", "-o", str(driver), str(HERE / "rhs_cost_driver.f90"),
                    f"-I{build_dir / 'libtmafm_core.a.p'}", str(build_dir / "libtmafm_core.a"),
                    *link_flags(build_dir)], check=True)
    result = {}
    for n in MODES:
        nml = work / f"n{n}.nml"
        nml.write_text(f"&model n_modes = {n}, convention = 'paper' /\n&scene alpha2 = 7e-4, theta = 0.2 /\n")
        result[str(n)] = {}
        for kind, name in KINDS.items():
            counts = [callgrind([str(driver), str(nml), str(n), str(calls), str(kind)], work)
                      for calls in CALLS]
            result[str(n)][name] = (counts[1] - counts[0]) / (CALLS[1] - CALLS[0])
    return result


def run_costs(builds: dict[str, Path], work: Path) -> dict:
    result = {}
    for name in SCENES:
        nml = scene_file(name, SCENES[name], work)
        seconds, counters = interleaved(builds, nml, RUNS)
        result[name] = {label: {"median_ms": 1e3 * statistics.median(seconds[label]),
                                "counters": counters[label],
                                "instructions": callgrind([str(build_dir / "tmafm"), "-q", str(nml)],
                                                          work)}
                        for label, build_dir in builds.items()}
        result[name]["median_ratio_old_over_new"] = statistics.median(
            o / w for o, w in zip(seconds["old"], seconds["new"]))
    return result


def chart(data: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.4))
    for key, style in (("old", "--"), ("new", "-")):
        rhs = data["builds"][key]["rhs"]
        for kind, marker in (("free_at_phase", "o"), ("contact_at_phase", "s")):
            left.loglog(MODES, [rhs[str(n)][kind] for n in MODES], style, marker=marker,
                        label=f"{key} ({data['builds'][key]['source']}), {kind.replace('_', ' ')}")
    left.set_xlabel("modes N")
    left.set_ylabel("instructions per call (callgrind)")
    left.set_xticks(MODES, [str(n) for n in MODES])
    left.set_title("model%derivative_at_phase")
    left.legend(fontsize=7)
    width = 0.4
    for k, label in enumerate(("old", "new")):
        values = [data["runs"][scene][label]["instructions"] / 1e6 for scene in SCENES]
        bars = right.bar([j + k * width for j in range(len(SCENES))], values, width,
                         label=f"{label} ({data['builds'][label]['source']})")
        right.bar_label(bars, fmt="%.1f", fontsize=8)
    right.set_xticks([j + width / 2 for j in range(len(SCENES))],
                     ["tilted_hertz_3, rtol 1e-10, 200 periods", "fig2, 100 periods"])
    right.set_ylabel("million instructions per process (callgrind)")
    right.set_title("whole runs")
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        old_src = export_revision(OLD_REV, tmp / "old-src")
        builds, results = {}, {}
        for key, label, source in (("old", OLD_REV, old_src), ("new", "working tree", REPO)):
            work = tmp / key
            work.mkdir()
            build(source, work / "build")
            builds[key] = work / "build"
            results[key] = {"source": label, "rhs": kernel_instructions(work / "build", work)}
            print(json.dumps(results[key]), flush=True)
        (tmp / "runs").mkdir()
        runs = run_costs(builds, tmp / "runs")
    data = {"builds": results, "runs": runs, "calls": CALLS, "rounds": RUNS,
            "command": "python benchmarks/rhs_instructions.py"}
    (HERE / "results" / "rhs_instructions.json").write_text(json.dumps(data, indent=1) + "\n")
    chart(data, HERE / "results" / "rhs_instructions.png")
    old, new = results["old"]["rhs"], results["new"]["rhs"]
    for n in MODES:
        print(f"N = {n:2d}: " + ", ".join(f"{kind} {old[str(n)][kind]:6.0f} -> {new[str(n)][kind]:6.0f}"
                                          for kind in KINDS.values()))
    for name in SCENES:
        r = runs[name]
        print(f"{name}: instructions {r['old']['instructions'] / 1e6:.1f} M -> "
              f"{r['new']['instructions'] / 1e6:.1f} M, CPU {r['old']['median_ms']:.1f} -> "
              f"{r['new']['median_ms']:.1f} ms (median ratio {r['median_ratio_old_over_new']:.3f}), "
              f"counters {'equal' if r['old']['counters'] == r['new']['counters'] else 'DIFFER'}")


if __name__ == "__main__":
    main()
