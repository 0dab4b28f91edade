"""Where are the period-2 motions of Figs. 4-5?  Classify the steady state of the N = 3
Hertz scene over a grid of alpha2 and a1(0), in both conventions, with flight_exact; and
classify Fig. 7 (Hertz and DMT) over a long horizon.

    /opt/tmafm-venv/bin/python studies/period_search.py

Writes studies/results/period_search.json; docs/reproduction.md quotes it.
"""

import json
import math
from pathlib import Path

import numpy as np

import tmafm
from tmafm import analysis

REPO = Path(__file__).resolve().parent.parent
SOLVER = {"method": "flight_exact", "rtol": 1e-9, "atol": 1e-15}


def classify(name, periods, **groups):
    period = math.pi
    solver = {**SOLVER, "tau_end": periods * period}
    r = tmafm.run(name, solver=solver, output={"sample_dtau": period / 200}, **groups)
    s = analysis.summary(r)
    return {"classification": s["classification"], "vt_min": s["vt_min"],
            "contact_fraction": s["contact_fraction"], "steady_tau": s["steady_state"]["tau"]}


def main():
    report = {"solver": SOLVER, "scan": [], "fig7": {}}
    for convention in ("paper", "consistent"):
        for alpha2 in np.round(np.linspace(3e-4, 8e-4, 11), 6):
            for a1 in (0.0, 3e-4, 7e-4, 8e-4):
                row = classify("fig4a", 100, model={"convention": convention},
                               scene={"alpha2": float(alpha2)}, initial={"a0": [a1, 0.0, 0.0]})
                report["scan"].append({"convention": convention, "alpha2": float(alpha2), "a1_0": a1, **row})
                print(convention, alpha2, a1, row["classification"], f"{row['vt_min']:.4e}")
    for name in ("fig7_hertz", "fig7_dmt"):
        for periods in (100, 300):
            report["fig7"][f"{name}/{periods}"] = classify(name, periods)
            print(name, periods, report["fig7"][f"{name}/{periods}"])
    kinds = {}
    for row in report["scan"]:
        kinds.setdefault(row["classification"], []).append((row["convention"], row["alpha2"], row["a1_0"]))
    report["kinds_found"] = {k: len(v) for k, v in kinds.items()}
    (REPO / "studies" / "results" / "period_search.json").write_text(json.dumps(report, indent=1))
    print(json.dumps(report["kinds_found"]))


if __name__ == "__main__":
    main()
