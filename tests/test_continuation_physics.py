"""The stroboscopic map beyond Hertz/DMT with one tone (docs/continuation.md, docs/vdw.md):
van der Waals attraction in flight ('dmt_vdw'), a general drive (two tones, a drive phase) and a
viscoelastic sample (the state (a, adot, w)).  The core's Jacobian against central differences
of the core's right-hand side, the monodromy matrix against central differences of the map,
and the typed errors of tmafm.continuation."""

import math
from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import continuation as cont

BISTABLE = str(Path(__file__).resolve().parents[1] / "inputs" / "sweeps" / "bistable_n2.nml")
VDW = "sweeps/vdw_attractive"
SLS = {"sls_relaxation_time": 0.3, "sls_modulus_ratio": 0.4}
PHASE = {"drive_phase": 0.7}
#: Two tones at 2:1 (the common period is tone 1's) and at 3:2 (twice tone 1's period).
TONES_2 = {"alpha2_2": 2e-4, "omega_2": 7.6, "drive_phase_2": 0.4}
TONES_3_2 = {"alpha2_2": 2e-4, "omega_2": 5.7}
#: A liquid (per-mode added mass and damping) and a second tone on the vdW scene (2:1).
LIQUID = {"medium_mass": 0.02, "medium_reynolds": 200.0}
VDW_TONE = {"alpha2_2": 4e-7, "omega_2": 7.032030537000301, "drive_phase": 0.3}
#: The forces at a distance (docs/model.md §17): a biased tip, and a double layer.
ELECTROSTATIC = {"electrostatic_strength": 0.05, "electrostatic_radius": 0.004, "cone_half_angle": 0.35}
DOUBLE_LAYER = {"double_layer_strength": 0.3, "double_layer_range": 3e-5}
#: A method that integrates a forced flight (bistable_n2 runs flight_exact).
DOP853 = {"solver": {"method": "dop853"}}
#: The vdW scene with two modes.
N2 = {"model": {"n_modes": 2}, "initial": {"a0": [0.0, 0.0]}}


def _with_gap(model, tau, vt, y):
    """y with a_1 changed so that the tip gap at tau is vt (V_T is affine in a_1; the core's
    V_T at a_1 = 0 and 1 gives it)."""
    y = np.array(y, dtype=float)
    n = model.n_modes
    a = y[:n].copy()
    a[0] = 0.0
    v0 = model.contact(tau, a).vt
    a[0] = 1.0
    slope = model.contact(tau, a).vt - v0
    y[0] = (vt - v0) / slope
    assert abs(model.contact(tau, y[:n]).vt - vt) <= 1e-9 * max(abs(vt), 1e-4)
    return y


def _fd_jacobian(model, tau, y, in_contact):
    """Central differences of the core's right-hand side in each state component, step 1e-6 of
    the component's size (1e-9 at least), the rows and columns of the map's state (the
    viscoelastic pad after w left out)."""
    m = cont.map_size(model)
    full = np.zeros(2 * model.n_modes + (2 if m % 2 else 0))
    full[:m] = y
    fd = np.empty((m, m))
    for j in range(m):
        h = max(1e-6 * abs(full[j]), 1e-9)
        e = np.zeros_like(full)
        e[j] = h
        fd[:, j] = (model.derivative(tau, full + e, in_contact)[:m]
                    - model.derivative(tau, full - e, in_contact)[:m]) / (2 * h)
    return fd


