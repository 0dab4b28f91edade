"""The tmafm executable: options, the output file, atomic writes, and agreement with Python."""

import re

import numpy as np
import pytest

import tmafm

from conftest import INPUTS, write_nml


def short_input(tmp_path, name="short.nml", **groups):
    groups.setdefault("solver", {}).setdefault("tau_end", 10.0)
    groups.setdefault("output", {}).setdefault("file", "short.dat")
    return write_nml(tmp_path / name, base=INPUTS / "fig2_n4.nml", **groups)


def read_header(path):
    return [line[2:] for line in path.read_text().splitlines() if line.startswith("# ")]


def test_help_and_version(run_exe):
    help_ = run_exe("--help")
    assert help_.returncode == 0 and "usage: tmafm INPUT.nml" in help_.stdout
    version = run_exe("--version")
    assert version.returncode == 0
    assert version.stdout.strip() == f"tmafm {tmafm.__version__}"


def test_usage_errors(run_exe):
    for args, text in ((("",), "no input file"), (("--bogus",), "unknown option"),
                       (("a.nml", "b.nml"), "more than one input"), (("x.nml", "-o"), "needs a file")):
        proc = run_exe(*[a for a in args if a])
        assert proc.returncode == 1, args
        assert text in proc.stderr and proc.stderr.count("\n") == 1


def test_run_writes_header_and_columns(tmp_path, run_exe):
    proc = run_exe(short_input(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert "short.dat" in proc.stdout
    out = tmp_path / "short.dat"
    header = read_header(out)
    assert header[0] == f"tmafm {tmafm.__version__}"
    text = "\n".join(header)
    for key in ("n_modes", "contact_law", "convention", "errata", "alpha1", "alpha6", "beta",
                "omega", "theta", "l_over_d", "g0_over_d", "delta_hat", "xi0", "a0", "adot0",
                "method", "dtau", "contact_refine", "tau_end", "blowup_limit", "file",
                "sample_dtau"):
        assert re.search(rf"^\s+{key} = ", text, re.M), key
    assert header[-1] == "columns: tau vt vtdot contact a_1 a_2 a_3 a_4 adot_1 adot_2 adot_3 adot_4"
    data = np.loadtxt(out)
    assert data.shape == (1001, 12)
    assert not list(tmp_path.glob("*.partial"))


def test_output_override(tmp_path, run_exe):
    proc = run_exe(short_input(tmp_path), "-o", "other.dat", "-q")
    assert proc.returncode == 0 and proc.stdout == ""
    assert (tmp_path / "other.dat").exists() and not (tmp_path / "short.dat").exists()


def test_header_reproduces_the_run(tmp_path, run_exe):
    """The header is a complete namelist: running it again gives the same numbers."""
    run_exe(short_input(tmp_path))
    echoed = "\n".join(read_header(tmp_path / "short.dat")[2:-2])
    (tmp_path / "again.nml").write_text(echoed.replace("'short.dat'", "'again.dat'") + "\n")
    proc = run_exe("again.nml")
    assert proc.returncode == 0, proc.stderr
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "short.dat"), np.loadtxt(tmp_path / "again.dat"))


@pytest.mark.parametrize("law", ["hertz", "dmt"])
def test_python_and_executable_agree(tmp_path, run_exe, law):
    path = short_input(tmp_path, model={"contact_law": law, "convention": "consistent"})
    assert run_exe(path, "-q").returncode == 0
    data = np.loadtxt(tmp_path / "short.dat")
    result = tmafm.run(path)
    # Printed with 17 significant digits: the numbers round-trip exactly.
    np.testing.assert_array_equal(data[:, 0], result.tau)
    np.testing.assert_array_equal(data[:, 1], result.vt)
    np.testing.assert_array_equal(data[:, 2], result.vtdot)
    np.testing.assert_array_equal(data[:, 3], result.contact)
    np.testing.assert_array_equal(data[:, 4:8], result.a)
    np.testing.assert_array_equal(data[:, 8:12], result.adot)
    assert result.resolved["model"]["convention"] == "consistent"
    assert result.resolved["model"]["errata"] == "E1,E2,E3,E4,E6,E7"


def test_fig2_n4_is_in_contact_a_large_share_of_each_period(tmp_path, run_exe):
    proc = run_exe(INPUTS / "fig2_n4.nml", "-q")
    assert proc.returncode == 0, proc.stderr
    data = np.loadtxt(tmp_path / "fig2_n4.dat")
    tau, vt = data[:, 0], data[:, 1]
    period = np.pi  # 2 pi / Omega
    shares = []
    for k in range(int(tau[-1] // period)):
        window = (tau >= k * period) & (tau < (k + 1) * period)
        shares.append(np.mean(vt[window] <= 0))
    shares = np.array(shares)
    assert np.all(shares[5:] > 0.15), shares
    assert np.all(shares[5:] < 0.6), shares
    assert vt.min() < 0 < vt.max()
