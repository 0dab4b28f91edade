"""Files written from Python (Result.save, Config.write, sweeps.write_dataset, the sweep
plots) follow the executable's output rules (docs/reliability.md#output).  Before, they were
written with mkstemp + os.replace: ``r.save('/dev/null')`` replaced the device with a regular
file (as root: the system's /dev/null), a symbolic link was replaced, a directory raised a raw
IsADirectoryError, files got mode 0600 whatever the umask, and write_dataset wrote through a
symbolic link planted at its fixed temporary name ``.NAME.partial``."""

import os
import signal
import stat
import subprocess
import sys

import numpy as np
import pytest

import tmafm
from tmafm import sweeps

from conftest import device_node


@pytest.fixture(scope="module")
def result():
    return tmafm.run("fig2_n4", solver={"tau_end": 0.5})


def _writers(result):
    config = result.config
    return {
        "save": lambda path: result.save(path),
        "write": lambda path: config.write(path),
    }


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if "partial" in p.name)


@pytest.mark.parametrize("how", ["save", "write"])
def test_a_device_stays_adevice_node(tmp_path, result, how):
    null = device_node(tmp_path, "null", 3)
    _writers(result)[how](null)
    assert stat.S_ISCHR(os.lstat(null).st_mode)
    full = device_node(tmp_path, "full", 7)
    with pytest.raises(tmafm.InputFileError, match="No space left on device"):
        _writers(result)[how](full)
    assert stat.S_ISCHR(os.lstat(full).st_mode)
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("how", ["save", "write"])
def test_a_symbolic_link_or_a_directory_is_refused(tmp_path, result, how):
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    os.symlink(victim, tmp_path / "link.npz")
    with pytest.raises(tmafm.InputFileError, match="symbolic link"):
        _writers(result)[how](tmp_path / "link.npz")
    assert (tmp_path / "link.npz").is_symlink() and victim.read_text() == "precious\n"
    (tmp_path / "folder.npz").mkdir()
    with pytest.raises(tmafm.InputFileError, match="is a directory"):
        _writers(result)[how](tmp_path / "folder.npz")
    with pytest.raises(tmafm.InputFileError, match="No such file or directory"):
        _writers(result)[how](tmp_path / "missing" / "r.npz")
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("how", ["save", "write"])
def test_a_new_file_has_the_umask_permissions_and_replaces_atomically(tmp_path, result, how):
    target = tmp_path / "r.npz"
    target.write_text("old\n")
    inode = os.stat(target).st_ino
    previous = os.umask(0o022)
    try:
        with open(target) as old_reader:
            _writers(result)[how](target)
            assert old_reader.read() == "old\n"
    finally:
        os.umask(previous)
    assert os.stat(target).st_ino != inode
    assert stat.S_IMODE(os.stat(target).st_mode) == 0o644
    assert _leftovers(tmp_path) == []


def test_an_interrupted_save_leaves_nothing(tmp_path, result, monkeypatch):
    import tmafm._safefile as safefile

    def interrupted(fd, data):
        os.write(fd, b"half")
        raise KeyboardInterrupt

    monkeypatch.setattr(safefile, "_write_all", interrupted)
    with pytest.raises(KeyboardInterrupt):
        result.save(tmp_path / "r.npz")
    assert list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def dataset():
    xr = pytest.importorskip("xarray")
    return xr.Dataset({"x": ("i", np.arange(3.0))})


def test_write_dataset_never_writes_through_a_planted_link(tmp_path, dataset):
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    os.symlink(victim, tmp_path / ".grid.nc.partial")  # the old fixed temporary name
    path = sweeps.write_dataset(dataset, tmp_path / "grid.nc")
    assert victim.read_text() == "precious\n"
    xr = pytest.importorskip("xarray")
    with xr.open_dataset(path) as back:
        assert np.array_equal(back["x"].values, dataset["x"].values)
    assert _leftovers(tmp_path) == [".grid.nc.partial"]