@pytest.mark.parametrize("name, source, overrides, vt, in_contact, w", [
    # 'dmt_vdw' in flight a few a0 above the surface, and in contact; N = 2 and a tilt, so the
    # slope's partials count too.
    ("vdw_flight", VDW, {**N2, "scene": {"theta": 0.2}}, 3e-5, False, None),
    ("vdw_flight_near", VDW, {"scene": {"theta": 0.1}}, 2e-6, False, None),
    ("vdw_contact", VDW, {**N2, "scene": {"theta": 0.2, "alpha4": 0.3}}, -2e-5, True, None),
    ("dmt_contact", BISTABLE, {"model": {"contact_law": "dmt"}}, -4e-4, True, None),
    ("phase_contact", BISTABLE, {"scene": PHASE}, -4e-4, True, None),
    ("tones_contact", BISTABLE, {"scene": TONES_2}, -4e-4, True, None),
    # The viscoelastic sample pressed (X > (1 - r) w), left behind (X < (1 - r) w), in flight.
    ("sls_pressed", BISTABLE, {"scene": SLS}, -4e-4, True, 0.5),
    ("sls_behind", BISTABLE, {"scene": SLS}, -4e-4, True, 200.0),
    ("sls_flight", BISTABLE, {"scene": SLS}, 4e-4, False, 3.0),
    # The parts composed (docs/model.md §16): the sample under the vdW law (its adhesion does
    # not relax; the attraction sees the undeformed surface), tones in the vdW separation, and
    # tones with a liquid and a viscoelastic sample.
    ("sls_vdw_pressed", VDW, {"scene": SLS}, -2e-5, True, 1.0),
    ("sls_vdw_behind", VDW, {"scene": SLS}, -2e-5, True, 50.0),
    ("sls_vdw_flight", VDW, {"scene": {**SLS, "theta": 0.1}}, 3e-5, False, 3.0),
    ("tones_vdw_flight", VDW, {"scene": VDW_TONE}, 3e-5, False, None),
    ("tones_liquid_sls", BISTABLE, {"scene": {**TONES_2, **LIQUID, **SLS}}, -4e-4, True, 0.5),
    # The forces at a distance in flight (their separation's slope partials with a tilt), on
    # their own and with the vdW tail, and their constant part in contact.
    ("electrostatic_flight", BISTABLE, {"scene": {**ELECTROSTATIC, "theta": 0.2}, **DOP853}, 3e-5, False,
     None),
    ("double_layer_vdw_flight", VDW, {"scene": {**DOUBLE_LAYER, "theta": 0.1}}, 2e-5, False, None),
    ("electrostatic_dmt_contact", BISTABLE, {"model": {"contact_law": "dmt"}, "scene": ELECTROSTATIC, **DOP853},
     -4e-4, True, None),
])
def test_jacobian_equals_finite_differences_of_the_right_hand_side(name, source, overrides, vt,
                                                                   in_contact, w):
    """The partials of tmafm_model_jacobian (the vdW force in flight, the DMT law in contact, the
    drive's base signal in V_T, the dashpot's row and column) against central differences of
    model.derivative: truncation O(h^2) ~ 1e-12 relative, round-off ~ 1e-10."""
    model = tmafm.Model(source, **overrides)
    n = model.n_modes
    tau = 0.37
    rest = np.concatenate([np.full(n, 3e-5), np.linspace(2e-3, -1e-3, n)])
    y = _with_gap(model, tau, vt, rest)
    if w is not None:
        y = np.append(y, w)
    jac = cont.jacobian(model, tau, y, in_contact)
    fd = _fd_jacobian(model, tau, y, in_contact)
    scale = np.max(np.abs(jac[n:]), axis=1, keepdims=True)
    assert np.max(np.abs(jac[n:] - fd[n:]) / scale) <= 1e-6, (name, jac, fd)
    np.testing.assert_allclose(jac[:n], fd[:n], rtol=0, atol=1e-8)
    # Where a force acts, its part is really there: the Jacobian differs from the free one far
    # from the sample (V_T = 0.5 d, the attraction 1e-9 of its value at contact) by more than
    # 1 % of the first mode's stiffness (not with the sample left behind under the stiff vdW
    # scene: there only the constant adhesion and a weak friction act).
    far = _with_gap(model, tau, 0.5, rest)
    free = cont.jacobian(model, tau, far if w is None else np.append(far, w), False)
    if (in_contact or "vdw" in name) and name != "sls_vdw_behind":
        assert np.max(np.abs(jac[n:2 * n] - free[n:2 * n])) > 1e-2 * abs(free[n, 0]), name
    if w is not None:
        assert jac[2 * n, 2 * n] < 0


def _orbit_state(model, periods, rtol=1e-10):
    y = np.zeros(cont.map_size(model))
    for _ in range(periods):
        y = cont.periodic_map(model, y, 1, rtol).y
    return y


