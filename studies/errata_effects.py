"""The measured effect of each erratum, applied on its own, on Fig. 2's steady state
(inputs/fig2_n4.nml, flight_exact at rtol 1e-10, 100 drive periods, second half analysed).

    /opt/tmafm-venv/bin/python studies/errata_effects.py

Prints JSON and writes studies/results/errata_effects.json; docs/errata.md quotes it.
"""

import json
import math
from pathlib import Path

import numpy as np

import tmafm
from tmafm import analysis

REPO = Path(__file__).resolve().parent.parent
SETS = ["none", "E1", "E2", "E3", "E4", "E6", "E7", "all"]


def main():
    period = math.pi
    runs = {}
    for errata in SETS:
        runs[errata] = tmafm.run("fig2_n4", model={"errata": errata},
                                 solver={"method": "flight_exact", "rtol": 1e-10, "atol": 1e-16,
                                         "tau_end": 100 * period},
                                 output={"sample_dtau": period / 200})
    base = runs["none"]
    last = base.tau >= base.tau[-1] - period
    report = {"input": "inputs/fig2_n4.nml", "method": "flight_exact rtol 1e-10", "periods": 100,
              "effects": {}}
    for errata, r in runs.items():
        s = analysis.summary(r)
        report["effects"][errata] = {
            "classification": s["classification"], "contact_fraction": s["contact_fraction"],
            "vt_min": s["vt_min"], "vt_max": s["vt_max"],
            "dissipated_per_period": s["dissipated_per_period"],
            "max_abs_vt_change_last_period": float(np.max(np.abs(r.vt[last] - base.vt[last]))),
            "relative_change": float(np.max(np.abs(r.vt[last] - base.vt[last])) / np.ptp(base.vt[last])),
        }
    (REPO / "studies" / "results" / "errata_effects.json").write_text(json.dumps(report, indent=1))
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
