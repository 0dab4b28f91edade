"""tmafm.analysis: period classification, steady-state detection, energy bookkeeping, and the
figure command."""

import math

import f90nml
import numpy as np
import pytest

import tmafm
from tmafm import analysis

from conftest import INPUTS

OMEGA = 2.0
T = 2 * math.pi / OMEGA


def synthetic_result(signal, periods, per_period=200, rtol=1e-9):
    """A Result whose single 'mode' follows signal(tau), sampled per_period times a period."""
    tau = np.arange(-1, periods * per_period + 2) * (T / per_period)
    x = signal(tau)
    xdot = np.gradient(x, tau)
    tau, x, xdot = tau[1:-1], x[1:-1], xdot[1:-1]   # central differences everywhere
    resolved = f90nml.Namelist({"solver": {"method": "flight_exact", "rtol": rtol, "dtau": 2e-3}})
    zeros = np.zeros_like(tau)
    return tmafm.Result(tau=tau, vt=x, vtdot=xdot, contact=zeros.astype(np.int8), a=x[:, None],
                        adot=xdot[:, None], resolved=resolved, scene={"omega": OMEGA})


def test_period_one_signal():
    r = synthetic_result(lambda t: np.sin(OMEGA * t) + 0.4 * np.sin(2 * OMEGA * t + 0.3), 60)
    assert analysis.classify_period(r)["kind"] == "period-1"


def test_period_three_signal():
    r = synthetic_result(lambda t: np.sin(OMEGA * t) + 0.3 * np.cos(OMEGA * t / 3 + 0.7), 60)
    result = analysis.classify_period(r)
    assert result["kind"] == "period-3"
    assert result["distances"][1] > 1e-2 and result["distances"][3] < 1e-9


def test_quasi_periodic_signal_is_non_periodic():
    r = synthetic_result(lambda t: np.sin(OMEGA * t) + 0.3 * np.sin(math.sqrt(2) * OMEGA * t), 60)
    result = analysis.classify_period(r)
    assert result["kind"] == "non-periodic"
    assert min(result["distances"].values()) > 1e-3


def test_steady_state_not_declared_during_a_decaying_transient():
    rate = 0.05
    r = synthetic_result(lambda t: np.sin(OMEGA * t) + 0.5 * np.exp(-rate * t) * np.sin(3.3 * t), 250)
    tol = 1e-6
    state = analysis.steady_state(r, tol=tol, max_period=1)
    assert state["reached"] and state["period"] == 1
    # From the declared time on, the section-to-section change of the transient must be
    # below tol (relative to the motion's range, 2 here); before it, it is not.
    scale = analysis.state_scale(r, r.tau[-1] / 2)[0]
    k = np.arange(0, 251)
    change = 0.5 * np.exp(-rate * k * T) * np.abs(
        np.sin(3.3 * k * T) - np.exp(rate * T) * np.sin(3.3 * (k - 1) * T)) / scale
    declared = int(round(state["tau"] / T))
    assert np.all(change[declared + 1:] <= tol * 2)
    # Not declared early: the transient's envelope at the declared time is below ~ tol.
    envelope = 0.5 * np.exp(-rate * state["tau"]) * (1 + np.exp(rate * T)) / scale
    assert envelope < 50 * tol
    assert state["tau"] > 150  # the envelope only falls below 1e-6 after tau ~ 200


def test_short_transient_is_not_mistaken_for_steady():
    r = synthetic_result(lambda t: np.sin(OMEGA * t) + 0.5 * np.exp(-0.05 * t) * np.sin(3.3 * t), 40)
    assert not analysis.steady_state(r, tol=1e-6, max_period=4)["reached"]


def test_poincare_needs_a_dividing_sample_interval():
    r = tmafm.run(INPUTS / "fig2_n4.nml", solver={"tau_end": 5.0})  # sample_dtau = 0.01
    with pytest.raises(ValueError, match="does not divide"):
        analysis.poincare_sections(r)


