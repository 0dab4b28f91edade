"""The numbers README.md and docs/ quote, against what makes them (benchmarks/check_docs.py):
every claim against its committed JSON, and the deterministic numbers behind them computed
again on this build (check_docs.py --recompute: the flight_exact cases of
docs/figures/summary.json and the rk4_paper verdicts the docs quote that round-off does not
flip, the V_T
errors of the quoted period_cost rows, the Fig. 2 run's rows and counters, Fig. 6's landing,
Fig. 7 over 300 periods).  The timings are not rerun here (check_docs.py --rerun-timings)."""

import copy
import importlib.util
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("check_docs", REPO / "benchmarks" / "check_docs.py")
check_docs = importlib.util.module_from_spec(_spec)
sys.modules["check_docs"] = check_docs
_spec.loader.exec_module(check_docs)


def _drift(ck):
    return "\n".join(f"{r.where}: {r.claim}\n    {r.labels[0]}: {r.docs}   {r.labels[1]}: {r.source}"
                     for r in ck.rows if r.ok is False)


@pytest.mark.parametrize("group", list(check_docs.GROUPS))
def test_docs_match_their_committed_json(group):
    ck = check_docs.Checker()
    check_docs.GROUPS[group](ck)
    assert ck.rows and all(r.ok is not False for r in ck.rows), _drift(ck)
    assert sum(r.ok is True for r in ck.rows) >= 3


def test_deterministic_numbers_recomputed_on_this_build():
    """Not the two rk4_paper verdicts that flip when a1(0) moves by 1e-16 (RK4_FRAGILE): with
    another BLAS or CPU they may come out either way (check_docs.py --recompute checks them)."""
    ck = check_docs.Checker()
    check_docs.recompute(ck, fragile=False)
    assert all(r.ok is not False for r in ck.rows), _drift(ck)
    # every flight_exact case of summary.json and each stable rk4_paper verdict was rerun
    cases = {r.where for r in ck.rows if r.where.startswith("summary.json ")}
    summary = check_docs.load(check_docs.SUMMARY)
    expected = {k for k in summary["cases"] if "/flight_exact/" in k} | set(check_docs.RK4_STABLE)
    assert cases == {f"summary.json {k}" for k in expected}


def test_a_changed_verdict_is_drift():
    """The checker is not vacuous: a summary with Fig. 6's old rk4_paper verdict (period-6,
    what reproduction.md said before the rerun) drifts on exactly that claim."""
    summary = copy.deepcopy(check_docs.load(check_docs.SUMMARY))
    summary["cases"]["fig6/rk4_paper/consistent"]["classification"] = "period-6"
    ck = check_docs.Checker()
    check_docs.check_figures(ck, summary)
    drift = [r for r in ck.rows if r.ok is False]
    assert len(drift) == 1 and drift[0].docs == "non-periodic" and drift[0].source == "period-6"


def test_a_changed_digit_is_drift():
    """One digit of one JSON number changed: the table row quoting it drifts, the others not."""
    ck = check_docs.Checker()
    summary = copy.deepcopy(check_docs.load(check_docs.SUMMARY))
    summary["cases"]["fig2_n3/flight_exact/paper"]["contact_fraction"] *= 1.001   # 0.2309 -> 0.2312
    check_docs.check_figures(ck, summary)
    drift = [r for r in ck.rows if r.ok is False]
    assert [r.claim for r in drift] == ["| contact fraction | {} | {} | {} | {} |"]
    assert drift[0].docs.split(" | ")[2] == "0.2309" and drift[0].source.split(" | ")[2] == "0.2312"


def test_text_not_found_is_drift():
    ck = check_docs.Checker()
    assert not ck.text("t", "README.md", "a sentence the README does not hold: {} s", ["1.0"])
    assert ck.rows[-1].ok is False and ck.rows[-1].docs == "(text not found)"
