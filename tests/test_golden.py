"""Regression against the stored golden trajectories (tests/golden/regenerate.py writes them)."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

GOLDEN = Path(__file__).parent / "golden"
_spec = importlib.util.spec_from_file_location("regenerate", GOLDEN / "regenerate.py")
regenerate = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(regenerate)

#: Largest allowed |difference| per array, in the array's own units (gap d, d per tau unit).
#: The runs are deterministic, so these only absorb round-off from a different BLAS/LAPACK.
TOLERANCE = {"tau": 1e-13, "vt": 1e-12, "vtdot": 1e-10, "contact": 0, "a": 1e-12, "adot": 1e-10}


def where_they_differ(name, new, old, tau, tol):
    diff = np.abs(np.asarray(new, float) - np.asarray(old, float))
    if diff.ndim == 1:
        diff = diff[:, None]
    bad = np.argwhere(diff > tol)
    row, col = bad[0]
    return (f"{name}: {len(bad)} entries differ by more than {tol}; first at tau = {tau[row]:.4f} "
            f"(sample {row}, column {col}), by {diff[row, col]:.3e}; largest {diff.max():.3e}")


@pytest.mark.parametrize("case", sorted(regenerate.CASES))
def test_golden_trajectory(case):
    stored = np.load(GOLDEN / f"{case}.npz")
    new = regenerate.compute(case)
    assert json.loads(str(new["resolved"])) == json.loads(str(stored["resolved"])), \
        "the resolved input changed: regenerate the goldens if that is intended"
    problems = []
    for name in regenerate.ARRAYS:
        assert new[name].shape == stored[name].shape, name
        if np.any(np.abs(np.asarray(new[name], float) - stored[name]) > TOLERANCE[name]):
            problems.append(where_they_differ(name, new[name], stored[name], stored["tau"],
                                              TOLERANCE[name]))
    assert not problems, f"{case}:\n" + "\n".join(problems)


def test_cases_cover_both_conventions_laws_and_every_figure():
    assert {"paper", "consistent"} <= {c.rsplit("_", 1)[1] for c in regenerate.CASES}
    for name in regenerate.FIGURE_INPUTS:
        assert f"{name}_paper_rk4_paper" in regenerate.CASES
        assert f"{name}_paper_flight_exact" in regenerate.CASES
    laws = {json.loads(str(np.load(GOLDEN / f"{c}.npz")["resolved"]))["model"]["contact_law"]
            for c in regenerate.CASES}
    assert laws == {"hertz", "dmt"}


def test_mismatch_report_says_where():
    stored = np.load(GOLDEN / "fig2_n4_paper.npz")
    changed = stored["a"].copy()
    changed[37, 2] += 1e-9
    message = where_they_differ("a", changed, stored["a"], stored["tau"], TOLERANCE["a"])
    assert "1 entries" in message and "tau = 1.8500" in message and "column 2" in message


#: Relative tolerance of the golden analysis numbers; classifications must match exactly.
ANALYSIS_RTOL = 1e-8


def _compare(path, new, old, problems):
    if isinstance(old, dict):
        for key in old:
            _compare(f"{path}.{key}", new[key], old[key], problems)
    elif isinstance(old, list):
        for k, (n, o) in enumerate(zip(new, old)):
            _compare(f"{path}[{k}]", n, o, problems)
    elif isinstance(old, float):
        if abs(new - old) > ANALYSIS_RTOL * abs(old) + 1e-300:
            problems.append(f"{path}: {new!r} != stored {old!r}")
    elif new != old:
        problems.append(f"{path}: {new!r} != stored {old!r}")


@pytest.mark.parametrize("name", regenerate.FIGURE_INPUTS)
def test_golden_analysis(name):
    stored = json.loads((GOLDEN / "analysis.json").read_text())
    problems = []
    for method in regenerate.ANALYSIS_METHODS:
        key = f"{name}/{method}"
        _compare(key, regenerate.compute_analysis(name, method), stored[key], problems)
    assert not problems, "\n".join(problems)
