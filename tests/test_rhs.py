"""The right-hand side kernel (tmafm_model) and the free-flight scan (tmafm_flight).

The reference file tests/data/rhs_reference.npz holds the right-hand side of the code as it
was before the kernel was rewritten (tests/data/make_rhs_reference.py says how it was made).
"""

import math
from pathlib import Path

import f90nml
import numpy as np
import pytest

import tmafm
from testcore import core as _core

import scenes  # studies/scenes.py (conftest's sys.path)

DATA = Path(__file__).resolve().parent / "data" / "rhs_reference.npz"
SCENES = ({}, {"xi0": 0.8, "theta": 0.2, "alpha4": 0.0})   # as in make_rhs_reference.py

# Tolerance against the old kernel, norm-wise per case.  Each acceleration is a sum of at
# most 2N + 4 <= 64 products (the B pass, the drive, the tip and moment terms), summed in a
# different order and with differently rounded coefficients (-alpha3 M^-1 folded at set-up,
# sin theta1 from the slope algebraically instead of through atan).  Recursive summation of
# k terms errs by at most k u sum|terms| (u = 1.1e-16), and the same holds for the old code,
# so two evaluations differ by at most 2 k u sum|terms| <= 1.4e-14 sum|terms|, which is
# attained only if every rounding has the same sign; as a random walk the bound is
# ~2 sqrt(k) u ~ 2e-15.  sum|terms| / |result| is ~1 at these random states (no
# cancellation: the largest term, beta_N^4 a_N, dominates).  1e-14 is therefore a bound
# that the reordering cannot reach, while any wrong term (a dropped product, a swapped
# sign, a wrong phase) moves the result by far more than that.
REFERENCE_RTOL = 1e-14


def _reference_cases():
    with np.load(DATA) as npz:
        d = {key: npz[key] for key in npz.files}
    offsets = np.concatenate([[0], np.cumsum(d["n"])])
    for k, n in enumerate(d["n"]):
        yield dict(n=int(n), convention=str(d["convention"][k]), law=str(d["law"][k]),
                   in_contact=bool(d["in_contact"][k]), scene=int(d["scene"][k]),
                   tau=float(d["tau"][k]),
                   a=d["a"][offsets[k]:offsets[k + 1]],
                   adot=d["adot"][offsets[k]:offsets[k + 1]],
                   rate=d["rate"][2 * offsets[k]:2 * offsets[k + 1]])


def _write_case(tmp_path, n, convention, law, scene_index):
    path = tmp_path / f"case_{n}_{convention}_{law}_{scene_index}.nml"
    if not path.exists():
        groups = {"model": {"n_modes": n, "convention": convention, "contact_law": law}}
        if SCENES[scene_index]:
            groups["scene"] = dict(SCENES[scene_index])
        f90nml.write(f90nml.Namelist(groups), str(path), force=True)
    return path


def test_reference_covers_every_combination():
    cases = list(_reference_cases())
    assert len(cases) == 960
    keys = {(c["n"], c["convention"], c["law"], c["in_contact"], c["scene"]) for c in cases}
    assert len(keys) == 30 * 2 * 2 * 2 * 2
    contact = [c for c in cases if c["in_contact"]]
    # In contact the force is on: the reference accelerations differ from the free ones.
    assert all(np.any(c["rate"][c["n"]:] != 0) for c in contact)


def test_derivative_equals_the_old_kernel(tmp_path):
    worst = 0.0
    for case in _reference_cases():
        path = _write_case(tmp_path, case["n"], case["convention"], case["law"], case["scene"])
        *_, rate, ierr, errmsg = _core.model_terms(str(path), case["tau"], case["a"],
                                                   case["adot"], case["in_contact"])
        assert ierr == 0, errmsg
        error = np.linalg.norm(rate - case["rate"]) / np.linalg.norm(case["rate"])
        worst = max(worst, error)
        assert error <= REFERENCE_RTOL, (case["n"], case["convention"], case["law"],
                                         case["in_contact"], case["scene"], error)
    print(f"largest relative difference from the old kernel: {worst:.2e}")


