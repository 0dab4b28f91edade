"""A random campaign over the composed model (docs/model.md §16): contact laws, parts (two tones,
phases, a liquid, a viscoelastic sample, van der Waals, the forces at a distance, the JKR neck),
methods and N, each a short run or an
observed run of Fig. 2's scene from the installed package.

    /opt/tmafm-venv/bin/python studies/compose_fuzz.py [--count 600] [--seed 7]

Every case must give finite numbers or one typed, one-line refusal; the refusals are counted by
kind (numbers masked).  Prints the counts, and each case that crashed, gave a non-finite result
or a multi-line message; exits 1 if there is any.
"""

from __future__ import annotations

import argparse
import random
import re
import sys
import warnings

import numpy as np

import tmafm


def case(rng: random.Random) -> dict:
    """One random combination of the parts, a method and N."""
    scene = {}
    law = rng.choice(["hertz", "dmt", "dmt_vdw", "jkr"])
    if rng.random() < 0.5:
        scene.update(alpha2_2=rng.choice([0.0, 1e-5, 3e-4]), omega_2=rng.choice([4.0, 6.0, 3.0, 2.5]))
    if rng.random() < 0.3:
        scene.update(drive_phase=rng.uniform(-3, 3), drive_phase_2=rng.uniform(-3, 3))
    if rng.random() < 0.5:
        scene.update(medium_mass=rng.choice([0.05, 0.5, 5.0]), medium_reynolds=rng.choice([0.5, 10.0, 300.0]))
    if rng.random() < 0.5:
        scene.update(sls_relaxation_time=rng.choice([1e-3, 0.1, 5.0]), sls_modulus_ratio=rng.choice([0.05, 0.5, 1.0]))
    if law == "dmt_vdw":
        scene.update(vdw_adhesion=rng.choice([0.1, 1.0, 5.0]), vdw_range=rng.choice([1e-5, 2e-4, 1e-2]))
    # The forces at a distance (docs/model.md §17), with hostile geometry now and then.
    if rng.random() < 0.3:
        scene.update(electrostatic_strength=rng.choice([1e-3, 0.05, 2.0]),
                     electrostatic_radius=rng.choice([1e-4, 0.004, 0.5]),
                     cone_half_angle=rng.choice([0.05, 0.35, 1.5]))
    if rng.random() < 0.3:
        scene.update(double_layer_strength=rng.choice([-1.0, 0.3, 20.0]),
                     double_layer_range=rng.choice([1e-6, 3e-4, 0.1]))
    scene.update(delta_hat=rng.choice([-2e-4, 0.0, 3e-4, 1e-3]))
    n = rng.choice([1, 2, 4, 6])
    return dict(model={"contact_law": law, "n_modes": n}, scene=scene,
                initial={"a0": [0.0] * n, "adot0": [0.0] * n},
                solver={"method": rng.choice(["dop853", "dopri5", "flight_exact", "rk4_event", "rk4_paper"]),
                        "tau_end": 6.0})


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=600)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    rng = random.Random(args.seed)
    results, kinds, bad = 0, {}, []
    for _ in range(args.count):
        kw = case(rng)
        try:
            if rng.random() < 0.5:
                run = tmafm.run("fig2_n4", **kw)
                if not (np.all(np.isfinite(run.vt)) and np.all(np.isfinite(run.a))):
                    bad.append(("non-finite run", kw))
            else:
                obs = tmafm.observe("fig2_n4", max_periods=3, **kw)
                if not all(np.all(np.isfinite(obs.per_period[name]))
                           for name in ("min_force", "peak_force", "dissipated_energy", "amplitude")):
                    bad.append(("non-finite observation", kw))
            results += 1
        except tmafm.TmafmError as error:
            message = str(error)
            if "\n" in message:
                bad.append(("multi-line message", kw, message))
            kind = re.sub(r"[-+0-9.E]+", "#", message.split("overrides: ")[-1])[:100]
            kinds[kind] = kinds.get(kind, 0) + 1
        except Exception as error:  # a crash of the package: what the campaign looks for
            bad.append(("crash", kw, repr(error)))
    print(f"{args.count} cases: {results} results, {sum(kinds.values())} typed refusals, {len(bad)} bad")
    for kind, count in sorted(kinds.items(), key=lambda item: -item[1]):
        print(f"  {count:5d}  {kind}")
    for item in bad:
        print("BAD", item)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
