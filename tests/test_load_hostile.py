"""tmafm.load of files that are not what they claim: every one ends in a typed one-line
InputError (or InputFileError), never a raw Python exception, and never a Result that the
file's own resolved input contradicts.  Before, a counters member of strings raised a raw
ValueError, a 0-d tau an IndexError, a lone .npy a TypeError, an empty file an EOFError, a
resolved text of invalid UTF-8 a UnicodeDecodeError; and a vt shorter than tau, complex
amplitudes (cast with a warning), contact flags of 300, NaN samples or an unreadable resolved
input (``.scene`` then {} or a raw f90nml ValueError) loaded as a Result."""

import numpy as np
import pytest

import tmafm


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    path = tmp_path_factory.mktemp("good") / "good.npz"
    result = tmafm.run("fig2_n4", solver={"tau_end": 1.0})
    result.save(path)
    with np.load(path) as data:
        return path, {name: data[name] for name in data.files}


def _n(members):
    return members["tau"].size


CASES = [
    ("counters_strings", lambda m: {"counters": np.array(list("abcde"))}),
    ("counters_two", lambda m: {"counters": np.array([1, 2], dtype="<i8")}),
    ("counters_nan", lambda m: {"counters": np.array([1.5, 2, 3, 4, np.nan])}),
    ("counters_negative", lambda m: {"counters": -m["counters"]}),
    ("resolved_array", lambda m: {"resolved": np.array([b"a", b"b"])}),
    ("resolved_int", lambda m: {"resolved": np.array(5)}),
    ("resolved_bad_namelist", lambda m: {"resolved": np.array(b"&model n_modes = /")}),
    ("resolved_open_group", lambda m: {"resolved": np.array(b"&model n_modes = 3 ")}),
    ("resolved_garbage", lambda m: {"resolved": np.array(b"garbage")}),
    ("resolved_not_utf8", lambda m: {"resolved": np.array(b"\xff\xfe")}),
    ("resolved_other_n", lambda m: {"resolved": np.array(
        m["resolved"].item().replace(b"n_modes = 4", b"n_modes = 3"))}),
    ("resolved_other_tau_end", lambda m: {"resolved": np.array(
        m["resolved"].item().replace(b"tau_end = 1.0E+000", b"tau_end = 2.0E+000"))}),
    ("version_other", lambda m: {"version": np.array(b"numpy 2.0")}),
    ("tau_0d", lambda m: {"tau": np.array(1.0)}),
    ("tau_2d", lambda m: {"tau": np.zeros((2, 2))}),
    ("tau_strings", lambda m: {"tau": np.array(["x"] * _n(m))}),
    ("tau_float32", lambda m: {"tau": m["tau"].astype(np.float32)}),
    ("vt_short", lambda m: {"vt": np.zeros(3)}),
    ("vt_complex", lambda m: {"vt": m["vt"] + 1j}),
    ("vt_nan", lambda m: {"vt": np.full(_n(m), np.nan)}),
    ("a_1d", lambda m: {"a": np.zeros(_n(m)), "adot": np.zeros(_n(m))}),
    ("adot_other_n", lambda m: {"adot": np.zeros((_n(m), 3))}),
    ("contact_300", lambda m: {"contact": np.full(_n(m), 300, dtype=np.int16)}),
    ("contact_2", lambda m: {"contact": np.full(_n(m), 2, dtype=np.int8)}),
    ("switches_2d", lambda m: {"switches": np.zeros((2, 2))}),
    ("structured_tau", lambda m: {"tau": np.zeros(_n(m), dtype=[("x", "f8")])}),
    ("object_member", lambda m: {"tau": np.array([object()] * _n(m))}),
    ("missing_member", lambda m: {"version": None}),
]


@pytest.mark.parametrize("change", [c[1] for c in CASES], ids=[c[0] for c in CASES])
def test_a_tampered_archive_is_refused_with_a_typed_error(tmp_path, saved, change):
    _, members = saved
    members = dict(members)
    for name, value in change(members).items():
        if value is None:
            del members[name]
        else:
            members[name] = value
    path = tmp_path / "bad.npz"
    np.savez(path, **members)
    with pytest.raises(tmafm.InputError) as info:
        tmafm.load(path)
    message = str(info.value)
    assert "bad.npz" in message and "\n" not in message and len(message) < 1200, message


@pytest.mark.parametrize("content", [b"", b"hello", b"PK\x03\x04" + b"\0" * 40],
                         ids=["empty", "text", "cut_zip"])
def test_a_file_that_is_not_an_archive_is_refused(tmp_path, content):
    path = tmp_path / "bad.npz"
    path.write_bytes(content)
    with pytest.raises(tmafm.InputError):
        tmafm.load(path)