def test_rates_at_phase_and_gap_equal_the_old_kernel(tmp_path):
    """derivative_at_phase and derivative_and_gap (the forms the pairs and the switch search call;
    N <= 4 and N > 4 take different code) give the old kernel's rate at every reference case,
    and derivative_and_gap's V_T and dV_T/dtau are p.a + alpha2 sin(Omega tau) + delta_hat and
    p.a' + alpha2 Omega cos(Omega tau), both phases, for N = 1..30.  The gap is a sum of N + 2
    terms, so two summation orders differ by at most 2 (N + 2) u sum|terms| <= 1.5e-14 sum|terms|."""
    scene_values = {}
    modes_seen = set()
    for case in _reference_cases():
        n = case["n"]
        path = _write_case(tmp_path, n, case["convention"], case["law"], case["scene"])
        rate, rate_with_gap, vt, vtdot, ierr, errmsg = _core.model_rates_at_phase(
            str(path), case["tau"], case["a"], case["adot"], case["in_contact"])
        assert ierr == 0, errmsg
        for got in (rate, rate_with_gap):
            error = np.linalg.norm(got - case["rate"]) / np.linalg.norm(case["rate"])
            assert error <= REFERENCE_RTOL, (n, case["convention"], case["law"],
                                             case["in_contact"], case["scene"], error)
        if case["scene"] not in scene_values:
            scene = tmafm.Config(path).scene
            scene_values[case["scene"]] = {k: scene[k] for k in ("alpha2", "omega", "delta_hat", "xi0")}
        sv = scene_values[case["scene"]]
        tip = _core.modes(n, np.array([sv["xi0"]]), 0)[1][0]
        phase = sv["omega"] * case["tau"]
        terms = np.concatenate([tip * case["a"], [sv["alpha2"] * math.sin(phase), sv["delta_hat"]]])
        rate_terms = np.concatenate([tip * case["adot"],
                                     [sv["alpha2"] * sv["omega"] * math.cos(phase)]])
        assert abs(vt - terms.sum()) <= 1.5e-14 * np.abs(terms).sum(), (n, vt, terms.sum())
        assert abs(vtdot - rate_terms.sum()) <= 1.5e-14 * np.abs(rate_terms).sum(), (n, vtdot)
        modes_seen.add(n)
    assert modes_seen == set(range(1, 31))


# M is I + alpha1 m m^T with |m|^2 <= 4N, so cond(M) <= 1 + 0.05 * 4 * 30 = 7, and numpy's
# solve errs by ~cond(M) N u relative to |F| + |C a'| + |K a|, ~3e-14 at N = 30; the kernel
# errs by ~2N u (see above).  1e-12 norm-wise leaves a factor 30 above both.
EXPLICIT_RTOL = 1e-12


@pytest.mark.parametrize("convention", ["paper", "consistent"])
def test_derivative_is_the_solution_of_the_explicit_system(tmp_path, convention):
    """a'' = M^-1 (F - C a' - K a) with M, C, K, F from model%matrices, for N = 1..30."""
    rng = np.random.default_rng(7)
    for n in range(1, 31):
        for law in ("hertz", "dmt"):
            path = tmp_path / f"{n}_{law}.nml"
            f90nml.write(f90nml.Namelist({"model": {"n_modes": n, "convention": convention,
                                                    "contact_law": law},
                                          "scene": {"xi0": 0.9, "theta": 0.3}}),
                         str(path), force=True)
            tip = _core.modes(n, np.array([0.9]), 0)[1][0]
            for in_contact in (False, True):
                j = np.arange(1, n + 1)
                tau = rng.uniform(0, 10)
                a = 1e-3 * rng.uniform(-1, 1, n) / j**2
                adot = 1e-2 * rng.uniform(-1, 1, n) / j
                if in_contact:      # V_T = -1e-4
                    a[0] -= (tip @ a + 5e-4 * math.sin(2 * tau) + 1e-4) / tip[0]
                mass, damping, stiffness, force, rate, ierr, errmsg = _core.model_terms(
                    str(path), tau, a, adot, in_contact)
                assert ierr == 0, errmsg
                expected = np.linalg.solve(mass, force - damping @ adot - stiffness @ a)
                np.testing.assert_array_equal(rate[:n], adot)
                error = np.linalg.norm(rate[n:] - expected) / np.linalg.norm(expected)
                assert error <= EXPLICIT_RTOL, (n, law, in_contact, error)
                if in_contact:      # the contact terms are really on
                    free = _core.model_terms(str(path), tau, a, adot, False)[4]
                    assert np.linalg.norm(free[n:] - rate[n:]) > 1e3 * EXPLICIT_RTOL * np.linalg.norm(expected)


