"""The multifrequency (bimodal) drive: a base driven by two commensurate tones (tmafm_drive,
docs/model.md §15).

Oracles: the one-tone runs themselves (a second tone of zero amplitude must leave every output
bit as it was); the linear response of the free beam, computed here with numpy from the model's
M, C, K (the core's matrices) and the documented drive force of each tone, with q and m from
the documented closed forms (q_i = 2 sigma_i/beta_i, phi_i(1) = 2 (-1)^(i+1)); dop853 at a tight
tolerance for a two-tone run with contacts; the energy balance of a free steady period; and the
executable's and Python's error contract for bad drive keys.
"""

import math
import subprocess

import numpy as np
import pytest
from scipy.optimize import brentq

import tmafm

from conftest import REPO, write_nml
from testcore import core

OMEGA, OMEGA_2 = 2.0, 12.5        # 12.5/2 = 25/4: the common period is 4 periods of tone 1
COMMON_PERIOD = 4 * 2 * math.pi / OMEGA
TONES = {"alpha2": 5e-4, "omega": OMEGA, "drive_phase": 0.3,
         "alpha2_2": 2e-4, "omega_2": OMEGA_2, "drive_phase_2": -1.1}
FREE = {**TONES, "delta_hat": 0.5}  # the tip never reaches the sample
N = 3
TAPPING = str(REPO / "inputs" / "bimodal" / "tapping.nml")


def _roots(n):
    """beta_j of 1 + cos(beta) cosh(beta) = 0, by bracketing (independent of the core's Newton)."""
    f = lambda b: math.cos(b) + 1 / math.cosh(b)  # noqa: E731 (same roots, no overflow)
    return np.array([brentq(f, (j - 0.5) * math.pi - 0.5, (j - 0.5) * math.pi + 0.5, xtol=1e-15)
                     for j in range(1, n + 1)])


def _linear_response(path, scene):
    """Per tone k: the complex modal amplitudes a_k (a = Re(a_k e^{i Omega_k tau})) and the
    complex amplitude c_k of V_T against the tone's drive, V_T's tone-k part = Re(c_k e^{i psi_k}),
    psi_k = Omega_k tau + phi_k.  M, C, K from the core; the drive force from docs/model.md §15."""
    zero = np.zeros(N)
    m, c, k, _, _, ierr, msg = core.model_terms(str(path), 0.0, zero, zero, False)
    assert ierr == 0, msg
    beta = _roots(N)
    sigma = (np.cosh(beta) + np.cos(beta)) / (np.sinh(beta) + np.sin(beta))
    q = 2 * sigma / beta
    tip = np.array([2.0 * (-1) ** j for j in range(N)])      # phi_j(1) = 2 (-1)^(j+1); tip mass there too
    out = []
    for amp, omega, phase in ((scene["alpha2"], scene["omega"], scene["drive_phase"]),
                              (scene["alpha2_2"], scene["omega_2"], scene["drive_phase_2"])):
        # F = amp Omega^2 (alpha1 m + q) sin(psi) - amp alpha3 Omega q cos(psi) = Re(F_hat e^{i Omega tau}).
        f_hat = np.exp(1j * phase) * (-1j * amp * omega**2 * (0.05 * tip + q) - amp * 0.4 * omega * q)
        a_hat = np.linalg.solve(k - omega**2 * m + 1j * omega * c, f_hat)
        # V_T's part: p.a + amp sin(psi) = Re((p.a_hat e^{-i phi} - i amp) e^{i psi}).
        out.append((a_hat, omega, tip @ a_hat * np.exp(-1j * phase) - 1j * amp))
    return out


def _state(response, tau):
    a = sum((a_hat * np.exp(1j * omega * tau)).real for a_hat, omega, _ in response)
    adot = sum((1j * omega * a_hat * np.exp(1j * omega * tau)).real for a_hat, omega, _ in response)
    return a, adot


@pytest.fixture(scope="module")
def free_scene(tmp_path_factory):
    path = write_nml(tmp_path_factory.mktemp("bimodal") / "free.nml",
                     model={"n_modes": N, "convention": "paper"}, scene=FREE)
    return path, _linear_response(path, FREE)


