"""Faults for every writer (issue 27): a full disk, a file-size limit (RLIMIT_FSIZE), a read-only
folder and two writers of one path at once, for each thing tmafm writes: the executable's text
and .npz output, Result.save, Config.write, sweeps.write_dataset of a sweep, of an approach
curve and of a continuation, a sweep plot, and a study's JSON (studies/api_campaign.py).

Each fault must give one line (a typed tmafm.InputFileError from Python, exit 3 and one
`tmafm: error:` line from the executable, exit 1 and one line from a study), nothing else on
stderr, and no file passed off as a result: no temporary left, the target absent or, when it
existed, its previous bytes.  Each writer runs in a child process (the limit is set there, and
a crash cannot take the test run with it)."""

import json
import os
import resource
import subprocess
import sys
import textwrap

import pytest

import tmafm

from conftest import REPO

#: What each writer writes: the file's suffix and the Python that makes and writes it to
#: sys.argv[1] (TARGET); VARIANT (sys.argv[3]) changes the content, for the two-writer race.
WRITERS = {
    "Result.save": (".npz", """
        result = tmafm.run("fig2_n4", solver={"tau_end": 5.0 + VARIANT})
        result.save(TARGET)"""),
    "Config.write": (".nml", """
        tmafm.Config("fig2_n4", solver={"tau_end": 5.0 + VARIANT}).write(TARGET)"""),
    "write_dataset (sweep)": (".nc", """
        from tmafm import sweeps
        ds = sweeps.sweep("fig2_n4", {"scene.delta_hat": [0.2, 0.1 + VARIANT / 100]}, max_periods=2,
                          workers=1)
        sweeps.write_dataset(ds, TARGET)"""),
    "write_dataset (approach)": (".nc", """
        from tmafm import sweeps
        ds = tmafm.approach("fig2_n4", [0.2, 0.1 + VARIANT / 100], max_periods=2, workers=1)
        sweeps.write_dataset(ds, TARGET)"""),
    "write_dataset (continuation)": (".nc", f"""
        from tmafm import sweeps
        ds = tmafm.continuation({str(REPO / "inputs" / "sweeps" / "bistable_n2.nml")!r}, "scene.delta_hat",
                                2.0e-3, 1.98e-3 - VARIANT * 1e-5, max_points=2, settle=30, workers=1)
        sweeps.write_dataset(ds, TARGET)"""),
    "sweep plot": (".png", """
        from tmafm import sweeps
        from tmafm.sweeps import plots
        ds = sweeps.sweep("fig2_n4", {"scene.delta_hat": [0.2, 0.1 + VARIANT / 100]}, max_periods=2,
                          workers=1)
        plots.plot(ds, TARGET)"""),
}

CHILD = """
import json, resource, sys, warnings
warnings.simplefilter("ignore")
import tmafm
TARGET, LIMIT, VARIANT = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
if LIMIT:
    # After the imports: the limit is the writer's, not the interpreter's caches'.
    resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT, LIMIT))
try:
{body}
    print(json.dumps({{"ok": True}}))
except tmafm.TmafmError as exc:
    print(json.dumps({{"ok": False, "type": type(exc).__name__, "message": str(exc)}}))
"""