@pytest.fixture(scope="module")
def fine_fig2():
    return {m: tmafm.run(INPUTS / "fig2_n4.nml",
                         solver={"method": "flight_exact", "tau_end": 20 * T, "rtol": 1e-11, "atol": 1e-17},
                         output={"sample_dtau": analysis.sample_dtau_for(OMEGA, m)})
            for m in (2000, 4000)}


def test_energy_bookkeeping_closes(fine_fig2):
    """dE = sum of the works of drive, beam damping, contact damping and contact forces.
    The works are integrated from samples (trapezoid), so the residual must shrink like
    sample_dtau^2, and be small against each work."""
    residuals = {}
    for m, r in fine_fig2.items():
        balance = analysis.energy_balance(r, 3 * T, 13 * T)
        total = max(abs(w) for w in balance["work"].values())
        assert balance["work"]["contact_normal"] != 0 and balance["work"]["contact_damping"] < 0
        assert balance["work"]["beam_damping"] < 0
        residuals[m] = abs(balance["residual"]) / total
    assert residuals[4000] < 1e-5
    assert residuals[2000] / residuals[4000] > 3.0  # at least second order in the sample interval


def test_steady_period_has_no_net_energy_change(fine_fig2):
    r = fine_fig2[4000]
    balance = analysis.energy_balance(r, 18 * T, 19 * T)
    assert abs(balance["energy_change"]) < 1e-6 * max(abs(w) for w in balance["work"].values())
    rows = analysis.per_period(r, since=15 * T)
    assert all(row["dissipated"] > 0 and 0 < row["contact_fraction"] < 1 for row in rows)
    assert all(row["contacts"] == 2 for row in rows)


def test_lockin_and_harmonics_of_a_known_signal():
    r = synthetic_result(lambda t: 0.1 + 2.0 * np.sin(OMEGA * t + 0.5) + 0.25 * np.cos(3 * OMEGA * t), 10)
    lock = analysis.lockin(r)
    assert lock["amplitude"] == pytest.approx(2.0, rel=1e-9)
    assert lock["phase"] == pytest.approx(0.5, abs=1e-9)
    assert lock["mean"] == pytest.approx(0.1, abs=1e-12)
    spectrum = analysis.harmonics(r, k_max=5)
    np.testing.assert_allclose(spectrum, [0.1, 2.0, 0.0, 0.25, 0.0, 0.0], atol=1e-9)


def test_modal_amplitude_definitions():
    r = synthetic_result(lambda t: 1.0 + 0.5 * np.sin(OMEGA * t), 4, per_period=2000)
    r.contact[r.vt > 1.2] = 1
    amps = analysis.modal_amplitudes(r)
    assert amps["contact"]["max_abs"][0] == pytest.approx(1.5, rel=1e-6)
    assert amps["contact"]["half_peak_to_peak"][0] == pytest.approx(0.15, abs=0.01)
    assert amps["free"]["max_abs"][0] == pytest.approx(1.2, abs=0.01)


def test_figure_command_writes_every_figure(tmp_path):
    from tmafm import figures
    summary = figures.make_figures(INPUTS, tmp_path, periods=20, basin_points=2, progress=lambda *_: None)
    pngs = sorted(tmp_path.glob("*.png"))
    expected = {f"fig2_{m}_{c}.png" for m in figures.METHODS for c in ("paper", "consistent")}
    expected |= {f"fig{k}_{m}_paper.png" for m in figures.METHODS for k in (3, 4, 5, 7)}
    expected |= {f"fig6_{m}_{c}.png" for m in figures.METHODS for c in ("paper", "consistent")}
    expected |= {"basin_fig4_5.png"}
    assert {p.name for p in pngs} == expected
    assert all(p.stat().st_size > 10_000 for p in pngs)
    assert (tmp_path / "summary.json").stat().st_size > 0
    assert summary["cases"]["fig6/flight_exact/paper"]["contact_fraction"] == 1.0
