"""tmafm.observe: per-period observables computed by the core while it integrates.

Oracles: the same run sampled finely (same method and tolerances, hence the same steps) and
integrated here period by period with the switches split out; synthetic Poincare sequences for
the classifier; a long run for the early stop; Eq. (10)-(12) recomputed here for the units.
"""

import math

import numpy as np
import pytest

import tmafm
from tmafm import analysis
from tmafm.observe import OBSERVABLES, steady_period

OMEGA = 2.0
T = 2 * math.pi / OMEGA
TIGHT = {"method": "dop853", "rtol": 1e-10, "atol": 1e-14}
PER_PERIOD = 4000          # samples per period of the oracle run
PERIODS = 4


def _piecewise(values, tau, switches, a, b):
    """Integral over [a, b] (sample times) of a sampled function that is smooth between the
    switches: trapezoids, with each interval that holds a switch split there and each side
    extrapolated linearly from its own phase (error O(h^2), as tmafm.analysis._integrate)."""
    i0 = int(round(a / (tau[1] - tau[0])))
    i1 = int(round(b / (tau[1] - tau[0])))
    total = 0.0
    for i in range(i0, i1):
        t0, t1 = tau[i], tau[i + 1]
        inside = switches[(switches > t0) & (switches < t1)]
        if inside.size == 0:
            total += 0.5 * (t1 - t0) * (values[i] + values[i + 1])
            continue
        assert inside.size == 1
        ts = inside[0]
        left = values[i] + (values[i] - values[i - 1]) * (ts - t0) / (t0 - tau[i - 1])
        right = values[i + 1] - (values[i + 2] - values[i + 1]) * (t1 - ts) / (tau[i + 2] - t1)
        total += 0.5 * (ts - t0) * (values[i] + left) + 0.5 * (t1 - ts) * (right + values[i + 1])
    return total


def _sampling_gap(values, sl, h):
    """|f''| (h/2)^2 / 2 at the sampled minimum of values[sl] (f'' by central differences)."""
    i = sl.start + int(np.argmin(values[sl]))
    second = (values[i - 1] - 2 * values[i] + values[i + 1]) / h ** 2
    return abs(second) * (h / 2) ** 2 / 2


@pytest.fixture(scope="module")
def fig3_pair():
    """fig3 at tight dop853 tolerances: observed, and sampled PER_PERIOD times a period."""
    obs = tmafm.observe("fig3", max_periods=PERIODS, stop_at_steady=False, solver=TIGHT)
    run = tmafm.run("fig3", solver={**TIGHT, "tau_end": PERIODS * T},
                    output={"sample_dtau": T / PER_PERIOD})
    return obs, run


