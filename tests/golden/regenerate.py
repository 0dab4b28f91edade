"""Regenerate the golden trajectories in this folder.  Never edit the .npz files by hand.

    /opt/tmafm-venv/bin/python tests/golden/regenerate.py

Each case is a short run (tau <= 10) of an input of inputs/, in one convention, stored as
<case>.npz with the arrays of tmafm.run and the resolved input (JSON) that produced them.
analysis.json holds the analysis outputs (tmafm.analysis.summary: classification, contact
fraction, V_T range, modal amplitudes, dissipation) of every figure input, with both the
paper's scheme and flight_exact, over 16 drive periods.
Rerun this only when a change of the numbers is intended, and say why in the commit.
"""

import json
import math
from pathlib import Path

import numpy as np

import tmafm

HERE = Path(__file__).resolve().parent
INPUTS = HERE.parent.parent / "inputs"

FIGURE_INPUTS = ("fig2_n1", "fig2_n2", "fig2_n3", "fig2_n4", "fig3", "fig4a", "fig4c", "fig5a",
                 "fig5c", "fig6", "fig7_hertz", "fig7_dmt")

#: case name -> (input file, overrides): three scenes in both conventions with the paper's
#: scheme, and every figure input with both integrators (the located one at rtol 1e-10).
CASES = {
    f"{name}_{convention}": (f"{name}.nml", {"model": {"convention": convention},
                                             "solver": {"tau_end": 10.0},
                                             "output": {"sample_dtau": 0.05}})
    for name in ("fig2_n4", "fig6", "fig7_dmt")
    for convention in ("paper", "consistent")
}
CASES.update({
    f"{name}_paper_{method}": (f"{name}.nml", {"model": {"convention": "paper"},
                                               "solver": {**settings, "tau_end": 10.0},
                                               "output": {"sample_dtau": 0.05}})
    for name in FIGURE_INPUTS
    for method, settings in (("rk4_paper", {"method": "rk4_paper"}),
                             ("flight_exact", {"method": "flight_exact", "rtol": 1e-10, "atol": 1e-16}))
})

ARRAYS = ("tau", "vt", "vtdot", "contact", "a", "adot")
ANALYSIS_METHODS = {"rk4_paper": {"method": "rk4_paper"},
                    "flight_exact": {"method": "flight_exact", "rtol": 1e-9, "atol": 1e-15}}
ANALYSIS_PERIODS = 16
#: The analysis outputs kept in the golden file.
ANALYSIS_KEYS = ("classification", "period", "contact_fraction", "contacts_per_period", "vt_min",
                 "vt_max", "max_indentation", "dissipated_per_period", "modal_amplitudes")


def compute_analysis(name: str, method: str) -> dict:
    """The golden analysis outputs of one figure input and method."""
    from tmafm import analysis
    period = math.pi  # 2 pi / Omega with Omega = 2 in every figure
    result = tmafm.run(INPUTS / f"{name}.nml",
                       solver={**ANALYSIS_METHODS[method], "tau_end": ANALYSIS_PERIODS * period},
                       output={"sample_dtau": period / 200})
    summary = analysis.summary(result)
    return json.loads(json.dumps({key: summary[key] for key in ANALYSIS_KEYS}))


def compute(case: str) -> dict:
    """The arrays and metadata of one golden case, as tmafm computes them now."""
    file, overrides = CASES[case]
    result = tmafm.run(INPUTS / file, **overrides)
    data = {key: getattr(result, key) for key in ARRAYS}
    data["resolved"] = np.array(json.dumps(result.resolved.todict(complex_tuple=False), default=str))
    data["counters"] = np.array(json.dumps(result.counters))
    return data


def main() -> None:
    for case in CASES:
        np.savez_compressed(HERE / f"{case}.npz", **compute(case))
        print(f"wrote {HERE / (case + '.npz')}")
    table = {f"{name}/{method}": compute_analysis(name, method)
             for name in FIGURE_INPUTS for method in ANALYSIS_METHODS}
    (HERE / "analysis.json").write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")
    print(f"wrote {HERE / 'analysis.json'}")


if __name__ == "__main__":
    main()
