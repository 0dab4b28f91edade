"""Every part with every other (docs/model.md, "How the parts compose"): a drive of two tones with
phases, a liquid, a viscoelastic (SLS) sample and van der Waals attraction ('dmt_vdw'), in pairs
and all together, under every method that integrates them.

Oracles, each independent of the code under test:
- the composed peer (studies/composed_peer.py): the right-hand side of every part written again in
  numpy from docs/model.md and integrated by scipy's DOP853 phase by phase with the switches as
  events; the peer at two tolerances gives the scale of its own error;
- over a steady orbit the drive's work equals the dissipations (the energy balance), with each
  part's loss channel present.
"""

import numpy as np
import pytest

import tmafm
from composed_peer import ComposedPeer

SCENE = "fig2_n4"
TAU_END = 10.0
SAMPLE = 0.01
TONES = {"alpha2_2": 2e-4, "omega_2": 6.0, "drive_phase": 0.4, "drive_phase_2": 1.1}
LIQUID = {"medium_mass": 0.1, "medium_reynolds": 10.0}
SLS = {"sls_relaxation_time": 0.5, "sls_modulus_ratio": 0.4}
VDW = {"vdw_adhesion": 0.5, "vdw_range": 2e-4}
# The forces at a distance (docs/model.md §17): a biased tip, and a double layer in a liquid.
ELECTROSTATIC = {"electrostatic_strength": 0.05, "electrostatic_radius": 0.004, "cone_half_angle": 0.35}
DOUBLE_LAYER = {"double_layer_strength": 0.3, "double_layer_range": 3e-4}
CAPILLARY = {"capillary_strength": 2.0, "capillary_range": 2e-4}

CASES = {
    "tones+liquid": ({**TONES, **LIQUID}, "hertz"),
    "tones+sls": ({**TONES, **SLS}, "hertz"),
    "tones+vdw": ({**TONES, **VDW}, "dmt_vdw"),
    "sls+vdw": ({**SLS, **VDW}, "dmt_vdw"),
    "liquid+vdw": ({**LIQUID, **VDW}, "dmt_vdw"),
    "liquid+sls": ({**LIQUID, **SLS}, "dmt"),
    "tones+liquid+sls+vdw": ({**TONES, **LIQUID, **SLS, **VDW}, "dmt_vdw"),
    "electrostatic+dmt": (ELECTROSTATIC, "dmt"),
    "electrostatic+tones+sls": ({**ELECTROSTATIC, **TONES, **SLS}, "hertz"),
    "double_layer+liquid+vdw": ({**DOUBLE_LAYER, **LIQUID, **VDW}, "dmt_vdw"),
    "double_layer+liquid": ({**DOUBLE_LAYER, **LIQUID}, "hertz"),
    "all_forces_at_a_distance+sls+vdw": ({**ELECTROSTATIC, **DOUBLE_LAYER, **SLS, **VDW}, "dmt_vdw"),
    # The JKR neck (docs/model.md §18): its pull-off above the surface is a switch of its own.
    # A drive of 2e-3 d: Fig. 2's 5e-4 leaves the tip on the neck for good after its first tap.
    "jkr": ({"alpha2": 2e-3}, "jkr"),
    "jkr+tones+liquid": ({**TONES, **LIQUID, "alpha2": 2e-3}, "jkr"),
    "jkr+electrostatic": ({**ELECTROSTATIC, "alpha2": 2e-3}, "jkr"),
    # The capillary meniscus (docs/model.md §19): it holds the tip in flight and breaks at D.
    "capillary": ({**CAPILLARY, "alpha2": 2e-3}, "dmt"),
    "capillary+tones+sls+vdw": ({**CAPILLARY, **TONES, **SLS, **VDW, "alpha2": 2e-3}, "dmt_vdw"),
}


def _run(scene, law, method, rtol):
    return tmafm.run(SCENE, scene=scene, model={"contact_law": law},
                     solver={"method": method, "rtol": rtol, "atol": 1e-15, "tau_end": TAU_END},
                     output={"sample_dtau": SAMPLE})


