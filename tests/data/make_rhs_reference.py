"""Make tests/data/rhs_reference.npz: the model's right-hand side at random states, as
computed by the code BEFORE the right-hand side was rewritten (commit d9e0afe), through the
flat entry point tests/testcore.py: tmafm_testcore.model_terms.  tests/test_rhs.py checks the current kernel
against it.  Rerunning this script with a later build regenerates the file from that build,
so only rerun it to extend the cases, with the old kernel installed.

    python tests/data/make_rhs_reference.py            # writes tests/data/rhs_reference.npz

Cases: N = 1..30, both conventions, both contact laws, both phases, two scenes (the
defaults with xi0 = 1, and xi0 = 0.8, theta = 0.2, alpha4 = 0, so the printed moment
phi''(xi0) and the E2 quadrature are on and the contact damping is off), two states each.
In contact the state is shifted along mode 1 so that V_T = -10**U(-7, -3) < 0.
"""

import math
import sys
import tempfile
from pathlib import Path

import f90nml
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent.parent / "tests"))
from testcore import core as _core  # noqa: E402  (the test-only extension, tests/testcore.py)

N_MAX = 30
SCENES = ({}, {"xi0": 0.8, "theta": 0.2, "alpha4": 0.0})
OMEGA, ALPHA2 = 2.0, 5e-4          # the scene defaults, which both scenes keep


def main(out: Path) -> None:
    rng = np.random.default_rng(20240611)
    rows = {k: [] for k in ("n", "convention", "law", "in_contact", "scene", "tau", "a", "adot",
                            "rate")}
    with tempfile.TemporaryDirectory() as tmp:
        for n in range(1, N_MAX + 1):
            for convention in ("paper", "consistent"):
                for law in ("hertz", "dmt"):
                    for scene_index, scene in enumerate(SCENES):
                        path = Path(tmp) / f"case_{n}_{convention}_{law}_{scene_index}.nml"
                        groups = {"model": {"n_modes": n, "convention": convention,
                                            "contact_law": law}}
                        if scene:
                            groups["scene"] = dict(scene)
                        f90nml.write(f90nml.Namelist(groups), str(path), force=True)
                        xi0 = scene.get("xi0", 1.0)
                        tip = _core.modes(n, np.array([xi0]), 0)[1][0]
                        for in_contact in (False, True):
                            for _ in range(2):
                                j = np.arange(1, n + 1)
                                tau = rng.uniform(0.0, 10.0)
                                a = 1e-3 * rng.uniform(-1, 1, n) / j**2
                                adot = 1e-2 * rng.uniform(-1, 1, n) / j
                                if in_contact:
                                    vt = tip @ a + ALPHA2 * math.sin(OMEGA * tau)
                                    target = -10.0 ** rng.uniform(-7, -3)
                                    a[0] += (target - vt) / tip[0]
                                *_, rate, ierr, errmsg = _core.model_terms(
                                    str(path), tau, a, adot, in_contact)
                                if ierr != 0:
                                    sys.exit(f"model_terms failed: {errmsg.decode().strip()}")
                                rows["n"].append(n)
                                rows["convention"].append(convention)
                                rows["law"].append(law)
                                rows["in_contact"].append(in_contact)
                                rows["scene"].append(scene_index)
                                rows["tau"].append(tau)
                                rows["a"].append(a)
                                rows["adot"].append(adot)
                                rows["rate"].append(rate)
    # Case k's vectors are the k-th slices of the flat arrays a, adot (n values) and rate (2n).
    flat = {k: np.concatenate(rows[k]) for k in ("a", "adot", "rate")}
    np.savez_compressed(out, **{k: np.array(v) for k, v in rows.items() if k not in flat}, **flat)
    print(f"{out}: {len(rows['n'])} cases")


if __name__ == "__main__":
    main(Path(__file__).resolve().parent / "rhs_reference.npz")