def _vdw_state(model, amplitude, lag_deg):
    """A state on a first-harmonic orbit of the vdW scene: V_T's swing `amplitude` (d) at the lag."""
    p, omega, lag = model.tip[0], model.scene["omega"], math.radians(lag_deg)
    return np.array([amplitude * math.sin(lag) / p, amplitude * omega * math.cos(lag) / p])


def _fd_map(model, y, rtol):
    fd = np.empty((len(y), len(y)))
    for j in range(len(y)):
        h = 1e-5 * max(abs(y[j]), np.max(np.abs(y[:model.n_modes])))
        e = np.zeros_like(y)
        e[j] = h
        fd[:, j] = (cont.periodic_map(model, y + e, 1, rtol).y
                    - cont.periodic_map(model, y - e, 1, rtol).y) / (2 * h)
    return fd


@pytest.mark.parametrize("name, make, contacts", [
    # The attractive orbit of docs/vdw.md at Z = 9 nm: no contact, the attraction all along.
    ("vdw_attractive", lambda: (tmafm.Model(VDW, scene={"delta_hat": 9.0e-4}), -116.0, 8.8e-4), 0),
    # The repulsive one: a tap, the DMT law in contact, the vdW continuous at the switches.
    ("vdw_repulsive", lambda: (tmafm.Model(VDW, scene={"delta_hat": 9.0e-4}), -66.0, 9.2e-4), 1),
    # With contact damping the field jumps at the switches: the saltation matrix is not I.
    ("vdw_damped", lambda: (tmafm.Model(VDW, scene={"delta_hat": 9.0e-4, "alpha4": 2e-3}), -66.0,
                            9.2e-4), 1),
])
def test_vdw_monodromy_equals_finite_differences(name, make, contacts):
    """Central differences of P with step 1e-5 of the state's size against the monodromy matrix
    from the variational equations in flight and contact and the saltation matrices: truncation
    O(h^2) ~ 1e-10, the map's tolerance 1e-13/1e-5 ~ 1e-8, against the 1e-6 asked."""
    model, lag, amplitude = make()
    y = _vdw_state(model, amplitude, lag)
    out = cont.periodic_map(model, y, 1, 1e-13)
    assert out.stats["contacts"] == contacts
    if contacts:
        assert out.stats["gap_min"] < 0 < out.stats["gap_max"]
    else:
        # The flight's closest approach is the orbit's minimum, found inside the flight.
        assert 0 < out.stats["flight_gap_min"] == out.stats["gap_min"]
    fd = _fd_map(model, y, 1e-13)
    error = np.max(np.abs(out.monodromy - fd)) / np.max(np.abs(out.monodromy))
    assert error <= 1e-6, (name, error, out.monodromy, fd)


@pytest.mark.parametrize("name, scene", [("sls_vdw", SLS), ("tones_vdw", VDW_TONE),
                                         ("sls_tones_vdw", {**SLS, **VDW_TONE})])
def test_composed_vdw_monodromy_equals_finite_differences(name, scene):
    """The vdW scene's tapping orbit with a viscoelastic sample (the state (a, adot, w)) and with a
    second tone (2:1, a phase): the monodromy matrix against central differences of the map."""
    model = tmafm.Model(VDW, scene={"delta_hat": 9.0e-4, **scene})
    y = _vdw_state(model, 9.2e-4, -66.0)
    if cont.map_size(model) == 3:
        y = np.append(y, 0.5)
    y = cont.periodic_map(model, y, 1, 1e-12).y
    out = cont.periodic_map(model, y, 1, 1e-13)
    assert out.stats["contacts"] == 1
    fd = _fd_map(model, y, 1e-13)
    error = np.max(np.abs(out.monodromy - fd)) / np.max(np.abs(out.monodromy))
    assert error <= 1e-6, (name, error, out.monodromy, fd)


