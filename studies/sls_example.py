"""The numbers of docs/model.md §14's example: inputs/sls_polystyrene.nml (a standard linear
solid sample) at steady state, against the same scene with an elastic sample.

    python studies/sls_example.py            # print the table docs/model.md quotes
    python studies/sls_example.py --check    # exit 1 if docs/model.md's table differs

tests/test_viscoelastic.py runs the check.
"""

import sys
from pathlib import Path

import tmafm

REPO = Path(__file__).resolve().parent.parent
INPUT = REPO / "inputs" / "sls_polystyrene.nml"
#: (observable, label, digits) in the table's order; SI-derived units (nm, deg, nN, us, aJ).
ROWS = [("amplitude", "amplitude (nm)", 4), ("phase", "phase (deg)", 4), ("min_gap", "min V_T (nm)", 4),
        ("peak_force", "peak force (nN)", 4), ("contact_time", "contact time (us)", 4),
        ("drive_work", "drive work per period (aJ)", 4),
        ("dissipated_viscoelastic", "dissipated in the sample (aJ)", 4),
        ("dissipated_beam", "dissipated by the beam damping (aJ)", 4),
        ("dissipated_energy", "dissipated in all (aJ)", 4)]


def steady(relaxation_time: float) -> dict:
    """The steady observables (SI-derived units) of the example with T2 = relaxation_time."""
    obs = tmafm.observe(str(INPUT), physical={"sample_relaxation_time": relaxation_time}, max_periods=200)
    if not obs.steady:
        raise RuntimeError(f"no steady state with T2 = {relaxation_time}: {obs.unsteady_reason}")
    return obs.steady_values(physical=True)


def table() -> str:
    """The markdown table of docs/model.md §14."""
    config = tmafm.Config(str(INPUT))
    sls, elastic = steady(config.to_dict()["physical"]["sample_relaxation_time"]), steady(0.0)
    lines = [f"Scene: r = {config.scene['sls_modulus_ratio']:.4g}, "
             f"T = {config.scene['sls_relaxation_time']:.4g} (τ units); "
             "`python studies/sls_example.py`.", "",
             "| steady state | SLS sample (T2 = 3 µs) | elastic sample (T2 = 0) |", "|---|---|---|"]
    for name, label, digits in ROWS:
        lines.append(f"| {label} | {sls[name]:.{digits}g} | {elastic[name]:.{digits}g} |")
    return "\n".join(lines)


def docs_table() -> str:
    """The table as docs/model.md quotes it (from 'Scene: r =' to the table's end)."""
    text = (REPO / "docs" / "model.md").read_text()
    start = text.index("Scene: r =", text.index("## 12."))
    lines = text[start:].splitlines()
    end = next(k for k in range(3, len(lines)) if not lines[k].startswith("|"))
    return "\n".join(lines[:end])


if __name__ == "__main__":
    made = table()
    if "--check" in sys.argv:
        if made != docs_table():
            print(f"docs/model.md §14 differs from:\n{made}")
            sys.exit(1)
        print("docs/model.md §14's example table: as computed")
    else:
        print(made)