def test_a_silent_second_tone_changes_no_bit():
    """alpha2_2 = 0 is no tone, whatever omega_2 says (even incommensurate): every array of a
    fixed-step run and of an exact-flight run is today's, bit for bit, and so is the resolved
    input.  Fails if the zero tone moved the period, the phase or any term."""
    for solver in ({"method": "rk4_paper", "tau_end": 6.0}, {"method": "flight_exact", "tau_end": 20.0}):
        base = tmafm.run("fig2_n2", solver=solver, output={"sample_dtau": 0.05})
        silent = tmafm.run("fig2_n2", solver=solver, output={"sample_dtau": 0.05},
                           scene={"alpha2_2": 0.0, "omega_2": 7.3})
        for name in ("tau", "vt", "vtdot", "a", "adot", "contact"):
            assert np.array_equal(getattr(base, name), getattr(silent, name)), (solver, name)
    text = tmafm.Config("fig2_n2").text
    assert "alpha2_2" not in text and "drive_phase" not in text


def test_free_two_tone_run_is_the_linear_response(free_scene):
    """A free run from the steady state of the linear response stays on it: each mode's
    displacement and velocity (flight_exact, dense samples) to 1e-9 of the mode's amplitude."""
    path, response = free_scene
    a0, adot0 = _state(response, 0.0)
    run = tmafm.run(str(path), initial={"a0": list(a0), "adot0": list(adot0)},
                    solver={"method": "flight_exact", "rtol": 1e-12, "atol": 1e-20, "tau_end": 30.0},
                    output={"sample_dtau": 0.05})
    expected = np.array([_state(response, t)[0] for t in run.tau])
    expected_rate = np.array([_state(response, t)[1] for t in run.tau])
    size = np.max(np.abs(expected), axis=0)
    assert np.max(np.abs(run.a - expected) / size) < 1e-9
    assert np.max(np.abs(run.adot - expected_rate) / np.max(np.abs(expected_rate), axis=0)) < 1e-9
    vt = np.array([sum((c * np.exp(1j * (w * t + ph))).real for (_, w, c), ph in
                       zip(response, (FREE["drive_phase"], FREE["drive_phase_2"])))
                   for t in run.tau]) + FREE["delta_hat"]
    assert np.max(np.abs(run.vt - vt)) < 1e-9 * np.max(np.abs(vt - FREE["delta_hat"]))


def test_each_tones_lock_in_is_the_linear_response(free_scene):
    """Observed over the common period (4 periods of tone 1), V_T's lock-in at each tone is the
    closed form's amplitude |c_k| (relative 1e-9) and phase atan2(Re c_k, -Im c_k) (1e-9 rad);
    the Poincare section at the common period returns to the start (it would not at tone 1's
    period: 25/4 turns of tone 2), and the drive work per period equals the beam's dissipation."""
    path, response = free_scene
    a0, adot0 = _state(response, 0.0)
    obs = tmafm.observe(str(path), max_periods=2, stop_at_steady=False,
                        initial={"a0": list(a0), "adot0": list(adot0)},
                        solver={"method": "dop853", "rtol": 1e-13, "atol": 1e-20})
    for k, (_, _, c) in enumerate(response, start=1):
        amplitude = obs.per_period[f"tone{k}_amplitude"]
        phase = np.radians(obs.per_period[f"tone{k}_phase"])
        assert np.max(np.abs(amplitude / abs(c) - 1)) < 1e-9, k
        assert np.max(np.abs(np.angle(np.exp(1j * (phase - math.atan2(c.real, -c.imag)))))) < 1e-9, k
    start = np.concatenate([a0, adot0])
    assert np.max(np.abs(obs.poincare[1:] - start)) < 1e-9 * np.max(np.abs(start))
    a_quarter, _ = _state(response, COMMON_PERIOD / 4)
    assert np.max(np.abs(a_quarter - a0)) > 1e-3 * np.max(np.abs(a0))   # not a period
    work, lost = obs.per_period["drive_work"], obs.per_period["dissipated_energy"]
    assert np.max(np.abs(work - lost)) < 1e-9 * np.max(np.abs(work))