def test_vdw_stats_match_a_dense_run():
    """The orbit stats under 'dmt_vdw' against a dense dop853 run over the same period from the
    same state: the smallest and largest V_T, the contact time, and the end state (the scene's
    atol 1e-12 is loose for a state of 4e-4: the run takes 1e-16)."""
    model = tmafm.Model(VDW, scene={"delta_hat": 9.0e-4})
    y = _vdw_state(model, 9.2e-4, -66.0)
    out = cont.periodic_map(model, y, 1, 1e-12)
    period = cont.map_period(model)
    run = tmafm.run(VDW, scene={"delta_hat": 9.0e-4}, initial={"a0": [y[0]], "adot0": [y[1]]},
                    solver={"method": "dop853", "rtol": 1e-12, "atol": 1e-16, "tau_end": period},
                    output={"sample_dtau": period / 20000})
    vt = run.vt
    step = period / 20000
    # Sampled extrema are within the sampling's error (V_T'' step^2/8) of the located ones.
    tol = 1e-3 * (out.stats["gap_max"] - out.stats["gap_min"])
    assert abs(vt.min() - out.stats["gap_min"]) <= tol
    assert abs(vt.max() - out.stats["gap_max"]) <= tol
    assert abs(np.sum(vt <= 0) * step - out.stats["contact_time"]) <= 3 * step
    np.testing.assert_allclose(out.y, [run.a[-1, 0], run.adot[-1, 0]], rtol=1e-9)


@pytest.mark.parametrize("name, scene", [
    ("phase", PHASE), ("tones_2_1", TONES_2), ("tones_3_2", TONES_3_2), ("sls", SLS),
    ("sls_dmt", SLS), ("tones_liquid_sls", {**TONES_2, **LIQUID, **SLS}),
])
def test_general_drive_and_sls_monodromy_equal_finite_differences(name, scene):
    """The map with a drive phase, two tones (the common period: 2 pi/Omega_0) and a viscoelastic
    sample (the state (a, adot, w)): its monodromy matrix against central differences, as for
    Hertz (tests/test_continuation.py)."""
    law = {"model": {"contact_law": "dmt"}} if name == "sls_dmt" else {}
    tones = name.startswith("tones")
    model = tmafm.Model(BISTABLE, scene={"delta_hat": 0.0005, **scene}, **law)
    omega = model.scene["omega"]
    expected_period = 2 * math.pi / omega * (2 if name == "tones_3_2" else 1)
    assert tones == ("alpha2_2" in scene)
    assert cont.map_period(model) == pytest.approx(expected_period, rel=1e-14)
    y = _orbit_state(model, 40 if name != "tones_3_2" else 20)
    out = cont.periodic_map(model, y, 1, 1e-13)
    assert len(out.y) == 2 * model.n_modes + (1 if "sls" in name else 0)
    assert out.stats["contacts"] >= 1 and out.stats["gap_min"] < 0
    fd = _fd_map(model, y, 1e-13)
    error = np.max(np.abs(out.monodromy - fd)) / np.max(np.abs(out.monodromy))
    assert error <= 1e-6, (name, error)


def test_continuation_unknown_keyword_is_a_typed_one_line_error():
    with pytest.raises(tmafm.InputTypeError, match="bogus = 1") as info:
        tmafm.continuation(BISTABLE, "scene.delta_hat", 0.0, 1e-3, bogus=1)
    assert "\n" not in str(info.value)


# --- docs/vdw.md: the two branches continued, their folds against warm-started sweeps -------

@pytest.fixture(scope="module")
def vdw_branch():
    """The branch of docs/vdw.md's scene from the attractive orbit at Z = 10 nm down to 6.7 nm
    (studies/vdw_continuation.py, whose JSON docs/vdw.md quotes)."""
    model = tmafm.Model(VDW, scene={"delta_hat": 1.0e-3})
    return tmafm.continuation(VDW, "scene.delta_hat", 1.0e-3, 6.7e-4,
                              y0=_vdw_state(model, 9.5e-4, -95.0), max_points=400, switch=False)