def _python_writer(name, target, limit=0, variant=0, wait=True):
    body = textwrap.indent(textwrap.dedent(WRITERS[name][1]).strip(), "    ")
    proc = subprocess.Popen([sys.executable, "-c", CHILD.format(body=body), str(target), str(limit),
                             str(variant)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if not wait:
        return proc
    out, err = proc.communicate(timeout=600)
    return proc.returncode, out, err


def _exe_writer(exe, target, inputs, limit=0, variant=0, wait=True):
    """The executable writing a short dopri5 run to `target` (its format by the suffix); its
    input is written in the folder `inputs`."""
    fmt = "npy" if str(target).endswith(".npz") else "text"
    source = inputs / f"input-{variant}.nml"
    source.write_text(f"&model n_modes = 4 /\n&solver method = 'dopri5', tau_end = {5 + variant} /\n"
                      f"&output format = '{fmt}' /\n")

    def limit_it():
        if limit:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    proc = subprocess.Popen([exe, "-q", str(source), "-o", str(target)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=limit_it)
    if not wait:
        return proc
    out, err = proc.communicate(timeout=600)
    return proc.returncode, out, err


ALL = list(WRITERS) + ["tmafm (text)", "tmafm (.npz)", "study JSON"]
SUFFIX = {**{k: v[0] for k, v in WRITERS.items()}, "tmafm (text)": ".dat", "tmafm (.npz)": ".npz",
          "study JSON": ".json"}


def _write(name, target, inputs, exe, limit=0, variant=0, wait=True):
    """Start writer `name` on `target`; (returncode, stdout, stderr), or the Popen."""
    if name.startswith("tmafm "):
        return _exe_writer(exe, target, inputs, limit, variant, wait)
    if name == "study JSON":
        def limit_it():
            if limit:
                resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        proc = subprocess.Popen([sys.executable, str(REPO / "studies" / "api_campaign.py"), "--calls",
                                 str(3 + variant), "--out", str(target)], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, preexec_fn=limit_it)
        if not wait:
            return proc
        out, err = proc.communicate(timeout=600)
        return proc.returncode, out, err
    return _python_writer(name, target, limit, variant, wait)


def _check_refused(name, code, out, err, target, words):
    """One line naming the target and the cause; nothing else on stderr."""
    if name.startswith("tmafm "):
        assert code == 3, (code, err)
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("tmafm: error: "), err
        message = lines[0]
    elif name == "study JSON":
        assert code == 1, (code, err)
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("api_campaign: error: "), err
        message = lines[0]
    else:
        assert code == 0 and err == "", (code, err)
        report = json.loads(out)
        assert report["ok"] is False and report["type"] == "InputFileError", report
        message = report["message"]
        assert "\n" not in message
    assert target.name in message and any(w in message for w in words), message


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir())


@pytest.mark.parametrize("name", ALL)
def test_a_full_disk_is_one_line_and_leaves_the_previous_file(name, small_tmpfs, tmp_path, exe):
    """The disk is full (a 64 KiB tmpfs filled to its last byte): the writer fails in one line
    with No space left on device, and the file that was there keeps its bytes; no temporary
    is left."""
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    target = small_tmpfs / f"out{SUFFIX[name]}"
    target.write_bytes(b"previous\n")
    fd = os.open(small_tmpfs / "filler", os.O_WRONLY | os.O_CREAT)
    try:
        with pytest.raises(OSError, match="No space left on device"):
            while True:
                os.write(fd, b"\0" * 512)
    finally:
        os.close(fd)
    code, out, err = _write(name, target, inputs, exe)
    _check_refused(name, code, out, err, target, ["No space left on device"])
    assert _leftovers(small_tmpfs) == sorted(["filler", target.name])
    assert target.read_bytes() == b"previous\n"


@pytest.mark.parametrize("name", ALL)
def test_a_file_size_limit_is_one_line_and_leaves_nothing(name, tmp_path, exe):
    """RLIMIT_FSIZE of 512 bytes (ulimit -f): every output is larger, the write fails with
    File too large (SIGXFSZ is ignored by Python and by the executable), nothing is left."""
    inputs, out_dir = tmp_path / "inputs", tmp_path / "out"
    inputs.mkdir()
    out_dir.mkdir()
    target = out_dir / f"out{SUFFIX[name]}"
    code, out, err = _write(name, target, inputs, exe, limit=512)
    _check_refused(name, code, out, err, target, ["File too large"])
    assert _leftovers(out_dir) == []


@pytest.fixture
def read_only_folder(tmp_path):
    """A read-only tmpfs (needs root: root writes through permission bits); unmounted after."""
    mount = tmp_path / "ro"
    mount.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(mount)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a read-only tmpfs: {proc.stderr.strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=True)


@pytest.mark.parametrize("name", ALL)
def test_a_read_only_folder_is_one_line_and_leaves_nothing(name, read_only_folder, tmp_path, exe):
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    target = read_only_folder / f"out{SUFFIX[name]}"
    code, out, err = _write(name, target, inputs, exe)
    _check_refused(name, code, out, err, target, ["Read-only file system"])
    assert _leftovers(read_only_folder) == []


def _complete(name, target, inputs):
    """The written file read back as what it is (a Result, a Config, a Dataset, a PNG, JSON)."""
    if name in ("Result.save", "tmafm (.npz)"):
        return tmafm.load(target).tau[-1]
    if name == "tmafm (text)":
        return tmafm.Config(str(target)).to_dict()["solver"]["tau_end"]
    if name == "Config.write":
        return tmafm.Config(str(target)).to_dict()["solver"]["tau_end"]
    if name.startswith("write_dataset"):
        from tmafm import sweeps
        return sweeps.read_dataset(target).sizes
    if name == "sweep plot":
        data = target.read_bytes()
        assert data.startswith(b"\x89PNG") and data.endswith(b"IEND\xaeB`\x82")
        return len(data)
    return json.loads(target.read_text())["calls"]


@pytest.mark.parametrize("name", ALL)
def test_two_writers_of_one_path_leave_one_whole_file(name, tmp_path, exe):
    """Two processes write the same path at once, with different contents: both succeed, the
    file is one of the two whole (it reads back), and no temporary is left."""
    inputs, out_dir = tmp_path / "inputs", tmp_path / "out"
    inputs.mkdir()
    out_dir.mkdir()
    target = out_dir / f"out{SUFFIX[name]}"
    procs = [_write(name, target, inputs, exe, variant=v, wait=False) for v in (0, 1)]
    for proc in procs:
        out, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
        if not name.startswith("tmafm ") and name != "study JSON":
            assert json.loads(out)["ok"] is True, out
    assert _leftovers(out_dir) == [target.name]
    assert _complete(name, target, inputs)
