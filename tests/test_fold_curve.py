"""tmafm.continuation.fold_curve: a fold of periodic orbits continued in two keys by the
minimally augmented system (docs/continuation.md, section 5a), against one-parameter
continuations at fixed values of the second key, and its refusals."""

import warnings
from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import continuation as cont

BISTABLE = str(Path(__file__).resolve().parents[1] / "inputs" / "sweeps" / "bistable_n2.nml")
KEY, KEY2 = "scene.delta_hat", "scene.alpha2"


@pytest.fixture(scope="module")
def upper_fold():
    """The upper fold of bistable_n2's period-1 branch (delta_hat = 4.1295e-3 at alpha2 =
    5e-4), and its curve in (delta_hat, alpha2) up to alpha2 = 6e-4."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.ContinuationWarning)
        branch = cont.continuation(BISTABLE, KEY, 8e-3, 0.0, max_points=90, switch=False)
    k = int(np.flatnonzero(branch["label"].values == "fold")[1])
    assert abs(branch[KEY].values[k] - 4.1295e-3) < 1e-7
    curve = cont.fold_curve(BISTABLE, KEY2, branch.isel(point=k), 6e-4, max_points=60)
    return branch, k, curve


def test_fold_curve_agrees_with_one_parameter_folds(upper_fold):
    """At five points of the curve (alpha2 from 5e-4 to 6e-4), a one-parameter continuation in
    delta_hat at that alpha2, started 2e-5 below the fold from the curve's orbit, locates its
    fold at the curve's delta_hat to 1e-6 relative (both to tol = 1e-9 of the scaled
    unknowns)."""
    branch, k, curve = upper_fold
    assert curve["end_reason"].values[-1] == "stop"
    assert curve[KEY2].values[-1] >= 6e-4
    assert np.all(np.abs(curve["test_function"].values) < 1e-7)
    # The multiplier +1 all along: the fold's Floquet signature.
    mu = curve["multiplier_re"].values + 1j * curve["multiplier_im"].values
    assert np.all(np.min(np.abs(mu - 1), axis=1) < 1e-6)
    picks = np.linspace(0, curve.sizes["point"] - 1, 5).round().astype(int)
    for i in picks:
        lam, alpha2 = float(curve[KEY].values[i]), float(curve[KEY2].values[i])
        base = tmafm.Config(BISTABLE, scene={"alpha2": alpha2})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", tmafm.ContinuationWarning)
            one = cont.continuation(base, KEY, lam - 2e-5, lam + 2e-4,
                                    y0=curve["state"].values[i, 0], ds=0.02, max_points=60,
                                    switch=False)
        folds = one[KEY].values[one["label"].values == "fold"]
        assert len(folds) == 1, (alpha2, one["label"].values)
        assert abs(folds[0] - lam) <= 1e-6 * lam, (alpha2, folds[0], lam)


def test_fold_curve_starts_at_the_fold(upper_fold):
    branch, k, curve = upper_fold
    assert curve[KEY].values[0] == pytest.approx(float(branch[KEY].values[k]), rel=1e-9)
    assert curve[KEY2].values[0] == 5e-4
    assert curve.attrs["tmafm_kind"] == "fold_curve"


def test_fold_curve_refusals(upper_fold):
    branch, k, _ = upper_fold
    with pytest.raises(tmafm.InputError, match="not 'fold'"):
        cont.fold_curve(BISTABLE, KEY2, branch.isel(point=0), 6e-4)
    with pytest.raises(tmafm.InputError, match="key2"):
        cont.fold_curve(BISTABLE, KEY, branch.isel(point=k), 6e-4)
    with pytest.raises(tmafm.InputError, match="stop2"):
        cont.fold_curve(BISTABLE, KEY2, branch.isel(point=k), 5e-4)
    with pytest.raises(tmafm.InputTypeError):
        cont.fold_curve(BISTABLE, KEY2, branch, 6e-4, bogus=1)
    with pytest.raises(tmafm.InputTypeError):
        cont.fold_curve(BISTABLE, KEY2, branch.isel(point=k), 6e-4, direction=0)


@pytest.fixture(scope="module")
def doubling():
    """The first period doubling of bistable_n2's period-1 branch (delta_hat = 2.9985e-3 at
    alpha2 = 5e-4) and its curve in (delta_hat, alpha2) up to alpha2 = 5.5e-4."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tmafm.ContinuationWarning)
        branch = cont.continuation(BISTABLE, KEY, 8e-3, 0.0, max_points=50, switch=False)
    k = int(np.flatnonzero(branch["label"].values == "period_doubling")[0])
    assert abs(branch[KEY].values[k] - 2.9985e-3) < 1e-7
    curve = cont.period_doubling_curve(BISTABLE, KEY2, branch.isel(point=k), 5.5e-4,
                                       max_points=60)
    return branch, k, curve


def test_period_doubling_curve_agrees_with_one_parameter_doublings(doubling):
    """At five points of the curve, a one-parameter continuation in delta_hat at that alpha2
    from the curve's orbit, started 2e-5 above it, locates its doubling at the curve's
    delta_hat to 1e-6 relative; a multiplier at -1 all along the curve."""
    branch, k, curve = doubling
    assert curve["end_reason"].values[-1] == "stop" and curve.attrs["tmafm_kind"] == \
        "period_doubling_curve"
    mu = curve["multiplier_re"].values + 1j * curve["multiplier_im"].values
    assert np.all(np.min(np.abs(mu + 1), axis=1) < 1e-6)
    picks = np.linspace(0, curve.sizes["point"] - 1, 5).round().astype(int)
    for i in picks:
        lam, alpha2 = float(curve[KEY].values[i]), float(curve[KEY2].values[i])
        base = tmafm.Config(BISTABLE, scene={"alpha2": alpha2})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", tmafm.ContinuationWarning)
            one = cont.continuation(base, KEY, lam + 2e-5, lam - 2e-4,
                                    y0=curve["state"].values[i, 0], max_points=40, switch=False)
        pds = one[KEY].values[one["label"].values == "period_doubling"]
        assert len(pds) == 1, (alpha2, one["label"].values)
        assert abs(pds[0] - lam) <= 1e-6 * lam, (alpha2, pds[0], lam)
