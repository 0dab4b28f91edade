"""Phase contrast from adhesion hysteresis: the standard tapping lever (tapping_polystyrene: 40 N/m,
300 kHz, Q = 400, A0 = 20 nm, R = 10 nm) over samples of rising work of adhesion w, with the JKR
law (a neck that breaks past the surface: each tap loses the loop's area, docs/model.md §18) and
with DMT (the same w as a pull-off force, no neck, no loss), at the same setpoint distance; and on
polystyrene (DMT) in air of rising relative humidity, where a water meniscus forms at each tap and
breaks at the Kelvin rupture gap on the way out (docs/model.md §19).

The phase difference between the two laws at the same w is the contrast the hysteresis alone
makes; the loss per tap against w is the JKR closed form 7.0922 (w^5 R^4/E*^2)^(1/3), and against
the humidity the meniscus's F0 D/2 (here from the runs).

    python studies/adhesion_phase_contrast.py    # ~1 min of CPU; writes studies/results/
                                                 # adhesion_phase_contrast.json and .png
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

import tmafm

HERE = Path(__file__).resolve().parent
OUT = HERE / "results" / "adhesion_phase_contrast.json"
#: Works of adhesion (J/m^2): from a hydrophobic polymer to a sticky soft sample.
WORKS = [0.01, 0.02, 0.035, 0.05, 0.07, 0.1]
#: The rest distance: A0 = 20 nm taps down to about 12 nm above the rest position.
DISTANCE = 12e-9
#: Relative humidities of the air (0: dry, no meniscus).
HUMIDITIES = [0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6]


def steady(law: str, work: float, humidity: float = 0.0) -> dict:
    physical = {"adhesion_energy": work, "tip_sample_distance": DISTANCE}
    if humidity > 0:
        physical["relative_humidity"] = humidity
    obs = tmafm.observe("tapping_polystyrene", max_periods=8000, steady_tol=1e-8, physical=physical,
                        model={"contact_law": law}, solver={"method": "dop853", "rtol": 1e-10, "atol": 1e-16})
    if not obs.steady:
        raise RuntimeError(f"{law}, w = {work}, RH = {humidity}: not steady ({obs.unsteady_reason})")
    p = obs.physical
    orbit = slice(len(p["phase"]) - obs.period, None)
    taps = float(np.sum(p["contacts_per_period"][orbit]))
    return {"period": int(obs.period), "amplitude_nm": float(p["amplitude"][-1]), "phase_deg": float(p["phase"][-1]),
            "taps_per_period": taps / obs.period,
            "adhesion_loss_per_tap_aJ": float(np.sum(p["dissipated_adhesion"][orbit])) / taps if taps else 0.0,
            "tip_sample_loss_per_period_aJ": float(np.mean(
                (p["dissipated_contact_damping"] + p["dissipated_friction"] + p["dissipated_adhesion"])[orbit])),
            "min_force_nN": float(np.min(p["min_force"][orbit]))}


def plot(result, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    works = np.array(result["works_J_per_m2"]) * 1e3
    fig, (left, right, humid) = plt.subplots(1, 3, figsize=(13.5, 3.6), constrained_layout=True)
    for law, style in (("jkr", "o-"), ("dmt", "s--")):
        left.plot(works, [r["phase_deg"] for r in result[law]], style, label=law.upper())
    left.set_xlabel("work of adhesion w (mJ/m²)")
    left.set_ylabel("phase (deg)")
    left.set_title(f"tapping_polystyrene at Z = {DISTANCE * 1e9:.0f} nm")
    left.legend()
    right.plot(works, [r["tip_sample_loss_per_period_aJ"] for r in result["jkr"]], "o-",
               label="JKR: all tip-sample losses")
    right.plot(works, [r["adhesion_loss_per_tap_aJ"] * r["taps_per_period"] for r in result["jkr"]], "o:",
               label="JKR: the neck's share")
    right.plot(works, [r["tip_sample_loss_per_period_aJ"] for r in result["dmt"]], "s--",
               label="DMT: all tip-sample losses")
    right.set_title("energy lost per drive period")
    right.set_xlabel("work of adhesion w (mJ/m²)")
    right.set_ylabel("energy (aJ)")
    right.legend()
    rh = np.array(result["humidities"]) * 100
    wet = result["humid"]
    humid.plot(rh, [r["phase_deg"] for r in wet], "o-", color="C0", label="phase")
    humid.set_xlabel("relative humidity (%)")
    humid.set_ylabel("phase (deg)", color="C0")
    humid.set_title(f"polystyrene (DMT) in humid air, Z = {DISTANCE * 1e9:.0f} nm")
    loss = humid.twinx()
    loss.plot(rh, [r["adhesion_loss_per_tap_aJ"] for r in wet], "s--", color="C3", label="meniscus loss per tap")
    loss.set_ylabel("meniscus loss per tap (aJ)", color="C3")
    fig.savefig(path, dpi=120)


def main() -> int:
    start = time.process_time()
    result = {"works_J_per_m2": WORKS, "tip_sample_distance_m": DISTANCE,
              "jkr": [steady("jkr", w) for w in WORKS], "dmt": [steady("dmt", w) for w in WORKS],
              "humidities": HUMIDITIES, "humid": [steady("dmt", 0.035, rh) for rh in HUMIDITIES]}
    result["cpu_s"] = time.process_time() - start
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps(result, indent=1) + "\n")
    plot(result, OUT.with_suffix(".png"))
    for law in ("jkr", "dmt"):
        for w, r in zip(WORKS, result[law], strict=True):
            print(f"{law} w = {w:5.3f} J/m^2: phase {r['phase_deg']:8.3f} deg, A {r['amplitude_nm']:.3f} nm, "
                  f"adhesion loss/tap {r['adhesion_loss_per_tap_aJ']:.4f} aJ, taps/period {r['taps_per_period']:.0f}")
    for rh, r in zip(HUMIDITIES, result["humid"], strict=True):
        print(f"dmt RH = {rh:.2f}: phase {r['phase_deg']:8.3f} deg, A {r['amplitude_nm']:.3f} nm, "
              f"meniscus loss/tap {r['adhesion_loss_per_tap_aJ']:.4f} aJ, taps/period {r['taps_per_period']:.0f}")
    print(f"{result['cpu_s']:.1f} s of CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
