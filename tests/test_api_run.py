"""tmafm.run and tmafm.Config in memory: typed input checks, packaged inputs, no files written,
read-once semantics, save/load, and the installed package used from outside the repository."""

import os
import subprocess
import sys
import textwrap

import f90nml
import numpy as np
import pytest

import tmafm
from conftest import INPUTS

SHORT = {"solver": {"tau_end": 2.0}}
ARRAYS = ("tau", "vt", "vtdot", "contact", "a", "adot", "switches")


def _same(r1, r2):
    for name in ARRAYS:
        np.testing.assert_array_equal(getattr(r1, name), getattr(r2, name), err_msg=name)
    assert r1.counters == r2.counters


def test_dict_path_name_and_config_give_one_result():
    by_path = tmafm.run(INPUTS / "fig2_n4.nml", **SHORT)
    by_name = tmafm.run("fig2_n4", **SHORT)
    groups = {g: dict(v) for g, v in f90nml.read(str(INPUTS / "fig2_n4.nml")).items()}
    groups["solver"].update(SHORT["solver"])
    by_dict = tmafm.run(groups)
    by_config = tmafm.Config("fig2_n4", **SHORT).run()
    for other in (by_name, by_dict, by_config):
        _same(by_path, other)
    assert by_path.resolved == by_dict.resolved
    assert by_path.scene == by_dict.scene


def test_resolved_is_lazy_and_complete():
    config = tmafm.Config({"model": {"n_modes": 2}, "solver": {"tau_end": 1.0}})
    result = config.run()
    assert result._resolved is None
    resolved = result.resolved
    assert isinstance(resolved, f90nml.Namelist)
    assert resolved["model"]["n_modes"] == 2 and resolved["solver"]["tau_end"] == 1.0
    assert resolved["scene"]["omega"] == result.scene["omega"] == 2.0
    assert config.to_dict()["solver"]["method"] == "rk4_paper"
    # The resolved input reruns to the same arrays.
    _same(result, tmafm.run(config.to_dict()))


def test_the_input_is_read_once(tmp_path):
    path = tmp_path / "in.nml"
    path.write_text("&model n_modes = 2 /\n&solver tau_end = 1.0 /\n")
    config = tmafm.Config(path)
    path.write_text("&model n_modes = 3 /\n&solver tau_end = 2.0 /\n")
    result = config.run()
    assert result.a.shape == (101, 2)
    assert result.resolved["model"]["n_modes"] == 2


def test_config_write_is_a_valid_input(tmp_path):
    config = tmafm.Config("physical_polystyrene", solver={"tau_end": 1.0})
    path = config.write(tmp_path / "resolved.nml")
    again = tmafm.Config(path)
    assert again.scene == config.scene
    _same(config.run(), again.run())
    assert [p.name for p in tmp_path.iterdir()] == ["resolved.nml"]


