"""The attractive regime of AM-AFM with van der Waals attraction (docs/vdw.md): a warm-started
approach and retract on inputs/sweeps/vdw_attractive.nml (contact_law = 'dmt_vdw', a silicon
cantilever k = 40 N/m, f0 = 309 kHz, Q = 400 on a stiff sample, R = 10 nm, H = 1e-19 J,
A0 = 10 nm), as published by Garcia and San Paulo (Phys. Rev. B 61, R13381 (2000);
Ultramicroscopy 82, 79 (2000)).

It sweeps delta_hat = Z/d (d = 10 um, so Z in nm is 1e4 delta_hat) down and back up, each point
warm-started from the last, and writes the amplitude and phase against Z (the plot), the two
branches (attractive: no contact and a lag past 90 degrees; repulsive: intermittent contact),
and where each direction jumps between them (the JSON).  The same sweep with N = 2 modes and
with a 100x tighter rtol checks that the jumps do not depend on N or on the tolerance.

    python studies/vdw_attractive.py --json studies/results/vdw_attractive.json \
        --plot docs/figures/vdw_attractive.png
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

import tmafm

REPO = Path(__file__).resolve().parent.parent
SCENE = REPO / "inputs" / "sweeps" / "vdw_attractive.nml"
#: The gap d of the scene (m): Z = delta_hat d, lengths in gap units times d.
GAP_NM = 1e4
#: Z from 11 nm down to 7 nm in steps of 0.1 nm (delta_hat = Z/d); a step must stay well below
#: the attractive orbit's smallest gap (~0.03 to 0.3 nm here), or the warm start touches.
Z_STEP = 1e-5
Z_HIGH, Z_LOW = 1.10e-3, 0.70e-3


def sweep(n_modes: int = 1, rtol: float = 1e-8):
    base = tmafm.Config(str(SCENE), model={"n_modes": n_modes}, solver={"rtol": rtol},
                        initial={"a0": [0.0] * n_modes})
    z = np.round(np.arange(Z_HIGH, Z_LOW - Z_STEP / 2, -Z_STEP), 12)
    start = time.process_time()
    ds = tmafm.approach(base, z, max_periods=4000, observables=["lockin", "extrema", "energy"],
                        workers=1)
    cpu = time.process_time() - start
    curves = {}
    for direction in ("approach", "retract"):
        s = ds.sel(direction=direction).sortby("scene.delta_hat")
        zz = s["scene.delta_hat"].values
        phase, gap = s.phase.values, s.min_gap.values
        attractive = (gap > 0) & (phase < -90)
        repulsive = (gap < 0) & (phase > -90)
        switches = np.flatnonzero(np.diff(attractive.astype(int)))
        curves[direction] = {
            "z_nm": np.round(zz * GAP_NM, 6).tolist(),
            "amplitude_nm": (s.amplitude.values * GAP_NM).tolist(),
            "phase_deg": phase.tolist(),
            "min_gap_nm": (gap * GAP_NM).tolist(),
            "virial": s.virial.values.tolist(),
            "contact_time": s.contact_time.values.tolist(),
            "steady": s.steady.values.astype(int).tolist(),
            "branch": ["attractive" if a else "repulsive" if r else "other"
                       for a, r in zip(attractive, repulsive)],
            # The jump lies between these two Z (nm): the last attractive point and the first
            # repulsive one below it.
            "jump_between_nm": [round(float(zz[k] * GAP_NM), 6) for k in (switches[0] + 1, switches[0])]
            if len(switches) == 1 else None,
            "switches": len(switches),
        }
    return curves, cpu


def free_oscillation():
    """Amplitude and phase far from the sample (Z = 50 nm): A0 and the free phase."""
    from tmafm.observe import observe
    obs = observe(str(SCENE), max_periods=4000, observables=["lockin"], scene={"delta_hat": 5e-3})
    assert obs.steady, obs.unsteady_reason
    values = obs.steady_values()
    return values["amplitude"] * GAP_NM, values["phase"]


def plot(curves: dict, a0_nm: float, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax_a, ax_p) = plt.subplots(2, 1, figsize=(6.4, 6.4), sharex=True)
    style = {"approach": dict(marker="v", color="tab:blue", label="approach"),
             "retract": dict(marker="^", color="tab:red", label="retract", markerfacecolor="none")}
    for direction, c in curves.items():
        ax_a.plot(c["z_nm"], c["amplitude_nm"], ls="-", lw=0.8, ms=4, **style[direction])
        ax_p.plot(c["z_nm"], c["phase_deg"], ls="-", lw=0.8, ms=4, **style[direction])
        if c["jump_between_nm"]:
            for ax in (ax_a, ax_p):
                ax.axvspan(*sorted(c["jump_between_nm"]), color=style[direction]["color"], alpha=0.15)
    ax_a.axhline(a0_nm, color="grey", lw=0.6, ls=":")
    ax_a.set_ylabel("amplitude A (nm)")
    ax_a.legend(loc="upper left")
    ax_p.axhline(-90, color="grey", lw=0.6, ls=":")
    ax_p.text(0.02, 0.3, "phase < -90°: attractive (non-contact)\nphase > -90°: repulsive "
              "(intermittent contact)", transform=ax_p.transAxes, ha="left", va="bottom", fontsize=8)
    ax_p.set_ylabel("phase φ (deg; -90 = free resonance)")
    ax_p.set_xlabel("rest separation Z (nm)")
    fig.suptitle(f"dmt_vdw, k = 40 N/m, f0 = 309 kHz, Q = 400, R = 10 nm, H = 1e-19 J, "
                 f"A0 = {a0_nm:.2f} nm", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path)
    parser.add_argument("--plot", type=Path)
    parser.add_argument("--quick", action="store_true", help="N = 1 at rtol 1e-8 only")
    args = parser.parse_args()
    a0_nm, free_phase = free_oscillation()
    curves, cpu = sweep()
    out = {"command": "python studies/vdw_attractive.py --json studies/results/vdw_attractive.json "
                      "--plot docs/figures/vdw_attractive.png",
           "scene": str(SCENE.relative_to(REPO)), "free_amplitude_nm": a0_nm,
           "free_phase_deg": free_phase, "z_step_nm": Z_STEP * GAP_NM, "cpu_seconds": cpu,
           "n1_rtol1e-8": curves}
    for direction, c in curves.items():
        print(f"N=1 rtol=1e-8 {direction}: jump between Z = {c['jump_between_nm']} nm "
              f"({c['switches']} switch)")
    if not args.quick:
        for n_modes, rtol in ((2, 1e-8), (1, 1e-10)):
            other, _ = sweep(n_modes, rtol)
            key = f"n{n_modes}_rtol{rtol:.0e}".replace("e-0", "e-")
            out[key] = {d: {"jump_between_nm": c["jump_between_nm"], "switches": c["switches"]}
                        for d, c in other.items()}
            for direction, c in other.items():
                print(f"N={n_modes} rtol={rtol:g} {direction}: jump between Z = "
                      f"{c['jump_between_nm']} nm")
    print(f"A0 = {a0_nm:.4f} nm, free phase {free_phase:.3f} deg, sweep CPU {cpu:.1f} s")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=1) + "\n")
    if args.plot:
        plot(curves, a0_nm, args.plot)


if __name__ == "__main__":
    main()
