"""Every validation path: a one-line error naming the key and the value, the documented exit
code from the executable, the typed exception from Python, no traceback, no file left behind."""

import pytest

import tmafm

from conftest import write_nml

INPUT_ERROR, FILE_ERROR = 2, 3

CASES = {
    # name: (text of the namelist file, words the message must contain, exit code)
    "unknown_key": ("&model n_modez = 3 /\n", ["&model", "n_modez"], INPUT_ERROR),
    "unknown_group": ("&modle n_modes = 3 /\n", ["&modle", "unknown namelist group"], INPUT_ERROR),
    "n_modes_too_many": ("&model n_modes = 31 /\n", ["n_modes", "31", "1..30"], INPUT_ERROR),
    "n_modes_negative": ("&model n_modes = -1 /\n", ["n_modes", "-1", "1..30"], INPUT_ERROR),
    "mode_tol_zero": ("&model n_modes = 0, mode_tol = 0 /\n", ["mode_tol", "> 0.0E+000"], INPUT_ERROR),
    "rtol_too_small": ("&solver rtol = 1e-20 /\n", ["rtol = 1e-20", ">= 1.0E-015"], INPUT_ERROR),
    "atol_negative": ("&solver atol = -1 /\n", ["atol = -1:"], INPUT_ERROR),
    "wrong_type_integer": ("&model n_modes = 'four' /\n", ["&model n_modes = 'four'", "integer"], INPUT_ERROR),
    "wrong_type_real": ("&scene alpha3 = 'x' /\n", ["&scene alpha3 = 'x'", "number"], INPUT_ERROR),
    "negative_damping": ("&scene alpha3 = -0.4 /\n", ["alpha3 = -0.4:", ">= 0"], INPUT_ERROR),
    "tilt_too_large": ("&scene theta = 2.0 /\n", ["theta = 2.0:", "< 1.57"], INPUT_ERROR),
    "xi0_outside_beam": ("&scene xi0 = 1.5 /\n", ["xi0 = 1.5:", "<= 1.0E+000"], INPUT_ERROR),
    "beta_zero": ("&scene beta = 0.0 /\n", ["beta", "> 0.0E+000"], INPUT_ERROR),
    "nan_value": ("&scene alpha2 = NaN /\n", ["alpha2 = NaN:", "finite"], INPUT_ERROR),
    "bad_law": ("&model contact_law = 'mdt' /\n", ["contact_law", "'mdt'", "'hertz', 'dmt', 'dmt_vdw' or 'jkr'"],
                INPUT_ERROR),
    "bad_convention": ("&model convention = 'mine' /\n", ["convention", "'mine'"], INPUT_ERROR),
    "bad_errata": ("&model errata = 'E5' /\n", ["errata", "'E5'"], INPUT_ERROR),
    "bad_method": ("&solver method = 'euler' /\n", ["method", "'euler'", "rk4_paper", "flight_exact"], INPUT_ERROR),
    "negative_dtau": ("&solver dtau = -1e-3 /\n", ["dtau = -1e-3:"], INPUT_ERROR),
    "refine_zero": ("&solver contact_refine = 0 /\n", ["contact_refine", "0"], INPUT_ERROR),
    "tau_end_zero": ("&solver tau_end = 0 /\n", ["tau_end = 0:"], INPUT_ERROR),
    "sample_above_end": ("&solver tau_end = 1.0 /\n&output sample_dtau = 2.0 /\n",
                         ["sample_dtau = 2.0:"], INPUT_ERROR),
    "empty_file_name": ("&output file = '' /\n", ["file", "must name a file"], INPUT_ERROR),
    "a0_too_short": ("&model n_modes = 3 /\n&initial a0 = 1e-4, 0 /\n",
                     ["a0", "2 values", "n_modes = 3"], INPUT_ERROR),
    "a0_too_long": ("&model n_modes = 2 /\n&initial a0 = 1e-4, 0, 0 /\n",
                    ["a0", "3 values", "n_modes = 2"], INPUT_ERROR),
    "adot0_mismatch": ("&model n_modes = 2 /\n&initial adot0 = 1e-4 /\n",
                       ["adot0", "1 values", "n_modes = 2"], INPUT_ERROR),
    "scene_and_physical": ("&scene alpha1 = 0.05 /\n&physical length = 3e-4 /\n",
                           ["&scene", "&physical"], INPUT_ERROR),
    "physical_negative_length": ("&physical length = -1 /\n", ["length = -1:"], INPUT_ERROR),
    "repeated_group": ("&model n_modes = 2 /\n&model n_modes = 3 /\n", ["&model", "twice"], INPUT_ERROR),
}


def write_case(tmp_path, text):
    path = tmp_path / "bad.nml"
    path.write_text(text + "&output file = 'bad.dat' /\n" if "&output" not in text else text)
    return path


@pytest.mark.parametrize("name", sorted(CASES))
def test_executable_reports_bad_input(tmp_path, run_exe, name):
    text, words, code = CASES[name]
    proc = run_exe(write_case(tmp_path, text))
    assert proc.returncode == code, proc.stderr
    assert proc.stderr.startswith("tmafm: error: ") and proc.stderr.count("\n") == 1, proc.stderr
    for word in words:
        assert word in proc.stderr, (word, proc.stderr)
    assert "Backtrace" not in proc.stderr and "Error termination" not in proc.stderr
    assert proc.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.nml"]


@pytest.mark.parametrize("name", sorted(CASES))
def test_python_raises_typed_error(tmp_path, name):
    text, words, _ = CASES[name]
    with pytest.raises(tmafm.InputError) as info:
        tmafm.run(write_case(tmp_path, text))
    assert isinstance(info.value, ValueError)
    for word in words:
        assert word in str(info.value), (word, str(info.value))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.nml"]


def test_missing_file(tmp_path, run_exe):
    proc = run_exe("nowhere.nml")
    assert proc.returncode == FILE_ERROR
    assert "nowhere.nml" in proc.stderr and "not found" in proc.stderr
    with pytest.raises(tmafm.InputFileError) as info:
        tmafm.run(tmp_path / "nowhere.nml")
    assert isinstance(info.value, FileNotFoundError)


def test_unwritable_output(tmp_path, run_exe):
    path = write_nml(tmp_path / "x.nml", solver={"tau_end": 0.1},
                     output={"file": str(tmp_path / "no_such_dir" / "x.dat")})
    proc = run_exe(path)
    assert proc.returncode == FILE_ERROR and "cannot write output file" in proc.stderr


def test_python_dict_errors_name_the_key_not_a_temporary_file():
    with pytest.raises(tmafm.InputError, match=r"^<dict input>: &scene alpha3 = -1\.0: must be finite"):
        tmafm.run({"scene": {"alpha3": -1.0}})


def test_python_rejects_non_mapping_groups():
    with pytest.raises(tmafm.InputError):
        tmafm.run({"model": 3})
    with pytest.raises(TypeError):
        tmafm.run(42)