def test_run_writes_no_file_and_needs_no_writable_folder(tmp_path):
    """A child process with TMPDIR and HOME pointing nowhere writable gives the same arrays."""
    reference = tmafm.run("fig2_n4", **SHORT)
    out = tmp_path / "ref.npz"
    reference.save(out)
    nowhere = tmp_path / "missing" / "folder"
    env = dict(os.environ, TMPDIR=str(nowhere), TEMP=str(nowhere), TMP=str(nowhere),
               HOME=str(nowhere))
    script = textwrap.dedent(f"""
        import numpy as np, tmafm
        r = tmafm.run("fig2_n4", solver={{"tau_end": 2.0}})
        ref = tmafm.load({str(out)!r})
        for name in {ARRAYS!r}:
            assert np.array_equal(getattr(r, name), getattr(ref, name)), name
        print("same")
    """)
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    before = set(os.listdir("/tmp"))
    proc = subprocess.run([sys.executable, "-c", script], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "same"
    assert list(cwd.iterdir()) == []
    assert not nowhere.exists()
    # The old file-based path left temporary .nml files in /tmp; other processes on a shared
    # machine may create their own entries there meanwhile, so look for ours only.
    assert not {p for p in set(os.listdir("/tmp")) - before if p.endswith(".nml")}


@pytest.mark.parametrize("groups,match", [
    ({"solver": {"tau_end": "5"}}, r"&solver tau_end = '5': must be a real"),
    ({"solver": {"tau_end": None}}, r"&solver tau_end = None"),
    ({"solver": {"tau_end": True}}, r"&solver tau_end = True: a bool"),
    ({"solver": {"tau_end": [1, 2]}}, r"&solver tau_end .*not a list"),
    ({"initial": {"a0": [[1e-4], [0.0]]}}, r"&initial a0 .*nested"),
    ({"initial": {"a0": ["x"]}}, r"&initial a0 .*number"),
    ({"model": {"n_modes": 2.5}}, r"&model n_modes = 2.5: must be an integer"),
    ({"model": {"convention": 1}}, r"&model convention = 1: must be a quoted string"),
    ({"solver": {"tau_end": float("nan")}}, r"&solver tau_end = nan: must be a finite"),
    ({"bogus": {}}, r"unknown namelist group &bogus"),
    ({"solver": 5}, r"&solver must be a dict"),
    ({3: {}}, r"group names must be strings"),
    ({"solver": {1: 2}}, r"&solver: key names must be strings"),
    ({"solver": {"tua_end": 5.0}}, r"&solver tua_end: unknown key"),
    ({"solver": {"tau_end": -1.0}}, r"&solver tau_end = -1"),
])
def test_bad_dict_values_name_group_and_key(groups, match):
    with pytest.raises(tmafm.InputError, match=match):
        tmafm.run(groups)


def test_override_typo_names_the_override():
    with pytest.raises(tmafm.InputError) as info:
        tmafm.run("fig2_n4", solver={"tua_end": 5.0})
    assert "override" in str(info.value) and "tua_end" in str(info.value)
    assert "fig2_n4.nml" not in str(info.value)


def test_bad_sources_are_tmafm_errors(tmp_path):
    with pytest.raises(tmafm.InputFileError, match="no packaged input has that name"):
        tmafm.run("no_such_input")
    with pytest.raises(tmafm.InputFileError, match="not a regular file"):
        tmafm.run(tmp_path)
    with pytest.raises(tmafm.InputTypeError, match="must be a path"):
        tmafm.run(42)
    binary = tmp_path / "binary.nml"
    binary.write_bytes(b"\xff\xfe&\x00m\x00")
    with pytest.raises(tmafm.InputError):
        tmafm.run(binary)


def test_packaged_inputs_are_the_repository_inputs():
    names = tmafm.inputs.names()
    # Every run input, the bimodal example's subfolder included (the sweep files: sweep_names).
    assert names == sorted(p.stem for p in INPUTS.glob("*.nml")) + sorted(
        f"bimodal/{p.stem}" for p in (INPUTS / "bimodal").glob("*.nml"))
    for name in names:
        assert tmafm.inputs.path(name).read_bytes() == (INPUTS / f"{name}.nml").read_bytes()
    with pytest.raises(tmafm.InputFileError, match=r"known: (\w+, )+fig2_n1"):
        tmafm.inputs.path("fig99")


def test_save_and_load_roundtrip(tmp_path):
    result = tmafm.run("fig7_dmt", model={"convention": "consistent"}, solver={"tau_end": 3.0})
    path = result.save(tmp_path / "r.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.npz"]
    loaded = tmafm.load(path)
    _same(result, loaded)
    assert loaded.a.flags.f_contiguous
    assert loaded.resolved == result.resolved
    assert loaded.scene == result.scene
    with np.load(path) as data:
        assert data["a"].flags.f_contiguous and data["a"].dtype == np.dtype("<f8")
        assert data["contact"].dtype == np.dtype("|i1") and data["counters"].dtype == "<i8"
        assert data["version"].item().startswith(b"tmafm ")
        assert data["resolved"].shape == ()


def test_physical_input_scene_survives_save_and_load(tmp_path):
    result = tmafm.run("physical_polystyrene", solver={"tau_end": 0.5})
    loaded = tmafm.load(result.save(tmp_path / "p.npz"))
    assert loaded.scene == pytest.approx(result.scene, rel=1e-15)


def test_load_refuses_other_files(tmp_path):
    with pytest.raises(tmafm.InputFileError):
        tmafm.load(tmp_path / "none.npz")
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(tmafm.InputError, match="missing"):
        tmafm.load(tmp_path / "other.npz")
    (tmp_path / "text.npz").write_text("hello")
    with pytest.raises(tmafm.InputError):
        tmafm.load(tmp_path / "text.npz")


def test_installed_package_works_from_any_folder(tmp_path):
    script = ("import tmafm; r = tmafm.run('fig2_n4', solver={'tau_end': 1.0}); "
              "print(r.a.shape, tmafm.__file__)")
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("(101, 4)")
    assert "pywrap" not in proc.stdout
    proc = subprocess.run([sys.executable, "-m", "tmafm.figures", "--help"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "--out" in proc.stdout


def test_load_reads_the_executables_npz(tmp_path, exe):
    """The executable's &output format = 'npy' archive loads to the arrays tmafm.run returns."""
    config = tmafm.Config("fig7_hertz", solver={"tau_end": 3.0, "method": "dopri5"},
                          output={"format": "npy", "file": "out.npz"})
    path = config.write(tmp_path / "in.nml")
    proc = subprocess.run([exe, str(path), "-q"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    loaded = tmafm.load(tmp_path / "out.npz")
    _same(loaded, config.run())
    assert loaded.resolved["solver"]["method"] == "dopri5"
    assert loaded.scene == config.scene


def test_convention_override_on_a_resolved_config_is_refused_not_misread():
    """A Config pins &model errata to its convention's list; overriding the convention alone
    used to keep that list (a 'consistent' run with the printed equations)."""
    base = tmafm.Config("fig2_n4")
    with pytest.raises(tmafm.InputError, match=r"convention is overridden .* errata = 'none'"):
        tmafm.Config(base, model={"convention": "consistent"})
    followed = tmafm.Config(base, model={"convention": "consistent", "errata": "convention"})
    direct = tmafm.Config("fig2_n4", model={"convention": "consistent"})
    assert followed.to_dict()["model"] == direct.to_dict()["model"]
    assert direct.to_dict()["model"]["errata"] == "E1,E2,E3,E4,E6,E7"
