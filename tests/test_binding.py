"""One binding into the core: the package reaches it only through tmafm_api (f90wrap, the
extension tmafm._fwrap), and a sweep point's input is parsed once, from its Config, never
written back to text for the core."""

import importlib.util
import pickle
from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm import _fortran
from tmafm.observe import OBSERVABLES, observe_batch


def test_the_package_has_one_extension_module_and_no_core():
    folder = Path(tmafm.__file__).parent
    modules = sorted(p.name for p in folder.iterdir() if p.suffix in (".so", ".pyd"))
    assert len(modules) == 1 and modules[0].startswith("_fwrap."), modules
    assert importlib.util.find_spec("tmafm._core") is None
    assert importlib.util.find_spec("tmafm.tmafm_testcore") is None


#: The entry points of tmafm_api that parse namelist text, and the one that writes a
#: configuration back to text.
PARSES = ("config_from_text", "config_from_texts", "namelist_syntax")
WRITES = ("config_text_codes",)


@pytest.fixture
def core_calls(monkeypatch):
    """Count the calls into tmafm_api that parse text or write it (every way into the core)."""
    calls = dict.fromkeys(PARSES + WRITES, 0)
    for name in calls:
        original = getattr(_fortran.api, name)

        def counted(*args, _name=name, _original=original, **kwargs):
            calls[_name] += 1
            return _original(*args, **kwargs)
        monkeypatch.setattr(_fortran.api, name, counted)
    return calls


QUICK = {"max_periods": 3, "stop_at_steady": False, "p_max": 2}


def test_a_sweep_point_is_parsed_once(core_calls):
    base = tmafm.Config("fig2_n1", solver={"method": "flight_exact"})
    before = dict(core_calls)
    ds = tmafm.sweep(base, {"scene.alpha2": [3e-4, 4e-4, 5e-4], "scene.omega": [1.9, 2.0]}, workers=1,
                     **QUICK)
    points = 6
    parses = {name: core_calls[name] - before[name] for name in PARSES}
    assert sum(parses.values()) == points, parses
    # The base is turned into a dict once (its text); the points never go back to text.
    assert core_calls["config_text_codes"] - before["config_text_codes"] <= 1
    assert np.all(np.isfinite(ds["amplitude"].values))


def test_observe_batch_takes_the_configs_without_text(core_calls):
    configs = [tmafm.Config("fig2_n1", solver={"method": "flight_exact"}, scene={"alpha2": a})
               for a in (3e-4, 5e-4)]
    before = dict(core_calls)
    got = observe_batch(configs, threads=1, **QUICK)
    assert core_calls == before
    # The same as each run alone from its resolved text read again (a pickle), bit for bit.
    again = [tmafm.observe(pickle.loads(pickle.dumps(c)), **QUICK) for c in configs]
    for one, other in zip(got, again, strict=True):
        assert np.array_equal(one.poincare, other.poincare)
        for name, values in one.per_period.items():
            assert np.array_equal(values, other.per_period[name], equal_nan=True), name


def test_batch_run_refuses_arrays_of_the_wrong_shape():
    config = tmafm.Config("fig2_n1", solver={"method": "flight_exact"})
    batch = _fortran.batch_t()
    _fortran.api.batch_add(batch, config._f)
    n, m, h, s = 1, 3, 2, 2
    k = len(OBSERVABLES)  # the core's per-period columns (19 before min_force)
    arrays = [np.zeros(shape, order="F") for shape in ((n, m, k), (n, m, h), (n, m, h), (n, m + 1, s),
                                                       (n, m), (n, m, s // 2, 4))]
    ints = [np.zeros(n, dtype=np.int32) for _ in range(2)]
    rest = [np.zeros((n, k), order="F"), np.zeros(n, dtype=np.int32), np.zeros((n, h), order="F"),
            np.zeros((n, h), order="F"), np.zeros((n, 5), order="F"), np.zeros(n, dtype=np.int32)]
    args = [batch, m, h, 2, 1e-6, 3, False, 15, 1, False]
    ierr, errmsg = _fortran.api.batch_run(*args, *arrays, *ints, *rest)
    assert ierr == 0 and ints[0][0] == m
    # Too few periods' room for the values: refused by name, nothing written or run.
    small = [np.zeros((n, m - 1, k), order="F")] + arrays[1:]
    ints = [np.zeros(n, dtype=np.int32) for _ in range(2)]
    ierr, errmsg = _fortran.api.batch_run(*args, *small, *ints, *rest)
    assert ierr != 0 and "values" in _fortran.text(errmsg) and ints[0][0] == 0
    with pytest.raises(tmafm.InputError, match="steps"):
        tmafm.errors.raise_for(*_fortran.api.steady_test_of(np.zeros((4, 1), order="F"), 3, 1e-6, 1,
                                                             np.zeros(4), -1.0, np.zeros(2))[4:])
