"""Build an earlier revision of tmafm next to the working tree and time their executables: what
the benchmarks that compare two builds in one run share (rhs_cost.py, rhs_instructions.py)."""

from __future__ import annotations

import math
import resource
import subprocess
from pathlib import Path

import f90nml
import numpy as np

REPO = Path(__file__).resolve().parent.parent
#: The counters an .npz output holds, in order (docs/output-format.md).
COUNTERS = ("steps", "contact_steps", "rejected_steps", "rhs_evaluations", "switches")
PERIOD = math.pi   # 2 pi / Omega, Omega = 2
#: The two runs of issue 8's remaining targets, as overrides of inputs/fig2_n4.nml: the tilted
#: 3-mode scene at rtol 1e-10 over 200 periods (one sample a period), and Fig. 2 over 100
#: periods at flight_exact's defaults and the input's sampling (0.01).
TARGET_RUNS = {
    "tilted_hertz_3": {"model": {"n_modes": 3, "convention": "paper"}, "scene": {"alpha2": 7e-4, "theta": 0.2},
                       "initial": {"a0": [2e-4, 0.0, 0.0]},
                       "solver": {"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14,
                                  "tau_end": 200 * PERIOD},
                       "output": {"sample_dtau": PERIOD}},
    "fig2": {"solver": {"method": "flight_exact", "tau_end": 100 * PERIOD},
             "output": {"sample_dtau": 0.01}},
}


def export_revision(rev: str, into: Path) -> Path:
    """The source tree of git revision `rev` of this repository, unpacked into `into`."""
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def build(source: Path, build_dir: Path, options: tuple[str, ...] | list[str] = ()) -> None:
    """meson (buildtype=release, plus `options`) and ninja, two jobs."""
    subprocess.run(["meson", "setup", str(build_dir), str(source), "-Dbuildtype=release", *options],
                   check=True, capture_output=True)
    subprocess.run(["ninja", "-C", str(build_dir), "-j", "2"], check=True, capture_output=True)


def link_flags(build_dir: Path) -> list[str]:
    """The LAPACK and BLAS the build itself linked the executable with (from build.ninja)."""
    lines = (build_dir / "build.ninja").read_text().splitlines()
    start = next(k for k, l in enumerate(lines) if l.startswith("build tmafm:"))
    line = next(l for l in lines[start:] if "LINK_ARGS" in l)
    return [w for w in line.split("=", 1)[1].split() if "lapack" in w or "blas" in w]


def callgrind(command: list[str], cwd: Path) -> int | None:
    """Instructions of one process under valgrind's callgrind, or None without valgrind."""
    try:
        out = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", *command],
                             check=True, capture_output=True, text=True, cwd=cwd).stderr
    except FileNotFoundError:
        return None
    line = next(l for l in out.splitlines() if "Collected :" in l)
    return int(line.split(":")[-1])


def scene_file(name: str, overrides: dict, work: Path) -> Path:
    """work/<name>.nml: inputs/fig2_n4.nml with `overrides` ({group: {key: value}}), writing
    work/<name>.npz."""
    nml = f90nml.read(str(REPO / "inputs" / "fig2_n4.nml"))
    for group, values in overrides.items():
        for key, value in values.items():
            nml[group][key] = value
    nml["output"]["file"] = str(work / f"{name}.npz")
    nml["output"]["format"] = "npy"
    path = work / f"{name}.nml"
    f90nml.write(nml, str(path), force=True)
    return path


def process_cpu(exe: Path | str, nml: Path) -> tuple[float, dict]:
    """CPU seconds (user + sys) of one `exe -q nml` process, and the counters of its output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([str(exe), "-q", str(nml)], check=True, cwd=nml.parent)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    with np.load(nml.with_suffix(".npz")) as npz:
        counters = dict(zip(COUNTERS, (int(c) for c in npz["counters"])))
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), counters


def interleaved(builds: dict[str, Path], nml: Path, rounds: int) -> tuple[dict, dict]:
    """CPU seconds of `rounds` runs of `nml` by each build's `tmafm`, one run of every build
    per round (so all see the same load), and each build's counters."""
    seconds = {label: [] for label in builds}
    counters = {}
    for _ in range(rounds):
        for label, build_dir in builds.items():
            cpu, counters[label] = process_cpu(build_dir / "tmafm", nml)
            seconds[label].append(cpu)
    return seconds, counters
