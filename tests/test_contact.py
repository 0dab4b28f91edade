"""Contact kinematics and forces (docs/model.md §6)."""

import math

import pytest

from testcore import core as _core

HERTZ, DMT = 1, 2
THETA, BETA, KAPPA5, KAPPA6 = math.pi / 12, 1.128e-4, 6.7665e-5, 0.7413


def state(vt, law, slope=0.0, signed=False):
    theta1, radius, normal, friction, p1, p2 = _core.contact_state(
        vt, slope, THETA, BETA, law, KAPPA5, KAPPA6, signed)
    return dict(theta1=theta1, radius=radius, normal=normal, friction=friction, p1=p1, p2=p2)


def test_hertz_force_is_continuous_at_contact():
    above = state(+1e-12, HERTZ)
    assert above["normal"] == 0 and above["p1"] == 0 and above["p2"] == 0
    previous = None
    for eps in (1e-6, 1e-8, 1e-10, 1e-12):
        below = state(-eps, HERTZ)
        # f_c ~ (eps sin theta1/beta)^(3/2) vanishes continuously.
        expected = (eps * math.sin(below["theta1"]) / BETA) ** 1.5
        assert below["normal"] == pytest.approx(expected, rel=1e-12)
        if previous is not None:
            assert abs(below["p1"]) < abs(previous["p1"])
        previous = below
    assert abs(state(-1e-12, HERTZ)["p1"]) < 1e-15


def test_dmt_jumps_by_the_pull_off():
    hertz, dmt = state(0.0, HERTZ), state(0.0, DMT)
    assert hertz["normal"] == 0.0
    assert dmt["normal"] == -4.0 / 3.0
    # The normal bracket kappa5 f_c jumps by exactly -4/3 kappa5, in both components.
    sin1, cos1 = math.sin(dmt["theta1"]), math.cos(dmt["theta1"])
    assert dmt["p1"] == pytest.approx(-4.0 / 3.0 * KAPPA5 * sin1, rel=1e-15)
    assert dmt["p2"] == pytest.approx(+4.0 / 3.0 * KAPPA5 * cos1, rel=1e-15)
    # With indentation, DMT is Hertz minus the same constant.
    for vt in (-1e-5, -1e-4):
        assert state(vt, DMT)["normal"] - state(vt, HERTZ)["normal"] == pytest.approx(-4 / 3, rel=1e-12)


def test_radius_friction_and_brackets_follow_their_definitions():
    vt = -2.0e-4
    s = state(vt, HERTZ)
    theta1 = math.pi / 2 - THETA
    radius = math.sqrt(-vt * math.sin(theta1) / BETA)
    friction = radius * (-vt * math.cos(theta1))
    assert s["theta1"] == pytest.approx(theta1, rel=1e-15)
    assert s["radius"] == pytest.approx(radius, rel=1e-14)
    assert s["friction"] == pytest.approx(friction, rel=1e-14)
    assert s["p1"] == pytest.approx(KAPPA5 * radius**3 * math.sin(theta1)
                                    + KAPPA6 * friction * math.cos(theta1), rel=1e-13)
    assert s["p2"] == pytest.approx(-KAPPA5 * radius**3 * math.cos(theta1)
                                    + KAPPA6 * friction * math.sin(theta1), rel=1e-13)


def test_contact_angle_printed_and_signed():
    for slope in (-3e-5, 3e-5):
        printed = state(-1e-4, HERTZ, slope, signed=False)["theta1"]
        signed = state(-1e-4, HERTZ, slope, signed=True)["theta1"]
        assert printed == pytest.approx(math.pi / 2 - THETA - math.atan(abs(slope)), rel=1e-15)
        assert signed == pytest.approx(math.pi / 2 - THETA + math.atan(slope), rel=1e-15)


@pytest.mark.parametrize("law", [HERTZ, DMT])
def test_force_groups_finite_difference_derivative(law):
    """d f_c / d V_T = -(3/2) A sin(theta1)/beta (the stiffness of the contact spring),
    checked by central differences: the contact stiffness behind the stability analysis."""
    theta1 = math.pi / 2 - THETA
    for vt in (-1e-5, -1e-4, -5e-4):
        h = 1e-7 * abs(vt)
        fd = (state(vt + h, law)["normal"] - state(vt - h, law)["normal"]) / (2 * h)
        radius = state(vt, law)["radius"]
        analytic = -1.5 * radius * math.sin(theta1) / BETA
        assert fd == pytest.approx(analytic, rel=1e-7)
