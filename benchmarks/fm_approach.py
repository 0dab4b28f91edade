"""An FM-AFM approach curve (docs/instrument.md, "FM-AFM") with its CPU cost, against the
Giessibl/Sader-Jarvis integral of the scene's own force law.

    /opt/tmafm-venv/bin/python benchmarks/fm_approach.py [--out DIR] [--step 0.5e-9]

The scene: inputs/tapping_polystyrene.nml's cantilever (k = 40 N/m, f0 = 300 kHz, Q = 400)
untilted, with the van der Waals attraction (contact_law = 'dmt_vdw') and no contact damping
(a conservative force: the integral applies), at A = 5 nm, Z from 20 nm down to 2 nm (3 nm
into the sample at the bottom), one mode and three modes, loops of 1 kHz (PLL) and 500 Hz
(amplitude), 1000 settle and 100 averaged periods a point.  The integral is taken by
quadrature of F(s) = -H R/(6 s^2) out of contact and 4 E* sqrt(R) delta^(3/2)/3 - H R/(6 a0^2)
in it (docs/model.md §6a), at the loop's own mean separation, with the model's own k and f0.
Cost: CPU time (user + sys) of each curve over its periods, and of tmafm.observe running the
same number of periods at one fixed Z (the plain observed run), in the same run.  Writes
fm_approach.json and fm_approach.png into --out (default benchmarks/results/).
"""

import argparse
import json
import resource
from pathlib import Path

import numpy as np
from scipy.integrate import quad

import tmafm
from tmafm.instrument import fm_approach, plot_fm_approach

REPO = Path(__file__).resolve().parent.parent
AMPLITUDE = 5e-9
LOOP = {"pll_bandwidth": 1e3, "amplitude_bandwidth": 500.0, "settle_periods": 1000, "average_periods": 100}


def cpu():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def scene(n_modes):
    return tmafm.Config("tapping_polystyrene", model={"n_modes": n_modes, "contact_law": "dmt_vdw"},
                        physical={"tilt": 0.0, "contact_damping": 0.0})


#: The scene's force law's constants: H and a0 are &physical's defaults (hamaker,
#: intermolecular_distance), R, E1, nu1, E2, nu2 tapping_polystyrene's.
HAMAKER, RADIUS, A0 = 3.592254119747249e-20, 10e-9, 0.165e-9
E_STAR = 1 / ((1 - 0.27 ** 2) / 130e9 + (1 - 0.3 ** 2) / 1.2e9)


def force_law(config):
    """F(s) (N) at the separation s = a0 + gap (m) of the scene's 'dmt_vdw' law, untilted."""
    def force(s):
        if s >= A0:
            return -HAMAKER * RADIUS / (6 * s ** 2)
        return 4 * E_STAR * np.sqrt(RADIUS) * (A0 - s) ** 1.5 / 3 - HAMAKER * RADIUS / (6 * A0 ** 2)
    return force, A0


def sader_jarvis(config, center, amplitude):
    derived = config.derived
    k, f0 = derived["spring_constant"], derived["resonance_frequency"]
    force, a0 = force_law(config)
    integrand = lambda th: force(center + amplitude * np.cos(th)) * np.cos(th)   # noqa: E731
    # the contact's switch (s = a0) split out: the law is not smooth there
    cut = (a0 - center) / amplitude
    points = [np.arccos(cut)] if -1 < cut < 1 else None
    value = quad(integrand, 0, np.pi, points=points, epsabs=0, epsrel=1e-10, limit=200)[0]
    return -f0 / (np.pi * k * amplitude) * value


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results")
    parser.add_argument("--step", type=float, default=0.5e-9)
    args = parser.parse_args()
    z = np.arange(20e-9, 2e-9 - 1e-12, -args.step)
    report = {"scene": "tapping_polystyrene, untilted, dmt_vdw, contact_damping = 0", "amplitude_m": AMPLITUDE,
              "loop": LOOP, "z_nm": list(z * 1e9), "curves": {}}
    curves = {}
    for n_modes in (1, 3):
        config = scene(n_modes)
        start = cpu()
        data = fm_approach(config, z=z, amplitude=AMPLITUDE, **LOOP)
        spent = cpu() - start
        periods = z.size * (LOOP["settle_periods"] + LOOP["average_periods"])
        start = cpu()
        tmafm.observe(config, max_periods=periods, stop_at_steady=False,
                      physical={"tip_sample_distance": 10e-9})
        plain = cpu() - start
        centers = [config_center(config, data, i) for i in range(z.size)]
        integral = np.array([sader_jarvis(config, c, AMPLITUDE) for c in centers])
        curves[n_modes] = (data, integral)
        report["curves"][str(n_modes)] = {
            "n_modes": n_modes, "cpu_s": spent, "periods": periods, "us_per_period": 1e6 * spent / periods,
            "plain_observe_us_per_period": 1e6 * plain / periods, "k_N_per_m": config.derived["spring_constant"],
            "f0_Hz": config.derived["resonance_frequency"],
            "phase_setpoint_deg": data.attrs["phase_setpoint_deg"],
            "df_Hz": [float(v) for v in data.df], "sader_jarvis_Hz": [float(v) for v in integral],
            "min_gap_nm": [float(v) for v in data.min_gap], "df_spread_Hz": [float(v) for v in data.df_spread],
            "dissipation_aJ": [float(v) for v in data.dissipation],
            "max_relative_difference": float(np.max(np.abs(data.df.values / integral - 1))),
        }
        print(json.dumps({k: v for k, v in report["curves"][str(n_modes)].items() if not isinstance(v, list)}))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "fm_approach.json").write_text(json.dumps(report, indent=1) + "\n")
    data, integral = curves[1]
    fig = plot_fm_approach(data, reference=(data.z.values, integral))
    top = fig.axes[0]
    three, integral3 = curves[3]
    top.plot(three.z, three.df, "s", ms=3, mfc="none", label="FM loop, 3 modes")
    top.plot(three.z, integral3, ":", label="integral, 3-mode k and f0")
    top.legend(fontsize=7)
    fig.savefig(args.out / "fm_approach.png", dpi=110)


def config_center(config, data, i):
    """The loop's mean separation s = a0 + Z + mean deflection (m)."""
    _, a0 = force_law(config)
    return a0 + float(data.z[i]) * 1e-9 + float(data.mean_deflection[i]) * 1e-9


if __name__ == "__main__":
    main()