def test_observables_match_the_dense_trajectory(fig3_pair):
    obs, r = fig3_pair
    assert obs.periods == PERIODS and obs.per_period["amplitude"].shape == (PERIODS,)
    flow = analysis.energy_flow(r)
    scene = r.scene
    u = r.vt - scene["delta_hat"]                               # tip displacement p.a + drive
    deflection = u - scene["alpha2"] * np.sin(OMEGA * r.tau)     # p.a
    force = scene["alpha5"] * flow["normal_group"]               # kappa5 f_c (no E4 in 'paper')
    sw = np.asarray(r.switches)
    starts = sw[[r.vt[min(int(np.searchsorted(r.tau, s)), r.tau.size - 1)] <= 0 for s in sw]]
    for k in range(1, PERIODS):        # period 0 starts at V_T = 0: skip its boundary case
        a, b = k * T, (k + 1) * T
        sl = slice(k * PER_PERIOD, (k + 1) * PER_PERIOD + 1)
        got = {name: obs.per_period[name][k] for name in OBSERVABLES}
        integ = lambda f: _piecewise(f, r.tau, sw, a, b)
        s1 = 2 / T * integ(r.vt * np.sin(OMEGA * r.tau))
        c1 = 2 / T * integ(r.vt * np.cos(OMEGA * r.tau))
        amp = math.hypot(s1, c1)
        assert got["amplitude"] == pytest.approx(amp, rel=1e-6)
        assert got["phase"] == pytest.approx(math.degrees(math.atan2(c1, s1)), abs=1e-4)
        for j in (2, 3):
            sj = 2 / T * integ(r.vt * np.sin(j * OMEGA * r.tau))
            cj = 2 / T * integ(r.vt * np.cos(j * OMEGA * r.tau))
            assert obs.per_period["harmonic_amplitude"][k, j - 1] == pytest.approx(
                math.hypot(sj, cj), rel=1e-5, abs=1e-6 * amp)
        assert got["mean_deflection"] == pytest.approx(integ(deflection) / T, rel=1e-6, abs=1e-9 * amp)
        # Located extrema: never above the sampled ones, and within the sampling's O(h^2).
        # The sampled extremum misses the true one by at most |f''| (h/2)^2 / 2.
        vmin = r.vt[sl].min()
        assert got["min_gap"] <= vmin + 1e-15
        assert vmin - got["min_gap"] <= 2 * _sampling_gap(r.vt, sl, r.tau[1] - r.tau[0])
        fmax = force[sl].max()
        assert got["peak_force"] >= fmax - 1e-18
        assert got["peak_force"] - fmax <= 2 * _sampling_gap(-force, sl, r.tau[1] - r.tau[0])
        # Contact time and contacts from the located switches.
        edges = np.concatenate([[0.0], sw, [np.inf]])
        contact_time = 0.0
        for lo, hi in zip(edges[:-1], edges[1:]):
            mid = 0.5 * (lo + min(hi, r.tau[-1]))
            i = int(np.searchsorted(r.tau, mid))
            if r.contact[min(i, r.tau.size - 1)] == 1:
                contact_time += max(0.0, min(hi, b) - max(lo, a))
        assert got["contact_time"] == pytest.approx(contact_time, abs=1e-9)
        assert got["contacts_per_period"] == np.count_nonzero((starts >= a) & (starts < b))
        work = {name: integ(flow[name]) for name in tmafm.POWER_NAMES}
        scale = abs(work["drive"]) + abs(work["beam_damping"])
        assert got["dissipated_beam"] == pytest.approx(-work["beam_damping"], abs=1e-5 * scale)
        assert got["dissipated_contact_damping"] == pytest.approx(-work["contact_damping"],
                                                                  abs=1e-5 * scale)
        assert got["dissipated_friction"] == pytest.approx(-work["contact_friction"], abs=1e-5 * scale)
        assert got["drive_work"] == pytest.approx(work["drive"], abs=1e-5 * scale)
        assert got["contact_normal_work"] == pytest.approx(work["contact_normal"], abs=1e-5 * scale)
        assert got["dissipated_energy"] == pytest.approx(
            got["dissipated_beam"] + got["dissipated_contact_damping"] + got["dissipated_friction"])
        virial = integ(force * u) / T
        assert got["virial"] == pytest.approx(virial, rel=1e-5, abs=1e-6 * abs(virial))
        # The Poincare point is the state at k T.
        state = np.concatenate([r.a[(k + 1) * PER_PERIOD], r.adot[(k + 1) * PER_PERIOD]])
        np.testing.assert_allclose(obs.poincare[k + 1], state, rtol=0, atol=1e-9 * np.abs(state).max())


def _refined_max(f, fdot, tau, inside, bounds, i):
    """The oracle's max of a sampled f over the samples `inside` (one phase of one period),
    refined from its best sample i: the parabola's vertex through i - 1, i, i + 1 when all three
    lie inside; else i is next to a switch or a period boundary (the part's end, between
    samples), and the max of f's Taylor parabola at i (slope fdot[i], curvature from the slopes
    on the inner side) between the inner neighbour and that end.  Error O(h^3)."""
    h = tau[1] - tau[0]
    if inside[i - 1] and inside[i + 1]:
        curve = f[i + 1] - 2 * f[i] + f[i - 1]
        return f[i] - (f[i + 1] - f[i - 1]) ** 2 / (8 * curve) if curve < 0 else f[i]
    step = 1 if not inside[i + 1] else -1
    if not inside[i - step]:
        return f[i]                                      # a part of a single sample
    lo, hi = sorted((tau[i], tau[i + step]))
    ends = bounds[(bounds > lo) & (bounds < hi)]
    end = (ends[0] if ends.size else tau[i + step]) - tau[i]
    curve = step * (fdot[i] - fdot[i - step]) / h
    parabola = lambda s: f[i] + fdot[i] * s + 0.5 * curve * s * s
    candidates = [parabola(-step * h), f[i], parabola(end)]
    if curve < 0 and min(-step * h, end) <= -fdot[i] / curve <= max(-step * h, end):
        candidates.append(parabola(-fdot[i] / curve))
    return max(candidates)


