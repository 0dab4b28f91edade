"""Physical inputs to dimensionless groups (docs/model.md §2, paper Eq. (12), (24))."""

import math

import pytest

import tmafm

from conftest import INPUTS, write_nml


def significant(x, digits=4):
    return float(f"{x:.{digits - 1}e}")


def test_section3_inputs_reproduce_printed_groups():
    _, scene = tmafm.resolve(INPUTS / "physical_polystyrene.nml")
    assert significant(scene["alpha5"]) == 6.767e-5  # printed 6.7665e-5
    assert significant(scene["alpha6"]) == 0.7413
    assert significant(scene["beta"]) == 1.128e-4
    assert scene["l_over_d"] == pytest.approx(60.0, rel=1e-14)
    assert scene["g0_over_d"] == pytest.approx(1.0, rel=1e-14)


def test_physical_file_is_the_fig2_scene():
    _, scene = tmafm.resolve(INPUTS / "physical_polystyrene.nml")
    expected = {"alpha1": 0.05, "alpha2": 5e-4, "alpha3": 0.4, "alpha4": 0.4, "omega": 2.0,
                "theta": math.pi / 12, "xi0": 1.0, "delta_hat": 0.0}
    for key, value in expected.items():
        assert scene[key] == pytest.approx(value, rel=1e-9, abs=1e-15), key


def test_physical_run_matches_dimensionless_run():
    physical = tmafm.run(INPUTS / "physical_polystyrene.nml", solver={"tau_end": 5.0})
    # physical_polystyrene names convention 'consistent'; fig2_n4 names 'paper'.
    scene = tmafm.run(INPUTS / "fig2_n4.nml", solver={"tau_end": 5.0},
                      model={"convention": "consistent", "errata": "convention"})
    # The printed groups are rounded to 4-5 digits; the trajectories agree to that level.
    assert abs(physical.vt - scene.vt).max() < 1e-3 * abs(scene.vt).max()


def test_inconsistent_geometry_is_rejected(tmp_path):
    path = write_nml(tmp_path / "p.nml", base=INPUTS / "physical_polystyrene.nml",
                     physical={"static_offset": 1e-6})
    with pytest.raises(tmafm.InputError, match="gap"):
        tmafm.resolve(path)
