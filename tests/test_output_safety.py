"""The output never loses or clobbers data: full disks, devices, symbolic links, concurrent
writers, signals, bad targets found before the run, standard output, long paths."""

import io
import os
import signal
import stat
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import INPUTS, device_node, write_nml


def short_input(tmp_path, name="short.nml", tau_end=10.0, **groups):
    groups.setdefault("solver", {}).setdefault("tau_end", tau_end)
    groups.setdefault("output", {}).setdefault("file", "short.dat")
    return write_nml(tmp_path / name, base=INPUTS / "fig2_n4.nml", **groups)


def leftovers(folder: Path):
    """Temporaries of any naming scheme: the old OUT.partial and the new .OUT.partial-XXXX."""
    return sorted(p.name for p in folder.iterdir() if "partial" in p.name)


def one_error_line(proc):
    lines = proc.stderr.splitlines()
    errors = [line for line in lines if line.startswith("tmafm: error:")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


@pytest.mark.parametrize("fmt", ["text", "npy"])
def test_full_disk_fails_and_leaves_nothing(tmp_path, run_exe, small_tmpfs, fmt):
    name = "out.npz" if fmt == "npy" else "out.dat"
    # About 280 kB of text or 130 kB of .npz: more than the 64 KiB file system holds.
    path = short_input(tmp_path, output={"format": fmt} if fmt == "npy" else {})
    proc = run_exe(path, "-o", small_tmpfs / name, "-q")
    assert proc.returncode == 3, proc.stderr
    assert "No space left on device" in one_error_line(proc)
    assert list(small_tmpfs.iterdir()) == []


def test_full_disk_keeps_the_previous_file(tmp_path, run_exe, small_tmpfs):
    previous = small_tmpfs / "out.dat"
    previous.write_text("previous result\n")
    proc = run_exe(short_input(tmp_path), "-o", previous, "-q")
    assert proc.returncode == 3
    assert previous.read_text() == "previous result\n"
    assert [p.name for p in small_tmpfs.iterdir()] == ["out.dat"]


def test_full_device_is_an_error_and_stays_a_device(tmp_path, run_exe):
    full = device_node(tmp_path, "full", 7)
    proc = run_exe(short_input(tmp_path), "-o", full, "-q")
    assert proc.returncode == 3
    assert "No space left on device" in one_error_line(proc)
    assert stat.S_ISCHR(os.lstat(full).st_mode)
    assert leftovers(tmp_path) == []


def test_null_device_stays_a_device(tmp_path, run_exe):
    null = device_node(tmp_path, "null", 3)
    proc = run_exe(short_input(tmp_path), "-o", null, "-q")
    assert proc.returncode == 0, proc.stderr
    assert stat.S_ISCHR(os.lstat(null).st_mode)
    assert leftovers(tmp_path) == []


def test_fifo_is_written_directly(tmp_path, run_exe):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    received = {}

    def read():
        with open(fifo, "rb") as handle:
            received["data"] = handle.read()

    reader = threading.Thread(target=read, daemon=True)  # never blocks the exit of pytest
    reader.start()
    proc = run_exe(short_input(tmp_path), "-o", "pipe", "-q")
    reader.join(timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert run_exe(short_input(tmp_path), "-q").returncode == 0
    assert received["data"].replace(b"'pipe'", b"'short.dat'") == (tmp_path / "short.dat").read_bytes()


def test_symlinks_at_temporary_names_are_not_followed(tmp_path, run_exe):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    # The old fixed temporary name, and the new pattern with a guessed suffix.
    for name in ("short.dat.partial", ".short.dat.partial", ".short.dat.partial-AAAAAAAAAA"):
        os.symlink(victim, tmp_path / name)
    proc = run_exe(short_input(tmp_path), "-q")
    assert proc.returncode == 0, proc.stderr
    assert victim.read_text() == "precious\n"
    assert np.loadtxt(tmp_path / "short.dat").shape == (1001, 12)
    for name in ("short.dat.partial", ".short.dat.partial", ".short.dat.partial-AAAAAAAAAA"):
        assert (tmp_path / name).is_symlink()


def test_symlink_target_is_refused_before_the_run(tmp_path, run_exe):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    os.symlink(victim, tmp_path / "short.dat")
    proc = run_exe(short_input(tmp_path))
    assert proc.returncode == 3
    assert "symbolic link" in one_error_line(proc)
    assert "%" not in proc.stderr  # no progress line: nothing was integrated
    assert victim.read_text() == "precious\n" and (tmp_path / "short.dat").is_symlink()


@pytest.mark.parametrize("where", ["missing/out.dat", "short.nml/out.dat", "."])
def test_bad_target_fails_before_integrating(tmp_path, run_exe, where):
    # A run long enough that finding the error only at the end would show progress lines.
    proc = run_exe(short_input(tmp_path, tau_end=2000.0), "-o", where)
    assert proc.returncode == 3
    line = one_error_line(proc)
    assert "tmafm: 10%" not in proc.stderr, proc.stderr
    assert ("directory" in line) if where == "." else ("No such file" in line or "Not a directory" in line)
    assert leftovers(tmp_path) == []


def test_concurrent_writers_never_mix(tmp_path, exe):
    """Two runs write the same file at once: it ends up entirely one run's output."""
    inputs = [short_input(tmp_path, f"run{k}.nml", tau_end=60.0,
                          model={"n_modes": 4}, scene={"alpha2": alpha2}, output={"file": "same.dat"})
              for k, alpha2 in enumerate((5e-4, 6e-4))]
    expected = []
    for path in inputs:
        subprocess.run([exe, path, "-q"], cwd=tmp_path, check=True)
        expected.append((tmp_path / "same.dat").read_bytes())
    assert expected[0] != expected[1]
    for _ in range(4):
        (tmp_path / "same.dat").unlink()
        procs = [subprocess.Popen([exe, path, "-q"], cwd=tmp_path) for path in inputs]
        assert [p.wait(timeout=300) for p in procs] == [0, 0]
        assert (tmp_path / "same.dat").read_bytes() in expected
        assert leftovers(tmp_path) == []


#: Terminating signals and the exit statuses they may give: tmafm's handler removes the
#: temporary and dies of the signal again (-signo), or a shell reports 128 + signo for SIGINT
#: and SIGTERM.  SIGQUIT (Ctrl-\\), SIGXCPU (a CPU-time limit, ulimit -t), SIGALRM and SIGUSR1
#: killed the run while it wrote and left .big.dat.partial-* behind until their handler was added.
TERMINATING = {signal.SIGTERM: (-signal.SIGTERM, 128 + signal.SIGTERM),
               signal.SIGINT: (-signal.SIGINT, 128 + signal.SIGINT),
               **{s: (-s,) for s in (signal.SIGQUIT, signal.SIGXCPU, signal.SIGALRM, signal.SIGUSR1)}}


@pytest.mark.parametrize("signo", list(TERMINATING))
def test_signal_while_writing_leaves_no_temporary(tmp_path, exe, signo):
    """Signal a run while its ~56 MB output is being written (the temporary exists)."""
    import resource

    path = short_input(tmp_path, "big.nml", tau_end=100.0, solver={"method": "dopri5"},
                       output={"file": "big.dat", "sample_dtau": 5e-4})

    def start():
        # A shell's background job inherits SIGINT ignored, and tmafm keeps an ignored signal
        # ignored (as nohup asks): start the run with the default disposition.
        signal.signal(signo, signal.SIG_DFL)
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # SIGQUIT and SIGXCPU dump core

    for _ in range(3):
        proc = subprocess.Popen([exe, path, "-q"], cwd=tmp_path, preexec_fn=start,
                                stderr=subprocess.DEVNULL)
        caught = False
        while proc.poll() is None:
            if leftovers(tmp_path):
                proc.send_signal(signo)
                caught = True
                break
            time.sleep(0.0005)
        returncode = proc.wait(timeout=300)
        if caught and not (tmp_path / "big.dat").exists():
            break
        (tmp_path / "big.dat").unlink(missing_ok=True)
    else:
        pytest.fail("never caught the run while it was writing")
    assert returncode in TERMINATING[signo]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.nml"]


@pytest.mark.parametrize("fmt", ["text", "npy"])
def test_dash_writes_to_standard_output(tmp_path, exe, run_exe, fmt):
    name = "short.npz" if fmt == "npy" else "short.dat"
    path = short_input(tmp_path, output={"format": fmt, "file": name} if fmt == "npy" else {})
    proc = subprocess.run([exe, path, "-o", "-"], cwd=tmp_path, capture_output=True)
    assert proc.returncode == 0, proc.stderr
    assert not (tmp_path / "-").exists() and not (tmp_path / name).exists()
    assert run_exe(path, "-q").returncode == 0
    if fmt == "text":
        np.testing.assert_array_equal(np.loadtxt(io.BytesIO(proc.stdout)), np.loadtxt(tmp_path / name))
    else:
        piped, filed = np.load(io.BytesIO(proc.stdout)), np.load(tmp_path / name)
        for key in ("tau", "vt", "a", "adot", "contact", "switches", "counters"):
            np.testing.assert_array_equal(piped[key], filed[key])


@pytest.mark.parametrize("option", ["-o", None])
def test_long_paths_are_refused_not_cut(tmp_path, run_exe, option):
    long_name = "d" * 1100 + ".dat"
    path = short_input(tmp_path)
    args = [path, "-o", long_name] if option else [long_name]
    proc = run_exe(*args)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "1104 characters" in line and "1024" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["short.nml"]


def test_empty_output_name_is_refused(tmp_path, run_exe):
    proc = run_exe(short_input(tmp_path), "-o", "")
    assert proc.returncode == 1
    one_error_line(proc)


def test_replacing_a_file_is_atomic(tmp_path, run_exe):
    """An existing output is replaced by a new inode (rename), never rewritten in place."""
    target = tmp_path / "short.dat"
    target.write_text("old\n")
    inode = os.stat(target).st_ino
    with open(target) as old_reader:
        assert run_exe(short_input(tmp_path), "-q").returncode == 0
        assert old_reader.read() == "old\n"  # a reader of the old file still sees it whole
    assert os.stat(target).st_ino != inode
    assert np.loadtxt(target).shape == (1001, 12)


_RENAME_SHIM = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <signal.h>
#include <stdlib.h>
/* rename(2), then the signal TMAFM_TEST_SIGNAL to this process: a signal that comes right
   after the complete output was put in place. */
int rename(const char *from, const char *to)
{
    int (*real)(const char *, const char *) =
        (int (*)(const char *, const char *))dlsym(RTLD_NEXT, "rename");
    int status = real(from, to);
    raise(atoi(getenv("TMAFM_TEST_SIGNAL")));
    return status;
}
"""


@pytest.fixture(scope="module")
def rename_shim(tmp_path_factory):
    """A preload library whose rename(2) signals the process right after renaming."""
    import shutil
    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        pytest.skip("no C compiler for the rename shim")
    folder = tmp_path_factory.mktemp("shim")
    (folder / "shim.c").write_text(_RENAME_SHIM)
    subprocess.run([compiler, "-shared", "-fPIC", "-o", str(folder / "shim.so"), str(folder / "shim.c"),
                    "-ldl"], check=True, capture_output=True)
    return folder / "shim.so"


@pytest.mark.parametrize("signo", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP])
@pytest.mark.parametrize("fmt", ["text", "npy"])
def test_a_signal_right_after_the_rename_is_a_success(tmp_path, exe, rename_shim, signo, fmt):
    """Once the complete output is renamed into place the run has succeeded: a signal then
    exits 0 with the file kept (issue 18: it died with 128 + signo over a finished file, so a
    caller took a complete result for a failed run)."""
    name = "short.npz" if fmt == "npy" else "short.dat"
    path = short_input(tmp_path, output={"format": fmt, "file": name})
    reference = subprocess.run([exe, path, "-q"], cwd=tmp_path, capture_output=True, timeout=300)
    assert reference.returncode == 0, reference.stderr
    os.replace(tmp_path / name, tmp_path / ("reference." + name.split(".")[1]))
    (tmp_path / name).write_text("old\n")
    env = dict(os.environ, LD_PRELOAD=str(rename_shim), TMAFM_TEST_SIGNAL=str(int(signo)))

    def start():
        signal.signal(signo, signal.SIG_DFL)  # as a shell's foreground job has it

    proc = subprocess.run([exe, path, "-q"], cwd=tmp_path, env=env, capture_output=True,
                          preexec_fn=start, timeout=300)
    assert proc.returncode == 0, (proc.returncode, proc.stderr)
    assert proc.stderr == b""
    if fmt == "text":
        assert (tmp_path / name).read_bytes() == (tmp_path / "reference.dat").read_bytes()
    else:
        piped, filed = np.load(tmp_path / name), np.load(tmp_path / "reference.npz")
        for key in ("tau", "vt", "a", "adot", "contact", "switches", "counters"):
            np.testing.assert_array_equal(piped[key], filed[key])
    assert leftovers(tmp_path) == []


def test_a_fifo_output_is_opened_before_the_run_and_says_that_it_waits(tmp_path, exe):
    """A FIFO with no reader was opened only after the whole run, then blocked without a word
    (issue 18).  It is opened before anything is integrated, with one line on stderr saying
    that tmafm waits for a reader, before any progress line."""
    import select

    os.mkfifo(tmp_path / "pipe")
    path = short_input(tmp_path, tau_end=20.0)
    proc = subprocess.Popen([exe, path, "-o", "pipe"], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        ready, _, _ = select.select([proc.stderr], [], [], 30)
        assert ready, "no line on stderr within 30 s"
        first = proc.stderr.readline()
        assert first.startswith("tmafm: waiting for a reader of the FIFO 'pipe'"), first
        with open(tmp_path / "pipe", "rb") as reader:
            data = reader.read()
        out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "tmafm: 10%" in err  # the progress lines came after the wait, not before it
    assert subprocess.run([exe, path, "-q"], cwd=tmp_path, timeout=300).returncode == 0
    assert data.replace(b"'pipe'", b"'short.dat'") == (tmp_path / "short.dat").read_bytes()
