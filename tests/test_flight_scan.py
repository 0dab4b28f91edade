"""The exact flight's contact scan (tmafm_flight first_contact): scan points one ladder step
apart are computed by turning the previous point's terms by tabulated exp(lambda h_k) instead
of calling exp, sin and cos, with a rounding allowance taken off G before an interval is
cleared.  Here the scan as the run loop makes it (direct evaluation every 16 points) is held
to the scan with every point evaluated directly: the same first contact, or the same absence
of one, over long flights and flights that graze the sample by far less than the gap's size.
"""

import math

import numpy as np
import pytest

from testcore import core as _core

from conftest import INPUTS, write_nml
from scenes import grazing_scene as grazing_scene_dict  # studies/scenes.py (conftest's sys.path)

EPS = np.finfo(float).eps
PERIOD = math.pi           # 2 pi / Omega, Omega = 2


def scan(path, n_modes, tau0, y0, s_max, anchor):
    found, s_contact, evaluations, ierr, errmsg = _core.flight_scan(
        str(path), tau0, np.asarray(y0, dtype=float), s_max, anchor, n_modes=n_modes)
    assert ierr == 0, errmsg
    return bool(found), s_contact, evaluations


def both_scans(path, n_modes, tau0, y0, s_max):
    """(found, s_contact, evaluations) as the run loop scans, and with every point direct."""
    return scan(path, n_modes, tau0, y0, s_max, 0), scan(path, n_modes, tau0, y0, s_max, 1)


def assert_same_contact(turned, direct, tau0, noise=0.0):
    """The same contact or none; the located times agree to Brent's 4 eps |tau| from each
    side, plus `noise`: where V_T crosses zero slowly its own rounding moves the root."""
    assert turned[0] == direct[0]
    if turned[0]:
        assert abs(turned[1] - direct[1]) <= 8 * EPS * (tau0 + direct[1]) + noise, (turned, direct)


@pytest.fixture(scope="module")
def orbit():
    """A 2-mode beam on its periodic free orbit (studies/scenes.py's grazing_scene) and the depth
    of the sample below the orbit's lowest V_T there: delta_hat = dip - depth."""
    scene = grazing_scene_dict(depth=0.0)
    return scene, float(scene["scene"]["delta_hat"])


@pytest.mark.parametrize("depth", [1e-9, 1e-11, -1e-9, -1e-11])
def test_grazing_flight_finds_what_direct_evaluation_finds(tmp_path, orbit, depth):
    """The sample `depth` into the orbit's lowest point (negative: above it).  Above it the
    flight runs 200 periods without contact, grazing the sample once a period: thousands of
    turned points, each cleared with its allowance, and not one false contact; into it both
    scans locate the first dip to round-off.  At |depth| = 1e-11 the dip is 1e-8 of the
    orbit's V_T amplitude."""
    scene, dip = orbit
    groups = {g: dict(v) for g, v in scene.items()}
    groups["scene"]["delta_hat"] = dip - depth
    path = write_nml(tmp_path / "graze.nml", **groups)
    n = scene["model"]["n_modes"]
    y0 = scene["initial"]["a0"] + scene["initial"]["adot0"]
    turned, direct = both_scans(path, n, 0.0, y0, 200 * PERIOD)
    # V_T ~ |dip| cos(Omega s) near the dip: it crosses zero at a rate sqrt(2 depth 4 |dip|),
    # and its rounding (a few eps of each term, |dip| at most) moves the root by that over it.
    noise = 16 * EPS * abs(dip) / math.sqrt(8 * abs(depth * dip))
    assert_same_contact(turned, direct, 0.0, noise)
    assert turned[0] == (depth > 0)
    if depth > 0:
        assert turned[1] < PERIOD
    else:
        # A long scan (at least two points a period; 15 of 16 turned), none of them a contact.
        assert turned[2] > 400, turned


# A state as the Fig. 2 motion leaves a contact (a, a'), at tau0 = 300 (tests/test_sampling.py).
Y0 = np.array([-2.8e-4, 4.6e-5, 3.7e-6, -9.5e-7, -8.8e-4, -6.1e-4, 5.2e-5, 1.8e-5])


@pytest.mark.parametrize("alpha3", [0.4, 0.05, 0.0])
@pytest.mark.parametrize("delta_hat", [0.0, 5e-4, 1.0])
def test_fig2_flights_find_what_direct_evaluation_finds(tmp_path, alpha3, delta_hat):
    """Fig. 2's 4-mode beam from a contact exit at tau0 = 300, damped, lightly damped and
    undamped (terms that never decay: the allowance's lambda s share grows along the
    flight), with the sample at the rest position, halfway down the swing, and out of
    reach for 200 periods."""
    path = write_nml(tmp_path / "fig2.nml", base=INPUTS / "fig2_n4.nml",
                     scene={"alpha3": alpha3, "delta_hat": delta_hat})
    turned, direct = both_scans(path, 4, 300.0, Y0, 200 * PERIOD)
    assert_same_contact(turned, direct, 300.0)
    if delta_hat == 1.0:
        assert not turned[0]
    else:
        assert turned[0]