def _fine_sweep(ds, fold, direction, step=2e-7):
    """A warm-started sweep through a fold in steps of 0.002 nm from the continued stable orbit
    nearest the fold but at least 2 steps from it on its stable side (its section state as the
    initial state) to 3 steps past the fold; returns the last Z on the branch and the first
    off it."""
    z, stable = ds["scene.delta_hat"].values, ds.stable.values
    sign = 1.0 if direction == "approach" else -1.0
    first = min((i for i in range(len(z)) if stable[i] and sign * (z[i] - fold) >= 2 * step),
                key=lambda i: abs(z[i] - fold))
    state = ds.state.values[first, 0]
    grid = np.round(np.arange(z[first], fold - sign * 3 * step, -sign * step), 12)
    base = tmafm.Config(VDW, initial={"a0": [state[0]], "adot0": [state[1]]})
    s = tmafm.approach(base, grid, retract=False, max_periods=6000, observables=["lockin"],
                       workers=1).sel(direction="approach")
    amplitude = s.amplitude.values
    # The jump: the one amplitude step far larger than the others (the branches are ~0.15 nm
    # apart in amplitude, the steps along a branch ~0.002 nm).
    jumps = np.abs(np.diff(amplitude))
    k = int(np.argmax(jumps))
    assert jumps[k] > 10 * np.median(jumps), amplitude
    return grid[k], grid[k + 1]


def _labelled(ds):
    return {k: [int(i) for i in np.flatnonzero(ds.label.values == k)] for k in ("grazing", "fold")}


def test_vdw_continuation_follows_the_attractive_and_the_repulsive_branch(vdw_branch):
    """From the attractive orbit the branch grazes the sample, folds, comes back unstable, folds
    again and goes on as the repulsive (tapping) branch: stable outside the folds, unstable
    between, one multiplier through 1 at each fold."""
    ds = vdw_branch
    labels = [str(v) for v in ds.label.values if v]
    assert labels == ["start", "grazing", "fold", "fold", "end"], labels
    found = _labelled(ds)
    i_graze, (i_low, i_high) = found["grazing"][0], found["fold"]
    z = ds["scene.delta_hat"].values
    stable = ds.stable.values
    assert stable[:i_low].all() and not stable[i_low + 1:i_high].any() and stable[i_high + 1:].all()
    assert ds.min_gap.values[:i_graze].min() > 0 and ds.contacts.values[i_graze + 1:].min() == 1
    assert z[i_low] < z[i_high]
    for i in (i_low, i_high):
        assert np.min(np.abs(ds.multiplier_abs.values[i] - 1)) <= 1e-6


@pytest.mark.filterwarnings("ignore::tmafm.UnsteadyWarning")
@pytest.mark.parametrize("direction", ["approach", "retract"])
def test_vdw_folds_are_where_warm_started_sweeps_jump(vdw_branch, direction):
    """Warm-started sweeps in 0.002 nm steps jump where the continuation's folds are: the
    approach leaves the attractive branch at the lower fold, the retract the repulsive one at
    the upper; a branch ends at most 3 steps before its fold (a warm start must stay in a basin
    that shrinks to nothing at the fold) and never past it (no orbit lies there)."""
    ds = vdw_branch
    i_low, i_high = _labelled(ds)["fold"]
    z = ds["scene.delta_hat"].values
    step = 2e-7
    if direction == "approach":
        last, first_off = _fine_sweep(ds, z[i_low], "approach")
        assert z[i_low] < last <= z[i_low] + 3 * step and first_off < last, (last, first_off, z[i_low])
    else:
        last, first_off = _fine_sweep(ds, z[i_high], "retract")
        assert z[i_high] - 3 * step <= last < z[i_high] < first_off, (last, first_off, z[i_high])


