"""The .npz output: numpy reads it, it holds exactly the text output's numbers, and its
layout is the contract shared with tmafm.Result.save (docs/output-format.md)."""

import zipfile

import numpy as np
import pytest

import tmafm

from conftest import INPUTS, write_nml

MEMBERS = ["tau", "vt", "vtdot", "contact", "a", "adot", "switches", "counters", "resolved", "version"]


def run_both(tmp_path, run_exe, **groups):
    """The same input written as text and as .npz; returns (text path, npz path)."""
    groups.setdefault("solver", {}).setdefault("tau_end", 30.0)
    for fmt, name in (("text", "out.dat"), ("npy", "out.npz")):
        path = write_nml(tmp_path / f"{fmt}.nml", base=INPUTS / "fig2_n4.nml", **groups,
                         output={"format": fmt, "file": name})
        proc = run_exe(path, "-q")
        assert proc.returncode == 0, proc.stderr
    return tmp_path / "out.dat", tmp_path / "out.npz"


def header(path):
    return [line[2:] for line in path.read_text().splitlines() if line.startswith("# ")]


@pytest.mark.parametrize("groups", [
    {},
    {"model": {"n_modes": 2, "contact_law": "dmt", "convention": "consistent"},
     "initial": {"a0": [1e-3, 0.0], "adot0": [0.0, -2e-3]}, "solver": {"method": "dopri5"}},
])
def test_npz_holds_exactly_the_text_numbers(tmp_path, run_exe, groups):
    text, archive = run_both(tmp_path, run_exe, **groups)
    data = np.loadtxt(text)
    n_modes = (data.shape[1] - 4) // 2
    with np.load(archive) as npz:
        assert sorted(npz.files) == sorted(MEMBERS)
        np.testing.assert_array_equal(npz["tau"], data[:, 0])
        np.testing.assert_array_equal(npz["vt"], data[:, 1])
        np.testing.assert_array_equal(npz["vtdot"], data[:, 2])
        np.testing.assert_array_equal(npz["contact"], data[:, 3])
        np.testing.assert_array_equal(npz["a"], data[:, 4:4 + n_modes])
        np.testing.assert_array_equal(npz["adot"], data[:, 4 + n_modes:])
        lines = header(text)
        counters = dict(item.split(" = ") for item in lines[-2].removeprefix("counters: ").split(", "))
        assert npz["counters"].tolist() == [int(counters[key]) for key in (
            "steps", "contact_steps", "rejected_steps", "rhs_evaluations", "phase_switches")]
        assert npz["switches"].shape == (int(counters["phase_switches"]),)
        # resolved is the header's namelist without the '# ' prefixes; version its first line.
        resolved = npz["resolved"].item().decode()
        assert resolved.splitlines()[:-1] == [line.replace("'out.dat'", "'out.npz'").replace(
            "'text'", "'npy'") for line in lines[2:-2]][:-1]
        assert npz["version"].item().decode() == lines[0] == f"tmafm {tmafm.__version__}"


def test_npz_members_have_the_contract_types(tmp_path, run_exe):
    _, archive = run_both(tmp_path, run_exe, solver={"tau_end": 10.0})
    with zipfile.ZipFile(archive) as z:
        assert z.testzip() is None  # every member's CRC-32 checks
        assert [info.filename for info in z.infolist()] == [f"{m}.npy" for m in MEMBERS]
        assert all(info.compress_type == zipfile.ZIP_STORED for info in z.infolist())
    with np.load(archive) as npz:
        n = 1001
        for key in ("tau", "vt", "vtdot"):
            assert npz[key].dtype == np.dtype("<f8") and npz[key].shape == (n,)
        assert npz["contact"].dtype == np.dtype("|i1") and set(np.unique(npz["contact"])) <= {0, 1}
        for key in ("a", "adot"):
            assert npz[key].dtype == np.dtype("<f8") and npz[key].shape == (n, 4)
            assert npz[key].flags.f_contiguous
        assert npz["switches"].dtype == np.dtype("<f8") and np.all(np.diff(npz["switches"]) > 0)
        assert npz["counters"].dtype == np.dtype("<i8") and npz["counters"].shape == (5,)
        for key in ("resolved", "version"):
            assert npz[key].dtype.kind == "S" and npz[key].shape == ()


def test_npz_agrees_with_python(tmp_path, run_exe):
    _, archive = run_both(tmp_path, run_exe, solver={"tau_end": 10.0})
    result = tmafm.run(tmp_path / "npy.nml")
    with np.load(archive) as npz:
        np.testing.assert_array_equal(npz["a"], result.a)
        np.testing.assert_array_equal(npz["adot"], result.adot)
        np.testing.assert_array_equal(npz["switches"], result.switches)


@pytest.mark.parametrize("fmt, name", [("text", "out.npz"), ("npy", "out.dat"), ("npy", "out")])
def test_format_and_name_must_agree(tmp_path, run_exe, fmt, name):
    path = write_nml(tmp_path / "in.nml", base=INPUTS / "fig2_n4.nml",
                     solver={"tau_end": 1.0}, output={"format": fmt, "file": "x.dat"})
    proc = run_exe(path, "-o", name)
    assert proc.returncode == 2
    assert proc.stderr.count("tmafm: error:") == 1 and ".npz" in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.nml"]


def es25(value: float) -> str:
    """Fortran's es25.16e3 for a double, from Python's correctly rounded %.16E."""
    mantissa, exponent = f"{value:.16E}".split("E")
    return f"{mantissa}E{exponent[0]}{int(exponent[1:]):03d}".rjust(25)


def test_text_digits_are_correctly_rounded(tmp_path, run_exe):
    """Every real in the text is the correctly rounded 17-digit es25.16e3 of its double."""
    path = write_nml(tmp_path / "in.nml", base=INPUTS / "fig2_n4.nml",
                     initial={"a0": [1e-200, -3.3e-17, 0.0, 2.5e-3], "adot0": [-0.0, 7e-250, 1.0, -1e-5]},
                     solver={"tau_end": 20.0, "method": "dopri5"}, output={"file": "out.dat"})
    assert run_exe(path, "-q").returncode == 0
    rows = [line for line in (tmp_path / "out.dat").read_text().splitlines() if not line.startswith("#")]
    checked = 0
    for row in rows:
        fields = [row[i:i + 25] for i in range(0, 75, 25)] + [row[i:i + 25] for i in range(78, len(row), 25)]
        for field in fields:
            assert field == es25(float(field)), field
            checked += 1
    assert checked == len(rows) * 11
    assert rows[0][78:178] == es25(1e-200) + es25(-3.3e-17) + es25(0.0) + es25(2.5e-3)
