"""Shared fixtures: the installed executable, the repository's inputs (and studies/ on sys.path),
namelist helpers, private
device nodes, a small tmpfs (full-disk tests) and a child process sent SIGINT (Ctrl-C tests)."""

import json
import os
import signal
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import f90nml
import numpy as np
import pytest

import tmafm

REPO = Path(__file__).resolve().parent.parent
INPUTS = REPO / "inputs"
# The studies (studies/: the scipy peer, the constructed scenes) are not part of the package;
# the tests that check them import them from the checkout, as their sibling scripts do.
STUDIES = REPO / "studies"
if str(STUDIES) not in sys.path:
    sys.path.insert(0, str(STUDIES))


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


def drive_interrupted_child(script: str, args, delay, timeout: float = 300):
    """Run `python -c script *args` and interrupt it.  The child prints one JSON object a line:
    {"start": name, ...} as a phase begins (the parent sleeps delay(fields) s, then sends SIGINT;
    no signal when delay gives None), {"phase": name, ...} with that phase's report,
    {"reference": name, ...} with an uninterrupted reference (kept as name + "_reference"),
    and anything else merged as it is.  Asserts a clean exit (no SIGSEGV, nothing left raised);
    returns the reports by name and the child's stderr."""
    proc = subprocess.Popen([sys.executable, "-c", script, *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    reports = {}
    watchdog = threading.Timer(timeout, proc.kill)  # a child that hangs fails, not the suite
    watchdog.start()
    try:
        for line in proc.stdout:
            fields = json.loads(line)
            if "start" in fields:
                reports[fields["start"]] = {k: v for k, v in fields.items() if k != "start"}
                seconds = delay(fields)
                if seconds is not None:
                    time.sleep(seconds)  # the child is inside the core by now
                    proc.send_signal(signal.SIGINT)
            elif "phase" in fields:
                reports[fields["phase"]].update(fields)
            elif "reference" in fields:
                reports[fields["reference"] + "_reference"] = fields
            else:
                reports.update(fields)
        err = proc.stderr.read()
        proc.wait(timeout=60)
    finally:
        watchdog.cancel()
        proc.kill()
    assert proc.returncode == 0, (proc.returncode, err[-3000:])
    return reports, err


def _monodromy_against_differences(model, x0, continuous, rtol=1e-12, steps=(1e-4, 1e-5)):
    """The monodromy matrix of the stroboscopic map at x0 and, for each relative step h, the
    largest difference between its first `continuous` rows and columns and central differences of
    the map (step h times the state's scale), over the matrix's largest entry."""
    from tmafm.continuation.shooting import periodic_map

    monodromy = periodic_map(model, x0, 1, rtol).monodromy
    scale = np.max(np.abs(x0[:continuous]))
    errors = []
    for h in steps:
        fd = np.empty((continuous, continuous))
        for k in range(continuous):
            e = np.zeros(len(x0))
            e[k] = h * scale
            fd[:, k] = (periodic_map(model, x0 + e, 1, rtol).y[:continuous]
                        - periodic_map(model, x0 - e, 1, rtol).y[:continuous]) / (2 * h * scale)
        errors.append(np.max(np.abs(monodromy[:continuous, :continuous] - fd)) / np.max(np.abs(monodromy)))
    return monodromy, errors


@pytest.fixture
def monodromy_fd():
    """_monodromy_against_differences, for the tests of a map's Jacobian."""
    return _monodromy_against_differences
