"""Build an earlier revision of tmafm next to the working tree and time their executables: what
the benchmarks that compare two builds in one run share (rhs_cost.py, rhs_instructions.py)."""

from __future__ import annotations

import resource
import subprocess
from pathlib import Path

import f90nml
import numpy as np

REPO = Path(__file__).resolve().parent.parent
#: The counters an .npz output holds, in order (docs/output-format.md).
COUNTERS = ("steps", "contact_steps", "rejected_steps", "rhs_evaluations", "switches")


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