@pytest.mark.parametrize("case", list(CASES))
def test_composed_trajectory_equals_the_independent_peer(case):
    scene, law = CASES[case]
    # (The peer takes the scene's constants; dop853 is a method every law and part accepts.)
    peer = ComposedPeer(SCENE, scene=scene, model={"contact_law": law}, solver={"method": "dop853"})
    _, reference = peer.solve(TAU_END, SAMPLE, rtol=1e-12)
    _, loose = peer.solve(TAU_END, SAMPLE, rtol=1e-10)
    scale = np.ptp(reference)
    # The peer's error at rtol 1e-10 bounds its error at 1e-12 many times over.
    peer_error = np.max(np.abs(loose - reference)) / scale
    # Both phases must be visited, else the test would not compose the contact with the rest.
    assert np.any(reference < 0) and np.any(reference > 0)
    # flight_exact integrates a flight with a force at a distance by its Lawson form (tmafm_lawson).
    for method in ["dop853", "dopri5", "flight_exact"]:
        tight = _run(scene, law, method, 1e-11)
        looser = _run(scene, law, method, 1e-9)
        # The method's own error at 1e-9 bounds its error at 1e-11.
        method_error = np.max(np.abs(looser.vt - tight.vt)) / scale
        difference = np.max(np.abs(tight.vt - reference)) / scale
        assert difference <= 10 * max(peer_error, method_error), (case, method, difference, peer_error,
                                                                 method_error)


@pytest.mark.parametrize("case", ["tones+liquid", "tones+sls", "sls+vdw", "liquid+sls", "tones+liquid+sls+vdw",
                                  "electrostatic+tones+sls", "double_layer+liquid", "jkr", "jkr+tones+liquid"])
def test_energy_balance_closes_with_every_part(case):
    scene, law = CASES[case]
    obs = tmafm.observe(SCENE, scene=scene, model={"contact_law": law},
                        solver={"method": "flight_exact", "rtol": 1e-11, "atol": 1e-15}, max_periods=200)
    assert obs.period >= 1
    p = obs.per_period
    orbit = slice(len(p["drive_work"]) - obs.period, None)

    def total(name):
        return float(np.sum(p[name][orbit]))

    drive = total("drive_work")
    balance = drive + total("contact_normal_work") - total("dissipated_energy")
    assert drive > 0
    # rtol 1e-11 on the orbit: the balance closes far inside 1e-6 of the drive's work.
    assert abs(balance) <= 1e-6 * drive, (case, balance, drive)
    # The sample's loss is there and is a loss.
    if "sls" in case:
        assert total("dissipated_viscoelastic") > 1e-3 * drive
        assert abs(balance + total("dissipated_viscoelastic")) > 100 * abs(balance)
    # The JKR neck's loss likewise, with the taps going past pull-off.
    if "jkr" in case:
        assert total("dissipated_adhesion") > 1e-3 * drive
        assert abs(balance + total("dissipated_adhesion")) > 100 * abs(balance)


@pytest.mark.parametrize("method", ["rk4_paper", "rk4_event"])
def test_a_viscoelastic_sample_under_a_fixed_step_method_is_refused_in_one_line(method):
    with pytest.raises(tmafm.InputError, match=f"method = '{method}'.*viscoelastic") as info:
        tmafm.run(SCENE, scene={**SLS, **TONES}, solver={"method": method, "tau_end": 1.0})
    assert "\n" not in str(info.value)