def test_rates_and_gap_with_an_offset_sample(tmp_path):
    """With delta_hat != 0 (the reference scenes have none): V_T of derivative_and_gap includes
    it, and derivative, derivative_at_phase and derivative_and_gap all give the solution of the
    explicit system (model%matrices, whose contact state forms V_T on its own), free and in
    contact, N = 1..30 (N <= 4 and N > 4 take different code)."""
    rng = np.random.default_rng(11)
    alpha2, omega, delta_hat = 7e-4, 2.0, -3e-4
    for n in range(1, 31):
        path = tmp_path / f"offset_{n}.nml"
        f90nml.write(f90nml.Namelist({"model": {"n_modes": n},
                                      "scene": {"xi0": 0.9, "theta": 0.3, "alpha2": alpha2,
                                                "omega": omega, "delta_hat": delta_hat}}),
                     str(path), force=True)
        tip = _core.modes(n, np.array([0.9]), 0)[1][0]
        j = np.arange(1, n + 1)
        for in_contact in (False, True):
            tau = rng.uniform(0, 10)
            a = 1e-4 * rng.uniform(-1, 1, n) / j**2
            adot = 1e-3 * rng.uniform(-1, 1, n) / j
            if in_contact:      # V_T = -1e-4
                a[0] -= (tip @ a + alpha2 * math.sin(omega * tau) + delta_hat + 1e-4) / tip[0]
            rate, rate_with_gap, vt, vtdot, ierr, errmsg = _core.model_rates_at_phase(
                str(path), tau, a, adot, in_contact)
            assert ierr == 0, errmsg
            mass, damping, stiffness, force, rate_tau, ierr, errmsg = _core.model_terms(
                str(path), tau, a, adot, in_contact)
            assert ierr == 0, errmsg
            expected = np.linalg.solve(mass, force - damping @ adot - stiffness @ a)
            for got in (rate, rate_with_gap, rate_tau):
                np.testing.assert_array_equal(got[:n], adot)
                error = np.linalg.norm(got[n:] - expected) / np.linalg.norm(expected)
                assert error <= EXPLICIT_RTOL, (n, in_contact, error)
            terms = np.concatenate([tip * a, [alpha2 * math.sin(omega * tau), delta_hat]])
            rate_terms = np.concatenate([tip * adot, [alpha2 * omega * math.cos(omega * tau)]])
            assert abs(vt - terms.sum()) <= 1.5e-14 * np.abs(terms).sum(), (n, vt, terms.sum())
            assert abs(vtdot - rate_terms.sum()) <= 1.5e-14 * np.abs(rate_terms).sum(), (n, vtdot)
            if in_contact:
                assert abs(vt + 1e-4) < 1e-12


# The stage nodes of dop853 (stages 2-12 and the dense-output stages 14-16) and of dopri5.
DOP853_NODES = [0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726,
                1 / 3, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0,
                0.1, 0.2, 0.7777777777777778]
DOPRI5_NODES = [0.2, 0.3, 0.8, 8 / 9, 1.0]
TAYLOR_LIMIT = 1.0   # tmafm_embedded_pair taylor_limit: |Omega c h| up to this is summed