def test_located_extrema_match_a_dense_oracle(fig3_pair):
    """max V_T and each mode's max and min in contact and out of contact, per period: never
    inside the sampled ones (they are located between samples), and equal to the refined
    extrema of the finely sampled tight run (refined between samples, every candidate sample
    tried) within a small fraction of what its sampling alone may miss."""
    obs, r = fig3_pair
    p = obs.per_period
    n = r.n_modes
    h = r.tau[1] - r.tau[0]
    assert p["max_gap"].shape == (PERIODS,)
    for name in ("modal_max_contact", "modal_min_contact", "modal_max_free", "modal_min_free"):
        assert p[name].shape == (PERIODS, n)
    accel = np.abs(np.diff(r.adot, axis=0)).max(axis=0) / h     # max |a_j''| over the run
    bounds = np.concatenate([np.asarray(r.switches, dtype=float), T * np.arange(PERIODS + 1)])
    for k in range(1, PERIODS):
        sl = slice(k * PER_PERIOD, (k + 1) * PER_PERIOD + 1)
        vmax = r.vt[sl].max()
        assert p["max_gap"][k] >= vmax - 1e-15
        assert p["max_gap"][k] - vmax <= 2 * _sampling_gap(-r.vt, sl, h)
        in_period = np.zeros(r.tau.size, dtype=bool)
        in_period[sl] = True
        for phase, flag in (("contact", 1), ("free", 0)):
            inside = in_period & (r.contact == flag)
            assert inside.any()        # fig3 touches the sample every period
            for j in range(n):
                slack = 1e-12 * np.abs(r.a[:, j]).max()
                for sign, name in ((1.0, f"modal_max_{phase}"), (-1.0, f"modal_min_{phase}")):
                    got = sign * p[name][k, j]
                    f, fdot = sign * r.a[:, j], sign * r.adot[:, j]
                    i = int(np.flatnonzero(inside)[np.argmax(f[inside])])
                    assert got >= f[i] - slack, (k, phase, j, sign)
                    # Every sample that beats its neighbours inside the part may hold the max.
                    g = np.where(inside, f, -np.inf)
                    peaks = np.flatnonzero(inside[1:-1] & (g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:])) + 1
                    oracle = max(_refined_max(f, fdot, r.tau, inside, bounds, q) for q in peaks)
                    # The oracle's refinement errs by O(h^3 max|third derivative|): far below
                    # this sixteenth of what the samples alone may miss (h^2 max|a_j''|).
                    assert abs(got - oracle) <= h ** 2 * accel[j] / 16 + slack, (k, phase, j, sign)


def test_modal_amplitudes_come_from_the_located_extrema(fig3_pair):
    """analysis.modal_amplitudes and summary's vt_max use the core's located extrema over the
    analysed whole periods, which contain the sampled ones."""
    _, r = fig3_pair
    since = T
    amps = analysis.modal_amplitudes(r, since=since)
    obs = analysis.observation(r)
    rows = slice(1, obs.periods)
    for phase, flag in (("contact", 1), ("free", 0)):
        high = obs.per_period[f"modal_max_{phase}"][rows].max(axis=0)
        low = obs.per_period[f"modal_min_{phase}"][rows].min(axis=0)
        np.testing.assert_array_equal(amps[phase]["half_peak_to_peak"], 0.5 * (high - low))
        np.testing.assert_array_equal(amps[phase]["max_abs"], np.maximum(np.abs(high), np.abs(low)))
        a = r.a[(r.tau >= since) & (r.contact == flag)]
        assert np.all(np.asarray(amps[phase]["max_abs"]) >= np.abs(a).max(axis=0) * (1 - 1e-12))
    assert analysis.vt_max(r, since) == obs.per_period["max_gap"][rows].max()
    assert analysis.vt_max(r, since) >= r.vt[r.tau >= since].max() - 1e-15


def test_energy_balance_closes_over_each_period(fig3_pair):
    """Drive work + normal contact work - dissipation = change of the modal energy."""
    obs, r = fig3_pair
    flow = analysis.energy_flow(r)
    for k in range(1, PERIODS):
        p = obs.per_period
        change = flow["energy"][(k + 1) * PER_PERIOD] - flow["energy"][k * PER_PERIOD]
        balance = p["drive_work"][k] + p["contact_normal_work"][k] - p["dissipated_energy"][k]
        assert balance == pytest.approx(change, abs=1e-7 * p["drive_work"][k])