def test_write_dataset_refuses_a_link_and_keeps_adevice_node(tmp_path, dataset):
    os.symlink(tmp_path / "elsewhere.nc", tmp_path / "link.nc")
    with pytest.raises(tmafm.InputFileError, match="symbolic link"):
        sweeps.write_dataset(dataset, tmp_path / "link.nc")
    null = device_node(tmp_path, "null", 3)
    sweeps.write_dataset(dataset, null)
    assert stat.S_ISCHR(os.lstat(null).st_mode)
    assert _leftovers(tmp_path) == []


def test_write_dataset_interrupted_leaves_nothing(tmp_path, dataset, monkeypatch):
    def interrupted(self, path, *args, **kwargs):
        # Half a file, into the buffer write_dataset makes it in (or a file, by name).
        if hasattr(path, "write"):
            path.write(b"half")
        else:
            open(path, "wb").write(b"half")
        raise KeyboardInterrupt

    monkeypatch.setattr(type(dataset), "to_netcdf", interrupted)
    with pytest.raises(KeyboardInterrupt):
        sweeps.write_dataset(dataset, tmp_path / "grid.nc")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("content", [None, b"hello\n", "dataset"], ids=["missing", "text", "not_a_sweep"])
def test_summarize_of_a_file_that_is_not_a_sweep_is_one_error_line(tmp_path, dataset, content):
    """`python -m tmafm.sweeps --summarize x.nc` ended in a raw traceback (ValueError from
    xarray, FileNotFoundError from h5py, KeyError for a NetCDF file of another kind)."""
    import subprocess
    import sys

    path = tmp_path / "x.nc"
    if content == "dataset":
        sweeps.write_dataset(dataset, path)
    elif content is not None:
        path.write_bytes(content)
    proc = subprocess.run([sys.executable, "-m", "tmafm.sweeps", "--summarize", str(path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tmafm.sweeps: error: "), proc.stderr
    assert "x.nc" in lines[0]


def test_figures_and_reports_follow_the_same_rules(tmp_path):
    """The sweep plots, tmafm.figures and studies/work_precision.py saved with fig.savefig(path) and
    Path.write_text: through a symbolic link, and in place (a partial file on a failure)."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from tmafm._safefile import save_figure, write_text

    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    for name in ("plot.png", "summary.json"):
        os.symlink(victim, tmp_path / name)
    fig = Figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    with pytest.raises(tmafm.InputFileError, match="symbolic link"):
        save_figure(fig, tmp_path / "plot.png", dpi=50)
    with pytest.raises(tmafm.InputFileError, match="symbolic link"):
        write_text(tmp_path / "summary.json", "{}")
    assert victim.read_text() == "precious\n"
    assert save_figure(fig, tmp_path / "p.png", dpi=50).read_bytes().startswith(b"\x89PNG")
    assert save_figure(fig, tmp_path / "p.svg").read_bytes().lstrip().startswith(b"<?xml")
    assert _leftovers(tmp_path) == []


def test_a_full_disk_fails_with_a_typed_error_and_leaves_the_previous_file(small_tmpfs):
    """Result.save on a 64 KiB tmpfs (about 100 kB of .npz): InputFileError, no temporary,
    the previous file untouched."""
    (small_tmpfs / "r.npz").write_text("previous\n")
    result = tmafm.run("fig2_n4", solver={"tau_end": 10.0})
    with pytest.raises(tmafm.InputFileError, match="No space left on device"):
        result.save(small_tmpfs / "r.npz")
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ["r.npz"]
    assert (small_tmpfs / "r.npz").read_text() == "previous\n"


@pytest.mark.parametrize("how", ["save", "write"])
@pytest.mark.parametrize("path", [b"r.npz", 3, None], ids=["bytes", "int", "none"])
def test_a_path_of_the_wrong_type_is_a_typed_error(tmp_path, result, how, path, monkeypatch):
    """Path(b'r.npz') raised a raw TypeError from save and write."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(tmafm.InputTypeError):
        _writers(result)[how](path)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("how", ["save", "write"])
def test_a_name_ending_in_a_slash_is_refused(tmp_path, result, how):
    """Path('out/') is Path('out'): save('out/') wrote a file named out (the executable
    refuses -o out/)."""
    with pytest.raises(tmafm.InputFileError, match="ends in /"):
        _writers(result)[how](str(tmp_path / "out") + "/")
    assert list(tmp_path.iterdir()) == []


#: A child that saves a Result whose write stalls after its first bytes (the temporary exists),
#: says so on stdout, and waits there for the parent's signal.
_STALLED_SAVE = r"""
import os, signal, sys, time
import tmafm, tmafm._safefile as safefile
if sys.argv[2] == "default":
    signal.signal(int(sys.argv[3]), signal.SIG_DFL)
result = tmafm.run("fig2_n4", solver={"tau_end": 0.2})
def stalled(fd, data):
    os.write(fd, bytes(data)[:100])
    print("writing", flush=True)
    time.sleep(60)
safefile._write_all = stalled
result.save(sys.argv[1])
print("saved", flush=True)
"""


@pytest.mark.parametrize("signo, disposition", [(signal.SIGTERM, "default"), (signal.SIGHUP, "default"),
                                                (signal.SIGINT, "default"), (signal.SIGINT, "python")])
def test_a_signal_during_save_leaves_no_temporary(tmp_path, signo, disposition):
    """SIGTERM (whose default action kills at once, past every finally) during Result.save left
    its .r.npz.partial-* behind (issue 18).  The temporary is removed, then the process dies of
    the signal as it would have (SIGINT with Python's handler: a KeyboardInterrupt)."""
    target = tmp_path / "out" / "r.npz"
    target.parent.mkdir()
    proc = subprocess.Popen([sys.executable, "-c", _STALLED_SAVE, str(target), disposition, str(int(signo))],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline() == "writing\n", proc.stderr.read() if proc.poll() is not None else ""
        assert _leftovers(target.parent)  # the stalled save has its temporary
        proc.send_signal(signo)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if disposition == "python":
        # An uncaught KeyboardInterrupt ends Python with SIGINT (Python >= 3.8).
        assert proc.returncode == -signal.SIGINT and "KeyboardInterrupt" in err, err
    else:
        assert proc.returncode == -signo, (proc.returncode, err)
    assert "saved" not in out
    assert list(target.parent.iterdir()) == []


_FIFO_WRITE = r"""
import sys
import tmafm._safefile as safefile
safefile.write_bytes(sys.argv[1], b"some bytes\n")
"""


def test_a_fifo_without_a_reader_says_that_it_waits(tmp_path):
    """Writing to a FIFO nobody reads blocked without a word (issue 18)."""
    import select

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    proc = subprocess.Popen([sys.executable, "-c", _FIFO_WRITE, str(fifo)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        ready, _, _ = select.select([proc.stderr], [], [], 60)
        assert ready, "no line on stderr within 60 s"
        line = proc.stderr.readline()
        assert line.startswith("tmafm: waiting for a reader of the FIFO ") and "pipe" in line, line
        with open(fifo, "rb") as reader:
            assert reader.read() == b"some bytes\n"
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0 and err == "", err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


# --- Result.save writes only what tmafm.load reads (issue 18, item 6) -------------------------

def _mutations(result):
    """Named changes to a Result's fields: each gives {field: new value} from the result."""
    n = result.tau.size
    text = result.resolved_text
    return {
        "nan_sample": lambda k: {"vt": np.where(np.arange(n) == k % n, np.nan, result.vt)},
        "inf_amplitude": lambda k: {"a": np.where(np.arange(n)[:, None] == k % n, np.inf, result.a)},
        "contact_256": lambda k: {"contact": np.where(np.arange(n) == k % n, 256, result.contact)},
        "contact_half": lambda k: {"contact": result.contact + 0.5},
        "contact_bool": lambda k: {"contact": result.contact.astype(bool)},
        "complex_vt": lambda k: {"vt": result.vt + 1j},
        "object_tau": lambda k: {"tau": np.array([object()] * n)},
        "string_vtdot": lambda k: {"vtdot": np.array(["0.5"] * n)},
        "float32_tau": lambda k: {"tau": result.tau.astype(np.float32)},
        "one_sample_less": lambda k: {"vt": result.vt[:-1]},
        "a_1d": lambda k: {"a": result.a[:, 0]},
        "adot_extra_mode": lambda k: {"adot": np.hstack([result.adot, result.adot[:, :1]])},
        "switches_2d": lambda k: {"switches": np.zeros((2, 2))},
        "switches_list": lambda k: {"switches": [0.1 * k, 0.2]},
        "counters_negative": lambda k: {"counters": dict(result.counters, steps=-k - 1)},
        "counters_huge": lambda k: {"counters": dict(result.counters, steps=10**400)},
        "counters_float": lambda k: {"counters": dict(result.counters, steps=1.5)},
        "counters_missing": lambda k: {"counters": {}},
        "counters_none": lambda k: {"counters": None},
        "resolved_bytes": lambda k: {"resolved_text": text.encode()},
        "resolved_surrogate": lambda k: {"resolved_text": text + "! \ud800\n"},
        "resolved_latin1_comment": lambda k: {"resolved_text": text + "! caf\udce9\n"},
        "resolved_nul": lambda k: {"resolved_text": text.replace("&scene", "&scene\0", 1)},
        "resolved_huge": lambda k: {"resolved_text": text + ("!" + "x" * 1000 + "\n") * 1100},
        "resolved_other_tau_end": lambda k: {"resolved_text": text.replace(
            "tau_end = 5.0E-001", f"tau_end = {0.5 + 0.01 * (k + 1)}")},
        "resolved_other_n": lambda k: {"resolved_text": text.replace("n_modes = 4", "n_modes = 3")},
        "resolved_garbage": lambda k: {"resolved_text": "garbage"},
        "resolved_empty": lambda k: {"resolved_text": ""},
        "resolved_control_file_name": lambda k: {"resolved_text": text.replace(
            "&output", "&output\n    file = 'a\x1bb'", 1)},
        "nothing": lambda k: {},
    }


def test_save_writes_only_what_load_reads_back(tmp_path_factory, result):
    """Property: for a Result changed in any of these ways, Result.save either refuses with a
    typed tmafm error and writes nothing, or writes a file that tmafm.load reads back equal.
    Before, save wrote NaN samples, contact flags of 256 (as 0), complex values (their real
    part), a resolved input that contradicts the arrays, or one with a NUL byte, and load then
    refused the file (or, for the cast flags and values, read back something else)."""
    from hypothesis import given, settings, strategies as st

    from tmafm._run import Result

    base = {name: getattr(result, name) for name in ("tau", "vt", "vtdot", "contact", "a", "adot",
                                                      "switches", "counters")}
    mutations = _mutations(result)
    outcomes = {"saved": 0, "refused": 0}

    @settings(max_examples=80, deadline=None, database=None)
    @given(st.lists(st.tuples(st.sampled_from(sorted(mutations)), st.integers(0, 10**6)),
                    min_size=1, max_size=2))
    def check(changes):
        fields = dict(base, resolved_text=result.resolved_text)
        for name, k in changes:
            fields.update(mutations[name](k))
        candidate = Result(**fields)
        folder = tmp_path_factory.mktemp("save")
        path = folder / "r.npz"
        try:
            candidate.save(path)
        except tmafm.TmafmError as exc:
            assert "\n" not in str(exc) and len(str(exc)) < 1200, str(exc)
            assert list(folder.iterdir()) == [], changes
            outcomes["refused"] += 1
            return
        outcomes["saved"] += 1
        back = tmafm.load(path)  # must not raise
        for name in ("tau", "vt", "vtdot", "a", "adot", "switches"):
            assert np.array_equal(getattr(back, name), np.asarray(fields[name], dtype=float)), name
        assert np.array_equal(back.contact, np.asarray(fields["contact"]).astype(np.int8))
        assert back.counters == {k: candidate.counters.get(k, 0) for k in tmafm.COUNTER_KEYS}
        assert back.resolved_text == fields["resolved_text"]

    check()
    assert outcomes["saved"] and outcomes["refused"], outcomes
