"""Sweep files (python -m tmafm.sweeps FILE, docs/sweeps.md) are read by tmafm's strict reader,
the one the executable uses, not by f90nml: f90nml let a repeated key win silently, read
`values(3) = x` as [x], kept an empty value as None, skipped text outside the group, stopped
at a NUL byte without a word, took an unquoted word for a string, and a repeated &sweep group
raised a raw TypeError."""

import pytest

import tmafm
from tmafm import sweeps

from conftest import INPUTS

GOOD = "kind = 'grid', base = 'bistable_n2.nml', key = 'scene.delta_hat', "


def _file(tmp_path, text):
    (tmp_path / "bistable_n2.nml").write_bytes((INPUTS / "sweeps" / "bistable_n2.nml").read_bytes())
    path = tmp_path / "sweep.nml"
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return path


BAD = {
    "repeated_group": (f"&sweep {GOOD} values = 0.0 /\n&sweep kind = 'grid' /\n", "twice"),
    "repeated_key": (f"&sweep {GOOD} start = 0, stop = 1e-3, count = 2, count = 3 /\n", "count"),
    "unquoted_word": ("&sweep kind = grid, base = 'bistable_n2.nml', key = 'scene.delta_hat', "
                      "values = 0.0 /\n", "quoted"),
    "empty_value": (f"&sweep {GOOD} values = 0.0,,1e-3 /\n", "empty value"),
    "text_outside": (f"hello\n&sweep {GOOD} values = 0.0 /\n", "outside a group"),
    "indexed_key": (f"&sweep {GOOD} values(3) = 1e-3 /\n", "values(3)"),
    "string_values": (f"&sweep {GOOD} values = 'a', 'b' /\n", "number"),
    "logical_values": (f"&sweep {GOOD} values = .true. /\n", "number"),
    "nul_byte": (f"&sweep {GOOD} values = 0.0 /\n\0 junk".encode(), "NUL"),
    "two_values_for_one": (f"&sweep {GOOD} start = 0 1, stop = 1e-3, count = 2 /\n", "one value"),
    "logical_for_a_real": (f"&sweep {GOOD} start = .true., stop = 1e-3, count = 2 /\n", "float"),
    "not_a_value": (f"&sweep {GOOD} values = 5.0_8 /\n", "values"),
}


@pytest.mark.parametrize("text, words", BAD.values(), ids=BAD.keys())
def test_a_bad_sweep_file_is_one_typed_error(tmp_path, text, words):
    with pytest.raises(tmafm.InputError) as info:
        sweeps.read_sweep_file(_file(tmp_path, text))
    message = str(info.value)
    assert "\n" not in message and words in message, message


def test_a_good_sweep_file_reads_every_kind_of_value(tmp_path):
    path = _file(tmp_path, "! a comment\n&SWEEP\n  kind = 'approach', base = 'bistable_n2.nml'\n"
                           "  start = 8.0d-3, stop = 0, count = 3\n"
                           "  curve_key = 'model.n_modes', curve_values = 2, 3\n"
                           "  reverse = .false., max_periods = 20, observables = 'contact', 'amplitude'\n"
                           "  values = 2*1e-3, 0.5e-3\n/\n")
    spec = sweeps.read_sweep_file(path)
    assert spec["kind"] == "approach" and spec["start"] == 8e-3 and spec["stop"] == 0.0
    assert spec["count"] == 3 and spec["reverse"] is False and spec["max_periods"] == 20
    assert spec["curve_values"] == [2, 3] and all(isinstance(v, int) for v in spec["curve_values"])
    assert spec["observables"] == ["contact", "amplitude"]
    assert spec["values"] == [1e-3, 1e-3, 0.5e-3]
    assert spec["base"] == str(tmp_path / "bistable_n2.nml")


@pytest.mark.parametrize("name", ["approach", "basin", "bifurcation", "frequency"])
def test_the_shipped_sweep_files_still_read(name):
    spec = sweeps.read_sweep_file(INPUTS / "sweeps" / f"{name}.nml")
    assert spec["kind"] in ("approach", "basin", "bifurcation", "frequency")


@pytest.mark.parametrize("args, words", [
    (["-o", "sweep.nml"], "is the input"),
    (["-o", "bistable_n2.nml"], "is the input"),
    (["--plot", "sweep.nml"], "is the input"),
    (["-o", "out.png"], "both"),
], ids=["output_is_the_sweep_file", "output_is_the_base", "plot_is_the_sweep_file", "plot_is_the_output"])
def test_the_sweep_command_never_replaces_its_inputs(tmp_path, args, words):
    """`python -m tmafm.sweeps sweep.nml -o sweep.nml` ran the sweep and replaced the sweep file
    with the NetCDF file (and -o out.png wrote the plot over the NetCDF file)."""
    import subprocess
    import sys

    _file(tmp_path, f"&sweep {GOOD} values = 0.0, max_periods = 2 /\n")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    proc = subprocess.run([sys.executable, "-m", "tmafm.sweeps", "sweep.nml", *args, "--workers", "1"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, (proc.returncode, proc.stderr[-500:])
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and words in lines[0], proc.stderr
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
