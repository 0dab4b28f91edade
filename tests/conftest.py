"""Shared fixtures: the installed executable, the repository's inputs, namelist helpers, private
device nodes and a small tmpfs (full-disk tests)."""

import os
import stat
import subprocess
from pathlib import Path

import f90nml
import pytest

import tmafm

REPO = Path(__file__).resolve().parent.parent
INPUTS = REPO / "inputs"


@pytest.fixture(scope="session")
def exe() -> str:
    """Path of the installed tmafm executable."""
    return tmafm.executable()


@pytest.fixture
def run_exe(exe, tmp_path):
    """Run the executable in tmp_path; returns the CompletedProcess."""
    def _run(*args):
        return subprocess.run([exe, *map(str, args)], cwd=tmp_path, capture_output=True,
                              text=True, timeout=600)
    return _run


def write_nml(path: Path, base=None, **groups) -> Path:
    """Write a namelist file: the groups of `base` (a path) patched by `groups`."""
    merged = {}
    if base is not None:
        merged = {g: dict(v) for g, v in f90nml.read(str(base)).items()}
    for group, values in groups.items():
        merged.setdefault(group, {}).update(values)
    f90nml.write(f90nml.Namelist(merged), str(path), force=True)
    return path


def device_node(tmp_path, name, minor):
    """A private character device node (1, minor: 3 is null, 7 is full), so the test never
    risks the system's /dev/null or /dev/full."""
    path = tmp_path / name
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
        with open(path, "wb") as handle:
            handle.write(b"")
    except OSError as error:  # not root, or a nodev mount
        pytest.skip(f"cannot make a device node here: {error}")
    return path


@pytest.fixture
def small_tmpfs(tmp_path):
    """A 64 KiB tmpfs (needs root); unmounted afterwards."""
    mount = tmp_path / "full"
    mount.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mount)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs: {proc.stderr.strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=True)