def test_a_lone_npy_array_and_a_cut_archive_are_refused(tmp_path, saved):
    good, _ = saved
    np.save(tmp_path / "plain.npy", np.zeros(3))
    with pytest.raises(tmafm.InputError, match="single .npy"):
        tmafm.load(tmp_path / "plain.npy")
    data = good.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(tmafm.InputError):
        tmafm.load(tmp_path / "cut.npz")
    flipped = bytearray(data)
    flipped[len(data) // 3] ^= 0xFF  # inside a member: its CRC-32 no longer checks
    (tmp_path / "flipped.npz").write_bytes(bytes(flipped))
    with pytest.raises(tmafm.InputError):
        tmafm.load(tmp_path / "flipped.npz")


@pytest.mark.parametrize("path, error", [(42, tmafm.InputTypeError), ("x" * 5000, tmafm.InputFileError),
                                         ("a\0b.npz", tmafm.InputFileError)],
                         ids=["int", "long_name", "nul"])
def test_a_bad_path_is_a_typed_error(path, error):
    with pytest.raises(error):
        tmafm.load(path)


def test_the_untouched_archive_still_loads_and_a_big_endian_one_too(tmp_path, saved):
    good, members = saved
    loaded = tmafm.load(good)
    assert np.array_equal(loaded.vt, members["vt"]) and loaded.scene["omega"] == 2.0
    swapped = {k: (v.astype(v.dtype.newbyteorder(">")) if v.dtype.kind in "fi" and v.dtype.itemsize > 1
                   else v) for k, v in members.items()}
    np.savez(tmp_path / "big.npz", **swapped)
    back = tmafm.load(tmp_path / "big.npz")
    assert np.array_equal(back.vt, loaded.vt) and np.array_equal(back.a, loaded.a)
    assert back.counters == loaded.counters


@pytest.fixture(scope="module")
def auto_n(tmp_path_factory):
    """A result of an automatic N (&model n_modes = 0), saved."""
    path = tmp_path_factory.mktemp("auto") / "auto.npz"
    result = tmafm.run("fig2_n4", model={"n_modes": 0}, solver={"tau_end": 1.0})
    result.save(path)
    return path, result


def _no_search(monkeypatch):
    """Make the core's readers fail the test when asked for an automatic N, which runs the
    search for N (tmafm_api choose_modes); returns the list of the texts they were given."""
    import re

    from tmafm import _run
    api = _run._api
    given = []
    automatic = re.compile(r"^\s*n_modes\s*=\s*0\s*$", re.MULTILINE)

    def one(text, *args):
        given.append(text)
        assert not automatic.search(text.decode("utf-8", "replace")), "the search for N ran"
        return real_one(text, *args)

    def two(text, label, override, *args):
        given.append(text)
        if automatic.search(text.decode("utf-8", "replace")):
            assert re.search(rb"n_modes = [1-9]", override), "the search for N ran"
        return real_two(text, label, override, *args)

    real_one, real_two = api.config_from_text, api.config_from_texts
    monkeypatch.setattr(api, "config_from_text", one)
    monkeypatch.setattr(api, "config_from_texts", two)
    return given


def test_loading_an_automatic_n_result_runs_nothing_and_gives_the_fresh_result(monkeypatch, auto_n):
    """tmafm.load read the resolved input (n_modes = 0) with the core, which ran the search for
    N again (8.4 s for one result of issue 18); it now takes the N the input records."""
    path, fresh = auto_n
    given = _no_search(monkeypatch)
    loaded = tmafm.load(path)
    assert given, "load read no resolved input"
    assert loaded.n_modes == fresh.n_modes == loaded.config.n_modes == 3
    assert loaded.resolved_text == fresh.resolved_text  # with n_modes = 0 and the chosen N
    assert "chosen n_modes = 3" in loaded.resolved_text
    assert loaded.scene == fresh.scene and loaded.counters == fresh.counters
    assert loaded.config.n_samples == fresh.config.n_samples
    for name in ("tau", "vt", "vtdot", "contact", "a", "adot", "switches"):
        assert np.array_equal(getattr(loaded, name), getattr(fresh, name)), name
    # The loaded Config is the fresh one with its N fixed (and &initial cut to N).
    mine, theirs = loaded.config.to_dict(), fresh.config.to_dict()
    assert mine["model"].pop("n_modes") == 3 and theirs["model"].pop("n_modes") == 0
    assert mine.pop("initial") == {"a0": [0.0] * 3, "adot0": [0.0] * 3}
    theirs.pop("initial")
    assert mine == theirs


@pytest.mark.parametrize("change, words", [
    (lambda t: t.replace(b"chosen n_modes = 3", b"chosen n_modes = 4"), "chosen N = 4"),
    (lambda t: t.replace(b"! chosen n_modes = 3", b"! nothing chosen"), "records no chosen N"),
    (lambda t: t.replace(b"n_modes = 0", b"n_modes = 3"), "records a chosen N"),
    (lambda t: t.replace(b"a0 = 0.0E+000, 0.0E+000, 0.0E+000, 0.0E+000",
                         b"a0 = 0.0E+000, 0.0E+000, 0.0E+000, 1.0E-003"), "nonzero value past mode 3"),
], ids=["other_chosen_n", "no_chosen_n", "fixed_n_with_a_chosen_n", "initial_value_past_n"])
def test_an_automatic_n_that_the_arrays_contradict_is_refused_without_a_search(
        tmp_path, monkeypatch, auto_n, change, words):
    path, _ = auto_n
    with np.load(path) as data:
        members = {name: data[name] for name in data.files}
    members["resolved"] = np.array(change(members["resolved"].item()))
    np.savez(tmp_path / "bad.npz", **members)
    _no_search(monkeypatch)
    with pytest.raises(tmafm.InputError, match=words):
        tmafm.load(tmp_path / "bad.npz")
