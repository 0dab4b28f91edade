"""The executable's command line against mistakes that lost data or were ignored silently:
``-o`` given twice used the last one; an output name that is the input file itself (by any
path: the same name, a symbolic or a hard link, an output file rerun from its own header)
replaced the user's input with the output."""

import os

import pytest

from conftest import INPUTS, write_nml


def short_input(tmp_path, name="short.nml", **groups):
    groups.setdefault("solver", {}).setdefault("tau_end", 1.0)
    groups.setdefault("output", {}).setdefault("file", "short.dat")
    return write_nml(tmp_path / name, base=INPUTS / "fig2_n4.nml", **groups)


def _one_error(proc):
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tmafm: error: "), proc.stderr
    return lines[0]


def test_output_option_twice_is_refused(tmp_path, run_exe):
    path = short_input(tmp_path)
    proc = run_exe(path, "-q", "-o", "a.dat", "--output", "b.dat")
    assert proc.returncode == 1
    assert "given twice" in _one_error(proc)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["short.nml"]


@pytest.mark.parametrize("how", ["same", "dot", "symlink", "hardlink", "absolute"])
def test_output_over_the_input_file_is_refused(tmp_path, run_exe, how):
    path = short_input(tmp_path)
    before = path.read_bytes()
    if how == "symlink":
        os.symlink(path.name, tmp_path / "link.nml")
        args = ["link.nml", "-o", path.name]
    elif how == "hardlink":
        os.link(path, tmp_path / "hard.nml")
        args = [path.name, "-o", "hard.nml"]
    else:
        target = {"same": path.name, "dot": f"./{path.name}", "absolute": str(path)}[how]
        args = [path.name, "-o", target]
    proc = run_exe(*args, "-q")
    assert proc.returncode == 3
    line = _one_error(proc)
    assert "is the input file" in line
    assert path.read_bytes() == before
    assert not [p for p in tmp_path.iterdir() if "partial" in p.name]


def test_an_output_file_rerun_from_its_own_header_keeps_itself(tmp_path, run_exe):
    """`tmafm out.dat` (its header says file = 'out.dat') replaced itself; a new name works."""
    assert run_exe(short_input(tmp_path), "-q").returncode == 0
    out = tmp_path / "short.dat"
    before = out.read_bytes()
    proc = run_exe("short.dat", "-q")
    assert proc.returncode == 3 and "is the input file" in _one_error(proc)
    assert out.read_bytes() == before
    assert run_exe("short.dat", "-q", "-o", "again.dat").returncode == 0


def test_standard_output_keeps_a_header_that_reruns(tmp_path, exe, run_exe):
    """`-o -` wrote file = '-' into the header, which then ran to standard output again, and a
    namelist with file = '-' wrote to standard output (issue 18).  '-' in a namelist is refused
    as ambiguous; the header of a `-o -` run keeps the input's &output file, so the saved
    stream is a valid input that writes a file."""
    import subprocess

    path = short_input(tmp_path)
    with open(tmp_path / "saved.dat", "wb") as saved:
        proc = subprocess.run([exe, str(path), "-q", "-o", "-"], cwd=tmp_path, stdout=saved,
                              stderr=subprocess.PIPE, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    header = (tmp_path / "saved.dat").read_text().splitlines()
    assert "#     file = 'short.dat'" in header and "#     file = '-'" not in header
    rerun = run_exe("saved.dat", "-q")
    assert rerun.returncode == 0 and rerun.stdout == "", rerun.stderr
    assert (tmp_path / "short.dat").read_text().splitlines()[2:] == header[2:]
    dash = short_input(tmp_path, "dash.nml", output={"file": "-"})
    proc = run_exe(dash, "-q")
    assert proc.returncode == 2 and proc.stdout == ""
    assert "&output file = '-': is ambiguous" in _one_error(proc)


@pytest.mark.parametrize("name", ["  lead.dat", "trail.dat  "])
def test_blanks_around_a_file_name_are_refused_not_dropped(tmp_path, run_exe, name):
    """&output file = '  lead.dat' wrote lead.dat (and the header said so): a value silently
    changed.  -o 'x.dat ' wrote x.dat."""
    path = short_input(tmp_path, output={"file": name})
    proc = run_exe(path, "-q")
    assert proc.returncode == 2
    line = _one_error(proc)
    assert "&output file" in line and "blank" in line
    proc = run_exe(short_input(tmp_path, name="plain.nml"), "-q", "-o", name)
    assert proc.returncode == 1 and "blank" in _one_error(proc)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plain.nml", "short.nml"]
    inner = run_exe(short_input(tmp_path, name="inner.nml"), "-q", "-o", "in ner.dat")
    assert inner.returncode == 0 and (tmp_path / "in ner.dat").is_file()


@pytest.mark.parametrize("fmt", ["text", "npy"])
def test_a_file_size_limit_is_a_write_error_not_a_crash(tmp_path, exe, fmt):
    """Under `ulimit -f` (RLIMIT_FSIZE) the write past the limit raised SIGXFSZ: the process
    died with a gfortran backtrace (exit 153 from a shell) and left .out.dat.partial-* behind."""
    import resource
    import subprocess

    name = "out.npz" if fmt == "npy" else "out.dat"
    path = short_input(tmp_path, solver={"tau_end": 20.0}, output={"format": fmt, "file": name})
    previous = tmp_path / name
    previous.write_text("previous result\n")

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (20480, 20480))

    proc = subprocess.run([exe, str(path), "-q"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120, preexec_fn=limit)
    assert proc.returncode == 3, (proc.returncode, proc.stderr)
    assert "File too large" in _one_error(proc)
    assert previous.read_text() == "previous result\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "short.nml"])