@pytest.mark.parametrize("nodes", [DOP853_NODES, DOPRI5_NODES])
def test_stage_phases_agree_with_libm(tmp_path, nodes):
    """sin and cos of Omega (tau + c h) from one sincos per step, the Taylor series of Omega c h
    and angle addition agree with libm at the rounded phase Omega (tau + c h).

    That phase is itself rounded twice (tau + c h and the product with Omega), so the two
    arguments differ by up to ~2 ulp of the phase; the Taylor sums and the angle addition add
    a few eps.  Bound: 4 ulp(phase) + 8 eps (3.5e-15 at tau = 0).  At |Omega c h| = 1 a series
    one term short errs by 1/18! = 1.6e-16 (harmless, under the bound), two terms short by
    1/16! = 4.8e-14 (caught); a wrong node or sign errs by O(h)."""
    path = tmp_path / "omega.nml"
    f90nml.write(f90nml.Namelist({"model": {"n_modes": 3}}), str(path), force=True)
    omega = 2.0   # the default scene
    nodes = np.array(nodes)
    worst = 0.0
    for tau in (0.0, 1e-3, 0.7, 3.0, 123.456, 2.0e4):
        # Omega h max(c) from tiny to the Taylor limit, and beyond it (libm per node).
        for reach in (1e-9, 1e-3, 0.05, 0.3, 0.999 * TAYLOR_LIMIT, TAYLOR_LIMIT, 1.5, 7.0):
            h = reach / (omega * nodes.max())
            s, c, ierr, errmsg = _core.stage_phases(str(path), 3, tau, h, nodes)
            assert ierr == 0, errmsg
            phase = omega * (tau + nodes * h)
            bound = 4 * np.spacing(np.abs(phase)) + 8 * np.finfo(float).eps
            error = np.maximum(np.abs(s - np.sin(phase)), np.abs(c - np.cos(phase)))
            assert np.all(error <= bound), (tau, reach, error / bound)
            worst = max(worst, float(np.max(error / bound)))
    print(f"largest error / bound: {worst:.2f}")


REPO = Path(__file__).resolve().parent.parent


def flight_evaluations(result):
    """(flights, an upper bound on the V_T evaluations of their scans) from the counters.

    flight_exact counts one step per flight and every contact step as a contact step; each
    contact step, accepted or rejected, costs at least 12 right-hand sides (dop853 in
    contact), and everything else in rhs_evaluations is a V_T evaluation of a flight scan
    (or a dense-output stage, so this is an upper bound)."""
    c = result.counters
    flights = c["steps"] - c["contact_steps"]
    return flights, c["rhs_evaluations"] - 12 * (c["contact_steps"] + c["rejected_steps"])


def test_flight_scan_needs_few_evaluations():
    """The scan step comes from the fourth-derivative bound (about 30 evaluations per flight
    on Fig. 2 with the root refinement; a step per fastest time scale took about 560)."""
    # Samples far apart: few dense outputs of the contact steps count among the evaluations.
    result = tmafm.run(REPO / "inputs" / "fig2_n4.nml",
                       solver={"method": "flight_exact", "tau_end": 100.0, "rtol": 1e-10},
                       output={"sample_dtau": 50.0})
    flights, evaluations = flight_evaluations(result)
    assert flights > 50 and len(result.switches) > 100
    assert evaluations / flights < 40


@pytest.mark.parametrize("depth, contacts", [(1e-10, 10), (-1e-10, 0)])
def test_flight_scan_finds_every_graze_and_no_false_one(depth, contacts):
    """A sample 1e-10 (gap units) above the lowest point of the free orbit is touched once per
    period, for about 5e-4; 1e-10 below it is never touched."""
    scene = scenes.grazing_scene(depth=depth)
    result = tmafm.run(scene, solver={"method": "flight_exact", "tau_end": 10 * math.pi,
                                      "rtol": 1e-12, "atol": 1e-18},
                       output={"sample_dtau": 0.01})
    assert len(result.switches) == 2 * contacts
    if contacts:
        durations = result.switches[1::2] - result.switches[0::2]
        assert np.all(durations > 1e-4) and np.all(durations < 1e-3)
    flights, evaluations = flight_evaluations(result)
    assert evaluations / flights < 200


def test_flight_on_overflowing_scene_is_an_error_not_a_crash(run_exe, tmp_path):
    """A tip modulus of 1e-300 Pa makes Omega ~ 1e155: the free-beam equations overflow.
    LAPACK used to be handed infinities (XERBLA text, then a heap corruption abort)."""
    path = tmp_path / "tiny_modulus.nml"
    path.write_text("&physical youngs_modulus_tip = 1e-300 /\n"
                    "&solver method = 'flight_exact', tau_end = 1 /\n")
    done = run_exe(path, "-o", tmp_path / "out.dat")
    assert done.returncode in (2, 5), done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tmafm: error:"), done.stderr
    assert "flight_exact" in lines[0] or "&physical" in lines[0]
    assert not (tmp_path / "out.dat").exists()
