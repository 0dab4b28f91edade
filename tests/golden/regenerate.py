"""Regenerate the golden trajectories in this folder.  Never edit the .npz files by hand.

    /opt/tmafm-venv/bin/python tests/golden/regenerate.py

Each case is a short run (tau <= 10) of an input of inputs/, in one convention, stored as
<case>.npz with the arrays of tmafm.run and the resolved input (JSON) that produced them.
Rerun this only when a change of the numbers is intended, and say why in the commit.
"""

import json
from pathlib import Path

import numpy as np

import tmafm

HERE = Path(__file__).resolve().parent
INPUTS = HERE.parent.parent / "inputs"

#: case name -> (input file, overrides)
CASES = {
    f"{name}_{convention}": (f"{name}.nml", {"model": {"convention": convention},
                                             "solver": {"tau_end": 10.0},
                                             "output": {"sample_dtau": 0.05}})
    for name in ("fig2_n4", "fig6", "fig7_dmt")
    for convention in ("paper", "consistent")
}

ARRAYS = ("tau", "vt", "vtdot", "contact", "a", "adot")


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


if __name__ == "__main__":
    main()
