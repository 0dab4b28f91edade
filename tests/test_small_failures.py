"""Small failures that escaped as silence or raw exceptions: a failed write of --help or
--version exited 0, tmafm._exe.executable() raised a raw FileNotFoundError, Result.save of a
hand-built Result raised AttributeError, and a symbolic link loop as input said "not found"."""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import _exe


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
@pytest.mark.parametrize("option, what", [("--help", "the help text"), ("-h", "the help text"),
                                          ("--version", "the version"), ("-V", "the version")])
def test_failed_write_of_help_or_version_is_an_error(exe, option, what):
    with open("/dev/full", "w") as full:
        proc = subprocess.run([exe, option], stdout=full, stderr=subprocess.PIPE, text=True, timeout=60)
    assert proc.returncode == 3, proc.stderr
    assert proc.stderr.splitlines() == [f"tmafm: error: cannot write {what} to standard output: "
                                        f"{os.strerror(28)}"], proc.stderr


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_failed_write_of_the_run_summary_is_an_error(exe, tmp_path):
    """The summary line after a run goes to stdout like --help: when it cannot be written the
    run says so and exits 3 (it exited 0 silently); the output file itself is complete."""
    nml = tmp_path / "in.nml"
    tmafm.Config("fig2_n4", solver={"tau_end": 0.5}, output={"file": "out.npz", "format": "npy"}).write(nml)
    with open("/dev/full", "w") as full:
        proc = subprocess.run([exe, str(nml)], stdout=full, stderr=subprocess.PIPE, text=True,
                              cwd=tmp_path, timeout=120)
    assert proc.returncode == 3, proc.stderr
    assert proc.stderr.splitlines()[-1] == (f"tmafm: error: cannot write the summary to standard output: "
                                            f"{os.strerror(28)}"), proc.stderr
    assert tmafm.load(tmp_path / "out.npz").tau[-1] == pytest.approx(0.5)
    proc = subprocess.run([exe, str(nml)], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert proc.returncode == 0 and proc.stdout == "tmafm: wrote 51 samples to out.npz\n", proc


def test_help_and_version_still_print(exe):
    proc = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout.startswith("usage: tmafm INPUT.nml"), proc
    assert proc.stdout.endswith("5 run failure.\n") and proc.stderr == ""
    proc = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout == f"tmafm {tmafm.__version__}\n", proc


def test_missing_executable_is_a_typed_error(tmp_path, monkeypatch):
    monkeypatch.delenv("TMAFM_EXE", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.setattr(_exe.sysconfig, "get_path", lambda name: str(tmp_path))
    monkeypatch.setattr(_exe.sys, "executable", str(tmp_path / "python"))
    with pytest.raises(tmafm.InputFileError, match="the tmafm executable is not installed"):
        _exe.executable()


def test_save_of_a_result_without_input_is_a_typed_error(tmp_path):
    n = 3
    result = tmafm.Result(np.arange(n) * 0.1, np.zeros(n), np.zeros(n), np.zeros(n, dtype=np.int8),
                          np.zeros((n, 2)), np.zeros((n, 2)))
    with pytest.raises(tmafm.InputError, match="no resolved input") as info:
        result.save(tmp_path / "r.npz")
    assert "\n" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def links(tmp_path):
    (tmp_path / "loop1.nml").symlink_to("loop2.nml")
    (tmp_path / "loop2.nml").symlink_to("loop1.nml")
    (tmp_path / "dangling.nml").symlink_to("nothing.nml")
    return tmp_path


@pytest.mark.parametrize("name, says", [("loop1.nml", "cannot be used: " + os.strerror(40)),
                                        ("loop1.nml/x.nml", "cannot be used: " + os.strerror(40)),
                                        ("dangling.nml", "is a symbolic link to a missing file"),
                                        ("missing.nml", "not found")])
def test_links_as_input_say_what_they_are(links, exe, name, says):
    proc = subprocess.run([exe, name], cwd=links, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 3
    assert proc.stderr.splitlines() == [f"tmafm: error: input file '{name}' {says}"], proc.stderr
    with pytest.raises(tmafm.InputFileError, match=f"input file '.*{name}' {says}"):
        tmafm.run(links / name)