def test_classifier_on_synthetic_sequences():
    rng = np.random.default_rng(1)
    a, b, c = np.array([1.0, 0.2]), np.array([-0.5, 0.7]), np.array([0.3, -0.9])
    two = np.array([a if n % 2 == 0 else b for n in range(12)]) + 1e-10 * rng.standard_normal((12, 2))
    assert steady_period(two, p_max=8, tol=1e-6, repeats=3) == 2
    three = np.array([(a, b, c)[n % 3] for n in range(15)])
    assert steady_period(three, p_max=8, tol=1e-6, repeats=3) == 3
    assert steady_period(three, p_max=2, tol=1e-6, repeats=3) == 0     # beyond p_max
    fixed = np.array([2.0, -1.0])
    decaying = np.array([fixed + 0.5 ** n * np.array([1.0, 1.0]) for n in range(40)])
    assert steady_period(decaying[:12], tol=1e-6) == 0      # still a transient (0.5^11 > 1e-6)
    assert steady_period(decaying[:40], tol=1e-6) == 1      # 0.5^36 < 2e-6
    # A decaying flip transient, P_n = P + (-0.9)^n v, repeats every 2 periods (within tol)
    # from n ~ 111 on, every period only from n ~ 132: it is never period 2.
    flip = np.array([fixed + (-0.9) ** n * np.array([1.0, 0.5]) for n in range(140)])
    assert steady_period(flip[:120], tol=1e-6) == 0
    assert steady_period(flip, tol=1e-6) == 1
    assert steady_period(rng.standard_normal((30, 3)), tol=1e-6) == 0
    assert steady_period(two[:4], repeats=3) == 0           # too short to confirm p = 2


def test_early_stop_matches_a_long_run():
    """fig4a: the stop at the first steady state gives the observables of a 300-period run."""
    early = tmafm.observe("fig4a", max_periods=300, steady_tol=1e-8, solver={"method": "dop853"})
    assert early.steady and 1 <= early.period <= 8 and early.periods < 300
    long = tmafm.observe("fig4a", max_periods=300, stop_at_steady=False,
                         solver={"method": "dop853"})
    assert long.periods == 300 and long.period == early.period
    e, l_ = early.steady_values(), long.steady_values()
    for name in OBSERVABLES:
        scale = max(abs(l_[name]), 1e-12) if name != "phase" else 180
        assert e[name] == pytest.approx(l_[name], abs=1e-5 * scale), name
    np.testing.assert_array_equal(early.per_period["amplitude"],
                                  long.per_period["amplitude"][:early.periods])


def test_one_and_two_threads_are_bit_identical():
    configs = [tmafm.Config("fig3", scene={"delta_hat": d}, solver={"method": m})
               for d in (0.0, 1e-4, -1e-4) for m in ("dopri5", "flight_exact")]
    one = tmafm.observe_batch(configs, threads=1, max_periods=12)
    two = tmafm.observe_batch(configs, threads=2, max_periods=12)
    for x, y in zip(one, two):
        assert (x.periods, x.period) == (y.periods, y.period)
        for name in x.per_period:
            np.testing.assert_array_equal(x.per_period[name], y.per_period[name])
        np.testing.assert_array_equal(x.poincare, y.poincare)
    # The batch gives what the single runs give.
    single = tmafm.observe(configs[1], max_periods=12)
    np.testing.assert_array_equal(single.per_period["virial"], one[1].per_period["virial"])


def _physical_scales(phys):
    """Oracle: the scales of Eq. (10)-(12) from the &physical values, written out here."""
    inertia = phys["width"] * phys["thickness"] ** 3 / 12
    ei = phys["youngs_modulus_tip"] * inertia
    m = phys["density"] * phys["width"] * phys["thickness"]
    L, d = phys["length"], phys["gap"]
    return {"nm": d * 1e9, "us": math.sqrt(m * L ** 4 / ei) * 1e6, "nN": ei / L ** 2 * 1e9,
            "aJ": ei * d ** 2 / L ** 3 * 1e18, "virial_aJ": ei / L ** 2 * d * 1e18}