def test_vdw_docs_quote_the_continuation_study():
    """docs/vdw.md's branch table and fine-sweep jumps are those of
    studies/results/vdw_continuation.json (written by the command the page gives), and VEDA's
    Z0 is Z + a0 of the scene."""
    import json
    repo = Path(__file__).resolve().parents[1]
    data = json.loads((repo / "studies" / "results" / "vdw_continuation.json").read_text())
    # The prose as one line (its line breaks fall anywhere); the table rows are lines already.
    text = " ".join((repo / "docs" / "vdw.md").read_text().split())
    assert data["command"] in text
    assert data["a0_nm"] == pytest.approx(tmafm.Model(VDW).scene["vdw_range"] * 1e4, rel=1e-12)

    def num(x, digits):
        return f"{x:.{digits}f}".replace("-", "\u2212")

    points = {p["label"]: p for p in data["labelled"] if p["label"] == "grazing"}
    folds = [p for p in data["labelled"] if p["label"] == "fold"]
    points["approach_fold"], points["retract_fold"] = sorted(folds, key=lambda p: p["z_nm"])
    for key, label in (("grazing", "grazing"), ("approach_fold", "fold"), ("retract_fold", "fold")):
        p = points[key]
        gap = "0" if key == "grazing" else num(p["min_gap_nm"], 3)
        row = (f"| {label} | {num(p['z_nm'], 4)} | {num(data['veda_z0_nm'][key], 4)} | "
               f"{num(p['amplitude_nm'], 3)} | {gap} |")
        assert row in text, row
        assert data["veda_z0_nm"][key] == pytest.approx(p["z_nm"] + data["a0_nm"], abs=1e-12)
    assert abs(points["grazing"]["min_gap_nm"]) < 1e-9
    assert f"below Z = {num(points['grazing']['z_nm'], 2)} nm, only barely" in text
    low, high = num(points["approach_fold"]["z_nm"], 4), num(points["retract_fold"]["z_nm"], 4)
    assert f"**{low} nm < Z < {high} nm**" in text
    assert f"Z = {low} nm and {high} nm" in text
    assert f"reaches {num(points['approach_fold']['min_gap_nm'], 3)} nm at the fold" in text
    end_gap = [p["min_gap_nm"] for p in data["labelled"] if p["label"] == "end"][0]
    assert f"up to {num(-end_gap, 2)} nm indentation" in text
    app, ret = data["approach"], data["retract"]
    z0, z1 = app["jump_between_nm"]
    k = app["z_nm"].index(z0)
    assert (f"the approach between Z = {num(z0, 3)} and {num(z1, 3)} nm (φ from "
            f"{num(app['phase_deg'][k], 1)}° to {num(app['phase_deg'][k + 1], 1)}°)") in text
    assert f"(φ = {num(app['phase_deg'][k], 1)}° at Z = {num(z0, 3)} nm)" in text
    lo, hi = z0 - points["approach_fold"]["z_nm"], z1 - points["approach_fold"]["z_nm"]
    assert f"{num(hi, 3)}–{num(lo, 3)} nm above the fold" in text
    r0, r1 = ret["jump_between_nm"]
    assert f"the retract between {num(r0, 3)} and {num(r1, 3)} nm, around the fold at {high} nm" in text
    assert r0 < points["retract_fold"]["z_nm"] < r1
    assert f"took {data['continuation_cpu_seconds']:.1f} s of CPU" in text


@pytest.mark.parametrize("name, scene", [("sls", SLS), ("tones_3_2", TONES_3_2)])
def test_continuation_with_a_viscoelastic_sample_and_two_tones(name, scene):
    """tmafm.continuation from a brute-force start (settle periods) with the state (a, adot, w)
    and with tones at 3:2 (the map's period twice tone 1's): each point is a fixed point of the
    map, and the contact fraction is the time in contact over the map's period (with two
    tones against a dense dop853 run over that period from the orbit's state)."""
    base = tmafm.Config(BISTABLE, scene=scene)
    ds = tmafm.continuation(base, "scene.delta_hat", 5e-4, 6e-4, max_points=3, switch=False,
                            settle=150)
    base = tmafm.Config(base, scene={"delta_hat": 5e-4})
    model = tmafm.Model(base)
    m = cont.map_size(model)
    assert ds.sizes["state"] == m == 2 * model.n_modes + (1 if name == "sls" else 0)
    x = ds.state.values[0, 0]
    assert ds["scene.delta_hat"].values[0] == 5e-4 and ds.stable.values[0]
    out = cont.periodic_map(model, x, 1, 1e-12)
    np.testing.assert_allclose(out.y, x, rtol=0, atol=1e-8 * np.max(np.abs(x)))
    if name == "sls":
        assert x[-1] > 0  # the sample is still relaxing when the period ends
        return
    period = cont.map_period(model)
    n = model.n_modes
    run = tmafm.run(base, initial={"a0": list(x[:n]), "adot0": list(x[n:])},
                    solver={"method": "dop853", "rtol": 1e-11, "atol": 1e-15, "tau_end": period},
                    output={"sample_dtau": period / 20000})
    fraction = np.mean(run.vt[1:] <= 0)
    assert abs(fraction - ds.contact_fraction.values[0]) <= 3 / 20000
    assert 0 < ds.contact_fraction.values[0] < 0.5
