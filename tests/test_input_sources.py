"""Where input comes from: a pipe, an output file's own header, f90nml's text (Python dicts),
and the automatic choice of N as the header records it."""

import subprocess

import f90nml
import numpy as np
import pytest

import tmafm
from testcore import core as _core

from conftest import INPUTS, write_nml


def short_input(tmp_path, **groups):
    groups.setdefault("solver", {}).setdefault("tau_end", 2.0)
    groups.setdefault("output", {}).setdefault("file", "short.dat")
    return write_nml(tmp_path / "short.nml", base=INPUTS / "fig2_n4.nml", **groups)


def test_non_seekable_input(tmp_path, exe):
    """`tmafm <(cat file)` reads a pipe: nothing seeks or rewinds."""
    path = short_input(tmp_path)
    proc = subprocess.run(["bash", "-c", f"'{exe}' <(cat '{path}') -q -o piped.dat"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert subprocess.run([exe, str(path), "-q", "-o", "direct.dat"], cwd=tmp_path).returncode == 0
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "piped.dat"), np.loadtxt(tmp_path / "direct.dat"))


@pytest.mark.parametrize("base", ["fig2_n4.nml", "physical_polystyrene.nml"])
def test_output_file_is_an_input(tmp_path, run_exe, base):
    """`tmafm out.dat -o out2.dat` reruns the run its header describes: the same rows."""
    path = write_nml(tmp_path / "in.nml", base=INPUTS / base, solver={"tau_end": 1.0},
                     output={"file": "out.dat"})
    assert run_exe(path.name, "-q").returncode == 0
    proc = run_exe("out.dat", "-q", "-o", "out2.dat")
    assert proc.returncode == 0, proc.stderr
    first, second = (tmp_path / "out.dat").read_text(), (tmp_path / "out2.dat").read_text()
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "out.dat"), np.loadtxt(tmp_path / "out2.dat"))
    # The headers differ only in the input name and the file key.
    changed = [(a, b) for a, b in zip(first.splitlines(), second.splitlines()) if a != b]
    assert changed == [("# input: in.nml", "# input: out.dat"),
                       ("#     file = 'out.dat'", "#     file = 'out2.dat'")]


def test_output_header_derived_scene_stays_a_comment(tmp_path, run_exe):
    """An edited derived &scene line in the header has no effect: it is a comment."""
    path = write_nml(tmp_path / "in.nml", base=INPUTS / "physical_polystyrene.nml",
                     solver={"tau_end": 0.5}, output={"file": "out.dat"})
    assert run_exe(path, "-q").returncode == 0
    text = (tmp_path / "out.dat").read_text()
    assert "# ! derived by Eq. (12): &scene" in text
    (tmp_path / "edited.dat").write_text(text.replace("Eq. (12):     alpha1 = 5.0E-002",
                                                      "Eq. (12):     alpha1 = 0.5"))
    assert run_exe("edited.dat", "-q", "-o", "out2.dat").returncode == 0
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "out.dat"), np.loadtxt(tmp_path / "out2.dat"))


def test_f90nml_text_parses_with_the_same_values(tmp_path):
    """Python dicts reach the core as f90nml's text: lists, integers in real keys, strings."""
    groups = {"model": {"n_modes": 2, "contact_law": "dmt", "convention": "consistent"},
              "initial": {"a0": [1e-4, 0.0], "adot0": [0, -2.5e-6]},
              "solver": {"method": "dopri5", "tau_end": 3, "rtol": 1e-9, "max_steps": 123456},
              "output": {"sample_dtau": 0.5, "format": "npy"}}
    resolved, _ = tmafm.resolve(groups)
    assert resolved["model"]["n_modes"] == 2
    assert resolved["model"]["contact_law"] == "dmt"
    assert resolved["initial"]["a0"] == [1e-4, 0.0]
    assert resolved["initial"]["adot0"] == [0.0, -2.5e-6]
    assert resolved["solver"]["tau_end"] == 3.0 and resolved["solver"]["rtol"] == 1e-9
    assert resolved["solver"]["max_steps"] == 123456
    assert resolved["output"]["format"] == "npy" and resolved["output"]["sample_dtau"] == 0.5
    # The resolved text reads back to itself.
    again, _ = tmafm.resolve({g: dict(v) for g, v in resolved.items()})
    assert again == resolved