def test_physical_units_are_the_scales_of_eq12():
    config = tmafm.Config("physical_polystyrene", solver={"method": "dop853"})
    obs = tmafm.observe(config, max_periods=6, stop_at_steady=False)
    scales = _physical_scales(config.to_dict()["physical"])
    unit_factor = {"nm": scales["nm"], "us": scales["us"], "nN": scales["nN"], "deg": 1.0, "1": 1.0,
                   "aJ": scales["aJ"]}
    assert obs.physical is not None
    for name in OBSERVABLES:
        unit = obs.physical_units[name]
        factor = scales["virial_aJ"] if name == "virial" else unit_factor[unit]
        np.testing.assert_allclose(obs.physical[name], obs.per_period[name] * factor, rtol=1e-12)
    np.testing.assert_allclose(obs.physical["harmonic_amplitude"],
                               obs.per_period["harmonic_amplitude"] * scales["nm"], rtol=1e-12)
    # The drive period in physical time is 2 pi / omega.
    omega = config.to_dict()["physical"]["drive_angular_frequency"]
    assert T * scales["us"] == pytest.approx(2 * math.pi / omega * 1e6, rel=1e-9)
    # A dimensionless input has no physical values.
    assert tmafm.observe("fig3", max_periods=2).physical is None


def test_rk4_paper_is_observed_with_its_own_steps():
    """The paper's scheme is fed step by step (its Hermite output): contact time is a whole
    number of contact steps, and the energy balance holds to the scheme's accuracy."""
    obs = tmafm.observe("fig3", max_periods=10, stop_at_steady=False)
    h = 2e-3 / 16
    steps = obs.per_period["contact_time"][1:] / h
    # Contacts begin at step starts; a period boundary may cut a step.
    assert obs.per_period["contacts_per_period"][-1] >= 1
    assert np.all(steps > 0)
    dop = tmafm.observe("fig3", max_periods=10, stop_at_steady=False, solver={"method": "dop853"})
    assert obs.per_period["amplitude"][-1] == pytest.approx(dop.per_period["amplitude"][-1], rel=1e-2)


def test_bad_arguments_raise_typed_errors():
    with pytest.raises(tmafm.InputError, match="rk4_event"):
        tmafm.observe("fig3", solver={"method": "rk4_event"}, max_periods=2)
    with pytest.raises(tmafm.InputError, match="max_periods"):
        tmafm.observe("fig3", max_periods=0)
    with pytest.raises(tmafm.InputTypeError):
        tmafm.observe("fig3", harmonics=2.5)
    with pytest.raises(tmafm.InputError, match="steady_tol"):
        tmafm.observe("fig3", steady_tol=0)
    with pytest.raises(tmafm.InputError, match="omega"):
        tmafm.observe("fig3", scene={"omega": 0.0}, max_periods=2)
    with pytest.raises(tmafm.InputTypeError):
        tmafm.observe_batch("fig3")
    assert tmafm.observe_batch([]) == []


# --- Observable groups (observables=) and runs from many states (observe_states) -----------

import importlib  # noqa: E402

observe_module = importlib.import_module("tmafm.observe")
FIG4 = tmafm.Config("fig4a", solver={"method": "flight_exact", "rtol": 1e-8})


@pytest.mark.parametrize("method", ["dop853", "flight_exact", "rk4_paper"])
def test_each_group_alone_gives_the_full_runs_values(method):
    solver = {"method": method} if method != "rk4_paper" else {"method": method, "dtau": 4e-3}
    full = tmafm.observe("fig3", solver=solver, max_periods=6, stop_at_steady=False)
    none = tmafm.observe("fig3", solver=solver, max_periods=6, stop_at_steady=False,
                         observables=())
    # The Poincare points and the always-computed columns do not depend on the groups.
    np.testing.assert_array_equal(none.poincare, full.poincare)
    assert set(none.per_period) == {"contact_time", "contacts_per_period"}
    for name in none.per_period:
        np.testing.assert_array_equal(none.per_period[name], full.per_period[name])
    for group, members in observe_module.OBSERVABLE_GROUPS.items():
        alone = tmafm.observe("fig3", solver=solver, max_periods=6, stop_at_steady=False,
                              observables=[group])
        np.testing.assert_array_equal(alone.poincare, full.poincare)
        assert set(alone.per_period) == set(members) | {"contact_time", "contacts_per_period"}
        for name in members:
            assert np.all(np.isfinite(alone.per_period[name])) or name.startswith("modal_")
            np.testing.assert_array_equal(alone.per_period[name], full.per_period[name])


