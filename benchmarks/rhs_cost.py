"""Cost of one right-hand side, of a flight scan, and of process start: old against new, in one run.

Builds the core at OLD_REV (default d9e0afe, before the kernel rework) and at the working
tree, each in a temporary folder with meson (buildtype=release), and measures with each:

- CPU ns per call of model%derivative, out of and in contact, at N = 1, 3, 4, 8, 30
  (benchmarks/rhs_cost_driver.f90; the best of 3 runs of 200 000 calls; scene of the profile:
  alpha2 = 7e-4, theta = 0.2, Hertz, state with V_T = -1e-4 in contact);
- V_T evaluations per flight of flight_exact on Fig. 2 (N = 4, tau_end = 100, rtol 1e-10),
  an upper bound from the counters (see tests/test_rhs.py);
- CPU time (user + sys of the child) of `tmafm --version`, the mean of 200 starts, and of
  /bin/true, the floor of fork + exec on the machine.

    python benchmarks/rhs_cost.py          # ~5 min on 2 cores; writes rhs_cost.json and .png
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
HERE = Path(__file__).resolve().parent
OLD_REV = os.environ.get("OLD_REV", "d9e0afe")
MODES = (1, 3, 4, 8, 30)
CALLS = 200_000
STARTS = 200

FLIGHTS = """
import sys, tmafm
r = tmafm.run(sys.argv[1], solver={"method": "flight_exact", "tau_end": 100.0, "rtol": 1e-10})
c = r.counters
flights = c["steps"] - c["contact_steps"]
print(flights, c["rhs_evaluations"] - 6 * (c["contact_steps"] + c["rejected_steps"]))
"""


def build(source: Path, build_dir: Path) -> None:
    subprocess.run(["meson", "setup", str(build_dir), str(source), "-Dbuildtype=release"],
                   check=True, capture_output=True)
    subprocess.run(["ninja", "-C", str(build_dir), "-j", "2"], check=True, capture_output=True)


def link_flags(build_dir: Path) -> list[str]:
    """The LAPACK and BLAS the build itself linked the executable with (from build.ninja)."""
    lines = (build_dir / "build.ninja").read_text().splitlines()
    start = next(k for k, l in enumerate(lines) if l.startswith("build tmafm:"))
    line = next(l for l in lines[start:] if "LINK_ARGS" in l)
    return [w for w in line.split("=", 1)[1].split() if "lapack" in w or "blas" in w]


def kernel_costs(build_dir: Path, work: Path) -> dict:
    driver = work / "driver"
    subprocess.run(["gfortran", "-O3", "-o", str(driver), str(HERE / "rhs_cost_driver.f90"),
                    f"-I{build_dir / 'libtmafm_core.a.p'}", str(build_dir / "libtmafm_core.a"),
                    *link_flags(build_dir)], check=True)
    costs = {}
    for n in MODES:
        nml = work / f"n{n}.nml"
        nml.write_text(f"&model n_modes = {n} /\n&scene alpha2 = 7e-4, theta = 0.2 /\n")
        runs = [subprocess.run([str(driver), str(nml), str(n), str(CALLS)], check=True,
                               capture_output=True, text=True).stdout.split() for _ in range(3)]
        costs[str(n)] = {"free_ns": min(float(r[1]) for r in runs),
                         "contact_ns": min(float(r[2]) for r in runs)}
    return costs


def flight_evaluations(source: Path, build_dir: Path, work: Path) -> float:
    package = work / "pkg" / "tmafm"
    package.mkdir(parents=True)
    for f in (source / "pywrap" / "tmafm").glob("*.py"):
        (package / f.name).symlink_to(f)
    for f in (build_dir / "pywrap").glob("_core*.so"):
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


def measure(label: str, source: Path, work: Path) -> dict:
    build_dir = work / "build"
    build(source, build_dir)
    result = {"source": label, "lapack": link_flags(build_dir)}
    result["rhs"] = kernel_costs(build_dir, work)
    result["evaluations_per_flight"] = flight_evaluations(source, build_dir, work)
    result["start_ms"] = start_cost(str(build_dir / "tmafm"))
    print(json.dumps(result), flush=True)
    return result


def chart(data: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for key, style in (("old", "--"), ("new", "-")):
        rhs = data[key]["rhs"]
        for phase, marker in (("free_ns", "o"), ("contact_ns", "s")):
            ax.loglog(MODES, [rhs[str(n)][phase] for n in MODES], style, marker=marker,
                      label=f"{key} ({data[key]['source']}), {phase.split('_')[0]}")
    ax.set_xlabel("modes N")
    ax.set_ylabel("CPU ns per right-hand side")
    ax.set_xticks(MODES, [str(n) for n in MODES])
    ax.set_title("model%derivative: old kernel vs new (one run)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        old_src = tmp / "old-src"
        old_src.mkdir()
        archive = subprocess.run(["git", "-C", str(REPO), "archive", OLD_REV], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(old_src)], input=archive, check=True)
        (tmp / "old").mkdir()
        (tmp / "new").mkdir()
        old = measure(OLD_REV, old_src, tmp / "old")
        new = measure("working tree", REPO, tmp / "new")
    data = {"old": old, "new": new, "calls": CALLS, "starts": STARTS,
            "start_ms_bin_true": start_cost("/bin/true"),
            "command": "python benchmarks/rhs_cost.py"}
    (HERE / "rhs_cost.json").write_text(json.dumps(data, indent=1) + "\n")
    chart(data, HERE / "rhs_cost.png")
    for n in MODES:
        o, w = old["rhs"][str(n)], new["rhs"][str(n)]
        print(f"N = {n:2d}: free {o['free_ns']:8.1f} -> {w['free_ns']:8.1f} ns, "
              f"contact {o['contact_ns']:8.1f} -> {w['contact_ns']:8.1f} ns")
    print(f"evaluations per flight: {old['evaluations_per_flight']:.1f} -> "
          f"{new['evaluations_per_flight']:.1f}")
    print(f"tmafm --version CPU: {old['start_ms']:.2f} -> {new['start_ms']:.2f} ms "
          f"(/bin/true: {data['start_ms_bin_true']:.2f} ms)")


if __name__ == "__main__":
    main()