def test_two_tones_with_contacts_flight_exact_agrees_with_dop853(tmp_path):
    """A tapping run driven by two tones: flight_exact (exact flights, dop853 in contact) and
    dop853 throughout agree to within their tolerances over several contacts."""
    path = write_nml(tmp_path / "tap.nml", model={"n_modes": 2, "convention": "consistent"},
                     scene={"alpha2_2": 1e-4, "omega_2": OMEGA_2, "drive_phase_2": 0.4})
    runs = {}
    for method in ("flight_exact", "dop853"):
        runs[method] = tmafm.run(str(path), solver={"method": method, "rtol": 1e-12, "atol": 1e-18,
                                                     "tau_end": 12.0}, output={"sample_dtau": 0.02})
    flight, ref = runs["flight_exact"], runs["dop853"]
    assert np.count_nonzero(np.diff(ref.contact) == 1) >= 3          # the tip taps
    scale = np.max(np.abs(ref.a), axis=0)
    assert np.max(np.abs(flight.a - ref.a) / scale) < 1e-7
    assert np.max(np.abs(flight.vt - ref.vt)) < 1e-7 * np.max(np.abs(ref.vt))
    assert np.array_equal(flight.contact, ref.contact)


@pytest.mark.parametrize("group, text, words", [
    ("scene", "alpha2_2 = -1e-4", ["&scene alpha2_2", "-1e-4"]),
    ("scene", "alpha2_2 = 1e-4, omega_2 = 0", ["&scene omega_2 = 0", "frequency > 0"]),
    ("scene", "alpha2_2 = 1e-4, omega_2 = 6.283185307179586",
     ["&scene omega_2 = 6.283185307179586", "not commensurate", "nearest 201/64: omega_2 = 6.28125"]),
    ("scene", "alpha2_2 = 1e-4, omega_2 = 12.5, omega = 0", ["&scene omega = 0", "> 0"]),
    ("scene", "drive_phase_2 = 7", ["&scene drive_phase_2", "7"]),
    ("physical", "drive_amplitude_2 = 1e-10, drive_angular_frequency_2 = 1e5",
     ["&physical drive_angular_frequency_2 = 1e5", "not commensurate", "nearest 16/23", "(line 1)"]),
    ("physical", "drive_amplitude_2 = -1e-10", ["&physical drive_amplitude_2", "-1e-10"]),
])
def test_bad_drive_keys_give_one_line_errors(exe, tmp_path, group, text, words):
    """Negative amplitude, zero frequency, incommensurate tones, a phase out of range: exit 2,
    one line naming the key and its value; the same message as tmafm.InputError in Python."""
    nml = tmp_path / "bad.nml"
    nml.write_text(f"&{group} {text} /\n&solver tau_end = 1 /\n")
    done = subprocess.run([exe, "-q", str(nml)], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tmafm: error:"), done.stderr
    for word in words:
        assert word in lines[0], (word, lines[0])
    with pytest.raises(tmafm.InputError) as caught:
        tmafm.run(str(nml))
    assert "\n" not in str(caught.value) and words[0] in str(caught.value)


def test_two_tone_observables_of_flight_exact_agree_with_dop853():
    """flight_exact's observables of a two-tone tapping run (closed forms over its flights, one
    harmonic per tone) against dop853's Gauss-Legendre sums on its dense output at a tight
    tolerance: every column, each tone's lock-in included, per period."""
    runs = {}
    for method, rtol in (("flight_exact", 1e-11), ("dop853", 1e-12)):
        runs[method] = tmafm.observe(TAPPING, max_periods=4, stop_at_steady=False,
                                     solver={"method": method, "rtol": rtol, "atol": 1e-20})
    got, ref = runs["flight_exact"].per_period, runs["dop853"].per_period
    assert np.all(ref["contacts_per_period"][1:] == 3)     # from rest: taps from period 2 on
    for name, values in ref.items():
        a, b = np.asarray(got[name], float), np.asarray(values, float)
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        # The limits of tests/test_observe_exact.py (measured: 3e-10 degrees, 3e-12 of the scale).
        if "phase" in name:
            assert np.nanmax(np.abs(a - b)) < 1e-7, name                      # degrees
        else:
            scale = np.nanmax(np.abs(b)) or 1.0
            assert np.nanmax(np.abs(a - b)) <= 1e-9 * scale, (name, np.nanmax(np.abs(a - b)) / scale)


def test_commensurate_ratio_sets_the_common_period():
    """omega_2/omega = 25/4 gives a common period of 4 tone-1 periods: an observed run counts
    periods of that length (its last Poincare point is at 2 common periods)."""
    obs = tmafm.observe("fig2_n2", max_periods=2, stop_at_steady=False, scene=TONES,
                        solver={"method": "dop853", "rtol": 1e-10})
    run = tmafm.run("fig2_n2", scene=TONES, solver={"method": "dop853", "rtol": 1e-10,
                                                   "tau_end": 2 * COMMON_PERIOD},
                    output={"sample_dtau": COMMON_PERIOD})
    final = np.concatenate([run.a[-1], run.adot[-1]])
    assert abs(run.tau[-1] - 2 * COMMON_PERIOD) < 1e-12
    assert np.max(np.abs(obs.poincare[2] - final)) < 1e-6 * np.max(np.abs(final))


hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies


@st.composite
def _tone_keys(draw):
    """The drive's keys, drawn around their edges: amplitudes 0, tiny, negative or large; a
    second frequency commensurate (p/q omega, q up to 70) or not, zero or negative; phases in
    and out of range; a few wrong types."""
    omega = draw(st.sampled_from([2.0, 3.2163, 0.0, 1e-3]))
    p, q = draw(st.integers(1, 80)), draw(st.integers(1, 70))
    omega_2 = draw(st.one_of(st.just(omega * p / q), st.floats(-1.0, 40.0), st.just(0.0)))
    number = st.one_of(st.floats(-1e-3, 2e-3), st.just(0.0), st.floats(-8.0, 8.0))
    scene = {"omega": omega, "omega_2": omega_2,
             "alpha2_2": draw(st.one_of(st.just(0.0), st.floats(-1e-4, 3e-4))),
             "drive_phase": draw(number), "drive_phase_2": draw(number)}
    if draw(st.integers(0, 9)) == 0:
        scene[draw(st.sampled_from(sorted(scene)))] = draw(st.sampled_from(["x", None, [1.0, 2.0], True]))
    return scene


@hypothesis.settings(max_examples=60, deadline=None, derandomize=True,
                     suppress_health_check=list(hypothesis.HealthCheck))
@hypothesis.given(_tone_keys(), st.sampled_from(["dop853", "flight_exact", "rk4_paper"]))
def test_fuzzed_tone_keys_give_a_result_or_one_line_error(scene, method):
    """Every draw of the tone keys runs to finite arrays or raises a one-line tmafm error; a run
    that succeeds with a second tone had tones commensurate to 1e-9 with q <= 64."""
    try:
        result = tmafm.run("fig2_n2", scene=scene, solver={"method": method, "tau_end": 0.5},
                           output={"sample_dtau": 0.1})
    except tmafm.TmafmError as exc:
        assert str(exc) and "\n" not in str(exc)
        return
    for name in ("vt", "vtdot", "a", "adot"):
        assert np.all(np.isfinite(getattr(result, name))), name
    if scene["alpha2_2"] != 0:
        ratio = scene["omega_2"] / scene["omega"]
        assert any(abs(ratio * k - round(ratio * k)) <= 1e-9 * ratio * k for k in range(1, 65))


def test_steady_tone_phase_has_no_wrap():
    """Over an orbit of two periods whose tone phase is 179 and -179 degrees, the steady phase is
    180 (the harmonic over the periods), not their arithmetic mean 0; the amplitude is the
    harmonic's, cos(1 degree) of the per-period ones."""
    from tmafm.observe import Observation
    per = {"tone2_amplitude": np.array([0.0, 1.0, 1.0]), "tone2_phase": np.array([0.0, 179.0, -179.0])}
    obs = Observation(periods=3, period=2, steady=True, per_period=per, poincare=np.zeros((4, 2)),
                      final_state=np.zeros(2))
    steady = obs.steady_values()
    assert abs(abs(steady["tone2_phase"]) - 180.0) < 1e-12
    assert steady["tone2_amplitude"] == pytest.approx(math.cos(math.radians(1.0)), rel=1e-14)


#: A calibrated cantilever (k = 2.8 N/m, f0 = 75 kHz, Q = 30) driven at f0 and at 7 f0, each tone
#: given in Hz and by the tip's free amplitude there, 1 um from the sample.
BIMODAL_PHYSICAL = {"spring_constant": 2.8, "resonance_frequency": 75e3, "quality_factor": 30.0,
                    "tip_mass_ratio": 0.01, "length": 225e-6, "tip_position": 225e-6,
                    "drive_frequency": 75e3, "free_amplitude": 10e-9,
                    "drive_frequency_2": 525e3, "free_amplitude_2": 0.5e-9, "tip_sample_distance": 1e-6}

def test_second_tone_in_hz_and_by_its_free_amplitude():
    """Bimodal AFM as practised: the second tone given in Hz and by the tip's free amplitude
    there (&physical drive_frequency_2, free_amplitude_2).  Far from the sample each tone's
    lock-in of a long flight_exact run is its free amplitude to 1e-6 (the tones' responses
    superpose), amplitude is tone 1's, and omega_2 = 2 pi f_2 t0."""
    physical = BIMODAL_PHYSICAL
    config = tmafm.Config({"model": {"n_modes": 3, "contact_law": "dmt"}, "physical": physical,
                           "solver": {"method": "flight_exact", "rtol": 1e-12, "atol": 1e-16}})
    t0 = config.derived["time_scale"]
    assert config.scene["omega_2"] == pytest.approx(2 * math.pi * 525e3 * t0, rel=1e-14)
    model = tmafm.Model(config)
    mass, damping, stiffness, _ = model.matrices(0.0, np.zeros(3), False)
    inv = np.linalg.inv(mass)
    values = np.linalg.eigvals(np.block([[np.zeros((3, 3)), np.eye(3)], [-inv @ stiffness, -inv @ damping]]))
    common = 2 * math.pi / config.scene["omega"]     # 525/75 = 7: the common period is tone 1's
    n_periods = math.ceil(21 / min(-values.real) / common) + 2
    obs = tmafm.observe(config, max_periods=n_periods, stop_at_steady=False)
    d = config.derived["gap"]
    assert obs.per_period["min_gap"][-1] > 0
    assert obs.per_period["tone1_amplitude"][-1] * d == pytest.approx(10e-9, rel=1e-6)
    assert obs.per_period["tone2_amplitude"][-1] * d == pytest.approx(0.5e-9, rel=1e-6)
    assert obs.per_period["amplitude"][-1] == obs.per_period["tone1_amplitude"][-1]
    # The resolved text keeps the keys given, and reads back to the same scene.
    again = tmafm.Config(config.to_dict())
    assert again.scene["alpha2_2"] == config.scene["alpha2_2"]


@pytest.mark.parametrize("extra, words", [
    ({"free_amplitude_2": 1e-9}, "free_amplitude_2 = 1e-09: needs the second tone's frequency"),
    ({"drive_frequency_2": 2e5, "drive_angular_frequency_2": 1e6}, "drive_frequency_2"),
])
def test_second_tone_keys_refused_in_one_line(extra, words):
    with pytest.raises(tmafm.InputError, match=words.replace("(", r"\(")) as info:
        tmafm.Config("tapping_polystyrene", physical=extra)
    assert "\n" not in str(info.value)


def test_a_two_tone_approach_reports_each_tones_setpoint():
    """An approach curve on a bimodal base given by both free amplitudes: far from the sample
    setpoint (tone 1) and setpoint_2 (tone 2) are 1 to the steady test's tolerance; tapping, both
    move off 1, and amplitude is tone 1's lock-in."""
    physical = BIMODAL_PHYSICAL
    base = tmafm.Config({"model": {"n_modes": 3, "contact_law": "dmt"}, "physical": physical,
                         "solver": {"method": "flight_exact", "rtol": 1e-10, "atol": 1e-14}})
    ds = tmafm.approach(base, z=[1e-6, 6e-9], retract=False, max_periods=2000, steady_tol=1e-9,
                        workers=1)
    a = ds.sel(direction="approach")
    assert (a.steady.values == 1).all()
    assert float(a.setpoint[0]) == pytest.approx(1.0, abs=1e-6)
    assert float(a.setpoint_2[0]) == pytest.approx(1.0, abs=1e-6)
    assert float(a.setpoint[1]) < 0.9 and abs(float(a.setpoint_2[1]) - 1) > 1e-3
    assert np.array_equal(a.amplitude.values, a.tone1_amplitude.values)