def test_most_attractive_force_is_the_attraction_at_the_closest_separation():
    """On the attractive branch of docs/vdw.md's scene (no contact), min_force is the van der
    Waals force at the orbit's closest approach, -c_H/(1 + V_T sin(theta1)/eps)^2 in the units
    of the brackets (-H R/(6 s^2) in SI), evaluated here in numpy over a dense run of the next
    period; peak_force is the weakest attraction, negative."""
    import math
    from pathlib import Path

    from tmafm.observe import observe_states

    scene_file = Path(__file__).resolve().parents[1] / "inputs" / "sweeps" / "vdw_attractive.nml"
    config = tmafm.Config(str(scene_file), scene={"delta_hat": 9.0e-4},
                          solver={"method": "dop853", "rtol": 1e-11, "atol": 1e-18})
    model = tmafm.Model(config)
    p, omega, lag = model.tip[0], model.scene["omega"], math.radians(-116)
    state = np.array([[8.9e-4 * math.sin(lag) / p, 8.9e-4 * omega * math.cos(lag) / p]])
    obs = observe_states(config, state, max_periods=3000, observables=["peak_force", "extrema"])
    assert obs.period[0] == 1 and obs.steady["min_gap"][0] > 0
    located_min, located_max = obs.steady["min_force"][0], obs.steady["peak_force"][0]
    # A dense run over the orbit's last period, from its start (the last Poincare point but one;
    # period 1: tau = 0 again): the same stretch of trajectory the observables were located on.
    final = obs.orbit[0, -2]
    period = 2 * math.pi / omega
    run = tmafm.run(config, initial={"a0": [final[0]], "adot0": [final[1]]},
                    solver={"tau_end": period}, output={"sample_dtau": period / 20000})
    s = model.scene
    slope = run.a @ model.slope / s["l_over_d"]
    sin1 = np.sin(math.pi / 2 - s["theta"] + np.arctan(slope))
    force = model.kappas[0] * (-s["vdw_adhesion"] / (1 + run.vt * sin1 / s["vdw_range"]) ** 2)
    assert np.all(run.vt > 0)
    # The closed form at the orbit's closest approach, the located min_gap (sin(theta1) from the
    # sample there: it changes by 1e-12 over the dip).
    k = int(np.argmin(run.vt))
    closest = model.kappas[0] * (-s["vdw_adhesion"] / (1 + obs.steady["min_gap"][0] * sin1[k] / s["vdw_range"]) ** 2)
    assert located_min == pytest.approx(closest, rel=1e-9)
    # Located, never inside the samples; and within the samples' own error of their extreme:
    # |F''| dt^2/8 from their second difference, plus rtol 1e-11 on V_T carried by dF/dV_T.
    for located, i, sign in ((located_min, k, 1.0), (located_max, int(np.argmax(force)), -1.0)):
        assert sign * located <= sign * force[i]
        # The orbit is periodic (sample 0 = the last): neighbours wrap around.
        before, after = force[(i - 1) % (force.size - 1)], force[(i + 1) % (force.size - 1)]
        curvature = abs(before - 2 * force[i] + after) / 8
        assert abs(located - force[i]) <= curvature + 1e-8 * abs(force[i]), (located, force[i], curvature)
    assert located_max < 0


def test_tip_sample_power_holds_the_sample_loss():
    """An approach curve on a viscoelastic polymer: tip_sample_power is every tip-sample loss
    channel (contact damping, friction and the sample's own loss) per drive period, in the
    proportion the per-period energies give, the sample's share included."""
    base = tmafm.Config("tapping_polystyrene",
                        physical={"sample_relaxation_time": 1e-6, "sample_modulus_relaxed": 0.4e9})
    ds = tmafm.approach(base, z=[10e-9], retract=False, max_periods=3000, steady_tol=1e-7, workers=1)
    at = ds.sel(direction="approach").isel(z=0)
    assert int(at.steady) == 1
    channels = float(at.dissipated_contact_damping + at.dissipated_friction + at.dissipated_viscoelastic)
    assert float(at.tip_sample_power / at.dissipated_power) == pytest.approx(
        channels / float(at.dissipated_energy), rel=1e-12)
    assert float(at.dissipated_viscoelastic) > 1e-3 * channels


@pytest.mark.parametrize("case", ["tones+liquid", "liquid+sls", "tones+sls"])
def test_flight_exact_observables_of_composed_scenes_agree_with_dop853(case):
    """flight_exact's closed-form observables over its flights (a'.C a' with the liquid's C_jj,
    each tone's drive and velocity parts) against dop853's Gauss-Legendre sums on its dense
    output at a tighter tolerance: every column, per period, within 10x flight_exact's own error
    (its change from rtol 1e-10 to 1e-11), or 1e-9 of the column's scale.  (With tones in a
    liquid the tones' velocity parts once left the liquid's damping out of the beam
    dissipation: 38 % off.)  Hertz, so that every period has flights and taps."""
    scene, _ = CASES[case]
    runs = {}
    for label, method, rtol in (("exact", "flight_exact", 1e-11), ("looser", "flight_exact", 1e-10),
                                ("reference", "dop853", 1e-12)):
        runs[label] = tmafm.observe(SCENE, scene=scene, model={"contact_law": "hertz"}, max_periods=6,
                                    stop_at_steady=False, solver={"method": method, "rtol": rtol, "atol": 1e-20})
    got, looser, ref = (runs[k].per_period for k in ("exact", "looser", "reference"))
    assert np.all(ref["contacts_per_period"] >= 1)
    for name, values in ref.items():
        a, b, c = (np.asarray(x, float) for x in (got[name], values, looser[name]))
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        own = 10 * np.nanmax(np.abs(c - a))
        if "phase" in name:
            assert np.nanmax(np.abs(a - b)) <= max(1e-7, own), name
        else:
            scale = np.nanmax(np.abs(b)) or 1.0
            assert np.nanmax(np.abs(a - b)) <= max(1e-9 * scale, own), (name, np.nanmax(np.abs(a - b)) / scale)