def test_an_observable_name_selects_its_group_and_bad_names_are_refused():
    assert observe_module.observable_groups(["amplitude", "virial"]) == ("lockin", "energy")
    assert observe_module.observable_groups(None) == tuple(observe_module.OBSERVABLE_GROUPS)
    assert observe_module.observable_groups(["poincare", "contact_time"]) == ()
    with pytest.raises(tmafm.InputError, match="amplitud"):
        tmafm.observe("fig3", solver={"method": "dop853"}, max_periods=2, observables=["amplitud"])
    with pytest.raises(tmafm.InputTypeError):
        tmafm.observe("fig3", solver={"method": "dop853"}, max_periods=2, observables=[3])


def _states(n=5):
    rng = np.random.default_rng(7)
    states = np.zeros((n, 6))
    states[:, 0] = rng.uniform(-1e-3, 1e-3, n)
    states[:, 3] = rng.uniform(-2e-3, 2e-3, n)
    return states


def test_observe_states_equals_observe_batch_on_the_same_inputs():
    states = _states()
    out = observe_module.observe_states(FIG4, states, threads=2)
    configs = [tmafm.Config(FIG4, initial={"a0": s[:3].tolist(), "adot0": s[3:].tolist()})
               for s in states]
    batch = tmafm.observe_batch(configs, threads=1)
    for k, obs in enumerate(batch):
        assert out.periods[k] == obs.periods and out.period[k] == obs.period
        np.testing.assert_array_equal(out.orbit[k, -1], obs.final_state)
        steady = obs.steady_values()
        for name in OBSERVABLES:
            assert out.steady[name][k] == pytest.approx(steady[name], rel=1e-14, abs=1e-300)
    assert np.all(out.attractor == -1) and not out.failed.any()


def test_observe_states_stops_at_a_known_attractor_and_only_there():
    states = _states()
    free = observe_module.observe_states(FIG4, states, threads=2, observables=())
    # The attractor: one run followed 60 periods.
    long = observe_module.observe_states(FIG4, states[:1], observables=(), max_periods=60,
                                         stop_at_steady=False)
    orbit = long.orbit[0, -1:]
    size = np.max(np.abs(orbit))
    known = observe_module.observe_states(FIG4, states, threads=2, observables=(),
                                          attractors=[orbit], capture=1e-3)
    assert np.all(known.attractor == 0) and np.all(known.period == 1)
    assert np.all(known.periods < free.periods)
    # Stopped only once the last `confirm` (= steady_repeats = 3) points were within the
    # capture radius of the orbit: each run's final point is.
    assert np.all(np.max(np.abs(known.orbit[:, -1] - orbit), axis=1) <= 1e-3 * size)
    # The same runs, period by period: the points before the stop are those of the free runs.
    for k in range(len(states)):
        m = known.periods[k]
        np.testing.assert_allclose(known.orbit[k, -1], _point(states[k], m), rtol=0,
                                   atol=1e-9 * size)
    # An orbit far from every run's attractor stops none of them.
    far = observe_module.observe_states(FIG4, states, threads=2, observables=(),
                                        attractors=[orbit * 1.5], capture=1e-3)
    assert np.all(far.attractor == -1)
    np.testing.assert_array_equal(far.periods, free.periods)
    np.testing.assert_array_equal(far.orbit, free.orbit)


def _point(state, m):
    """The Poincare point after m periods of a run from `state` that never stops early."""
    run = observe_module.observe_states(FIG4, state[None, :], observables=(), max_periods=int(m),
                                        stop_at_steady=False)
    return run.orbit[0, -1]


def test_observe_states_refuses_bad_states_and_options_before_any_run():
    states = _states(2)
    bad = states.copy()
    bad[1, 0] = 1.5
    with pytest.raises(tmafm.InputError, match="state 2 component 1"):
        observe_module.observe_states(FIG4, bad)
    with pytest.raises(tmafm.InputError, match="shape"):
        observe_module.observe_states(FIG4, states[:, :4])
    with pytest.raises(tmafm.InputError, match="capture"):
        observe_module.observe_states(FIG4, states, attractors=[states[:1]], capture=2.0)
    with pytest.raises(tmafm.InputTypeError, match="confirm"):
        observe_module.observe_states(FIG4, states, attractors=[states[:1]], confirm=0)