@pytest.mark.parametrize("bad", [{"solver": {"tau_end": True}}, {"solver": {"tau_end": "5"}},
                                 {"solver": {"tau_end": [1, 2]}}, {"model": {"n_modes": 3.0}},
                                 {"solver": {"max_steps": 1.5}}, {"output": {"format": "xml"}}])
def test_f90nml_wrong_types_raise(bad):
    group, values = next(iter(bad.items()))
    key = next(iter(values))
    with pytest.raises(tmafm.InputError, match=rf"^(<dict input>: )?&{group} {key} = "):
        tmafm.resolve(bad)


def test_automatic_n_starts_at_one_and_labels_differences(tmp_path, run_exe):
    """n_modes = 0 compares N = 1, 2, ... whatever a0 holds; each difference carries its N, and
    a nonzero initial value beyond the chosen N raises N instead of being dropped."""
    path = tmp_path / "auto.nml"
    path.write_text("&model n_modes = 0, mode_horizon = 2, mode_tol = 0.5 /\n"
                    "&initial a0 = 0, 0, 0, 1e-6 /\n&solver tau_end = 0.2 /\n&output file = 'a.dat' /\n")
    proc = run_exe(path, "-q")
    assert proc.returncode == 0, proc.stderr
    header = [line for line in (tmp_path / "a.dat").read_text().splitlines() if "chosen n_modes" in line]
    assert len(header) == 1, header
    assert "N=1: " in header[0]
    # With mode_tol = 0.5, N = 1 agrees with N = 2 (the first comparison) ...
    assert "N=2: " not in header[0]
    # ... but a0(4) is nonzero, so N = 4 is kept.
    assert "chosen n_modes = 4 (the search stopped at N = 1;" in header[0]
    data = np.loadtxt(tmp_path / "a.dat")
    assert data.shape[1] == 4 + 2 * 4
    np.testing.assert_array_equal(data[0, 4:8], [0, 0, 0, 1e-6])
    # The header reruns the same choice.
    assert run_exe("a.dat", "-q", "-o", "b.dat").returncode == 0
    np.testing.assert_array_equal(data, np.loadtxt(tmp_path / "b.dat"))


def test_config_text_is_the_header(tmp_path, run_exe):
    """write_config (the header) and the resolved text Python gets are the same text."""
    path = short_input(tmp_path)
    assert run_exe(path, "-q").returncode == 0
    header = [line[2:] for line in (tmp_path / "short.dat").read_text().splitlines()
              if line.startswith("# ")][2:-2]
    resolved, _ = tmafm.resolve(path)
    from_header = f90nml.reads("\n".join(header))
    assert from_header == resolved


@pytest.mark.parametrize("indent", [0, 250, 255, 256, 257, 511, 700])
def test_long_lines_read_in_pieces(tmp_path, indent):
    """The reader takes a line in pieces of 256 characters (tmafm_input_file): a key, a value or
    a comment across a piece boundary, and lines of several pieces, read as the short file does."""
    plain = (INPUTS / "fig2_n4.nml").read_text()
    padded = plain.replace("    alpha1 =", " " * indent + "alpha1 =").replace(
        "&model", "&model ! " + "c" * (indent + 300), 1)
    path = tmp_path / "long.nml"
    path.write_text(padded)
    assert max(len(line) for line in padded.splitlines()) > 256
    resolved = []
    for source in (path, INPUTS / "fig2_n4.nml"):
        out = tmp_path / f"resolved-{source.stem}.nml"
        *_, ierr, errmsg = _core.resolve(str(source), str(out))
        assert ierr == 0, errmsg
        resolved.append(out.read_text())
    assert resolved[0] == resolved[1]
