"""A namelist file read from Python (tmafm.Config(path)) is read as the executable reads it
(docs/reliability.md#input).  Before, Python decoded the file as UTF-8 and handed it to f2py
as a C string: a file with a NUL byte was silently read up to the NUL (the rest ignored), a
Latin-1 comment that the executable accepts was refused, and a file of any size was read
whole into memory (the executable stops at 1 MiB)."""

import subprocess

import pytest

import tmafm


def _executable_accepts(exe, path):
    proc = subprocess.run([exe, str(path), "-q", "-o", "/dev/null"], capture_output=True,
                          text=True, timeout=120)
    return proc.returncode == 0, proc.stderr


def test_a_nul_byte_is_refused_as_the_executable_refuses_it(tmp_path, exe):
    path = tmp_path / "nul.nml"
    path.write_bytes(b"&solver tau_end = 1 /\n\0\n&model bogus = 1 /\n")
    ok, stderr = _executable_accepts(exe, path)
    assert not ok and "NUL byte" in stderr
    with pytest.raises(tmafm.InputError, match=r"line 2: a NUL byte"):
        tmafm.Config(path)


def test_a_latin1_comment_is_accepted_as_the_executable_accepts_it(tmp_path, exe):
    path = tmp_path / "latin1.nml"
    path.write_bytes(b"! caf\xe9: a Latin-1 comment\n&solver tau_end = 1 /\n")
    assert _executable_accepts(exe, path) == (True, "")
    config = tmafm.Config(path, solver={"dtau": 1e-3})
    assert config.to_dict()["solver"]["tau_end"] == 1.0
    assert tmafm.Config(path).text == tmafm.Config({"solver": {"tau_end": 1.0}}).text


def test_a_latin1_byte_outside_comments_is_refused_by_name(tmp_path):
    path = tmp_path / "latin1.nml"
    path.write_bytes(b"&solver tau_end = 1\xe9 /\n")
    with pytest.raises(tmafm.InputError, match="tau_end"):
        tmafm.Config(path)


def test_a_huge_file_is_refused_without_reading_it(tmp_path, exe):
    path = tmp_path / "huge.nml"
    with open(path, "wb") as handle:  # sparse: 64 GiB of zeros that take no disk
        handle.truncate(64 * 2**30)
    ok, stderr = _executable_accepts(exe, path)
    assert not ok and "larger than 1048576 bytes" in stderr
    with pytest.raises(tmafm.InputError, match="larger than 1048576 bytes"):
        tmafm.Config(path)
    just = tmp_path / "just.nml"
    just.write_bytes(b"&solver tau_end = 1 /\n" + b" " * (2**20 - 22))
    assert just.stat().st_size == 2**20
    assert tmafm.Config(just).to_dict()["solver"]["tau_end"] == 1.0


def test_utf16_gets_the_cores_message(tmp_path):
    path = tmp_path / "utf16.nml"
    path.write_bytes("&solver tau_end = 1 /\n".encode("utf-16"))
    with pytest.raises(tmafm.InputError, match="UTF-16"):
        tmafm.Config(path)


def test_a_latin1_file_name_keeps_its_bytes(tmp_path, exe):
    """The executable writes &output file = 'caf\\xe9.dat' (one Latin-1 byte) under that byte;
    a Config of the same file, its pickle and its written text keep the byte (the resolved text
    was decoded with U+FFFD: Config.write and a pickled copy named another file)."""
    import pickle

    path = tmp_path / "latin1.nml"
    path.write_bytes(b"&solver tau_end = 0.1 /\n&output file = 'caf\xe9.dat' /\n")
    config = tmafm.Config(path)
    copy = pickle.loads(pickle.dumps(config))
    assert copy.text == config.text and "\ufffd" not in config.text
    written = config.write(tmp_path / "written.nml")
    assert b"file = 'caf\xe9.dat'" in written.read_bytes()
    proc = subprocess.run([exe, str(written), "-q"], cwd=tmp_path, capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "caf\udce9.dat").is_file()  # os.fsencode: the byte 0xe9
    result = config.run()
    loaded = tmafm.load(result.save(tmp_path / "r.npz"))
    assert loaded.resolved_text == config.text


def test_an_output_file_larger_than_the_limit_is_read_through_its_header(tmp_path, exe):
    """The executable reads an output file's header only, so a 5 MB output reruns; the 1 MiB
    limit of Python's reader must count the header too, not the rows."""
    (tmp_path / "in.nml").write_text("&solver tau_end = 2 /\n"
                                     "&output file = 'big.dat', sample_dtau = 1e-4 /\n")
    proc = subprocess.run([exe, "in.nml", "-q"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    big = tmp_path / "big.dat"
    assert big.stat().st_size > 2**20
    rerun, direct = tmafm.Config(big).to_dict(), tmafm.Config(tmp_path / "in.nml").to_dict()
    for group in ("solver", "output", "scene", "initial"):
        assert rerun[group] == direct[group], group
    assert tmafm.Config(big, solver={"tau_end": 1.0}).to_dict()["solver"]["tau_end"] == 1.0
