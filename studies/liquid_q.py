"""A cantilever from vacuum to air to water: how its first resonances and quality factors move.

Two rectangular silicon cantilevers, with no tip mass and no structural damping (beam_damping =
0, so that the liquid is the only loss): the paper's 300 x 30 x 3 um beam (k = 3 EI/L^3 ~ 1 N/m,
a soft cantilever of the kind used in liquid), and a stiff tapping cantilever 125 x 30 x 4 um
(k ~ 32 N/m, f0 ~ 310 kHz in vacuum).  In each medium, tmafm's own free decay (flight_exact, no drive, no
contact) gives every mode's eigenvalue lambda = -omega/(2Q) +- i omega sqrt(1 - 1/(4Q^2)),
read from the sampled state by a least-squares fit of the one-sample transition matrix
exp(A h) (exact for a linear autonomous system); and the reference below, written again from
J. E. Sader, J. Appl. Phys. 84, 64 (1998) with scipy's Bessel functions, gives the same
quantities from Sader's Eqs. (17), (20), (21), (25)-(26): f_R and Q.  The two agree to round-off
(they solve the same model), and Q1 in water lands in the published range (Q ~ 1-10 for such
beams: Sader 1998, Sec. V; Chon, Mulvaney and Sader, J. Appl. Phys. 87, 3978 (2000)).

    python studies/liquid_q.py            # writes studies/results/liquid_q.json, prints a table

The reference functions (gamma_circular, sader_omega, gamma_rectangular, sader_resonance) are
what tests/test_liquid.py checks the core's tmafm_hydrodynamics against.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import brentq
from scipy.special import kv

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "studies" / "results" / "liquid_q.json"

#: Sader's fit of Omega(Re) = Gamma_rect/Gamma_circ (Eq. 21), coefficients of tau^0..tau^6.
SADER_REAL_NUM = (0.91324, -0.48274, 0.46842, -0.12886, 0.044055, -0.0035117, 0.00069085)
SADER_REAL_DEN = (1.0, -0.56964, 0.48690, -0.13444, 0.045155, -0.0035862, 0.00069085)
SADER_IMAG_NUM = (-0.024134, -0.029256, 0.016294, -0.00010961, 0.000064577, -0.000044510)
SADER_IMAG_DEN = (1.0, -0.59702, 0.55182, -0.18357, 0.079156, -0.014369, 0.0028361)
#: Where the fit holds (0.1 %, Sader 1998).
RE_RANGE = (1e-6, 1e4)

#: Media: density (kg/m^3) and dynamic viscosity (Pa s) at 20-25 C.
MEDIA = {"vacuum": (0.0, 0.0), "air": (1.18, 1.86e-5), "water": (997.0, 8.9e-4)}
#: Silicon.
SILICON = {"density": 2330.0, "youngs_modulus_tip": 130.0e9}
#: Rectangular cantilevers (m): the paper's beam and a stiff tapping cantilever.
CANTILEVERS = {
    "paper_300x30x3um": {"length": 300e-6, "width": 30e-6, "thickness": 3e-6},
    "tapping_125x30x4um": {"length": 125e-6, "width": 30e-6, "thickness": 4e-6},
}
#: Published range of Q1 in water for such beams (Sader 1998; Chon et al. 2000).
WATER_Q_RANGE = (1.0, 10.0)


def _poly(coefficients, x):
    return sum(c * x**k for k, c in enumerate(coefficients))


def gamma_circular(re):
    """Gamma of a circular cylinder (Sader Eq. 17): 1 + 4 i K1(-i sqrt(i Re))/(sqrt(i Re) K0(...))."""
    s = np.sqrt(1j * np.asarray(re, float))
    return 1 + 4j * kv(1, -1j * s) / (s * kv(0, -1j * s))


def sader_omega(re):
    """Sader's rectangular correction Omega(Re) (Eq. 21)."""
    tau = np.log10(np.asarray(re, float))
    return (_poly(SADER_REAL_NUM, tau) / _poly(SADER_REAL_DEN, tau)
            + 1j * _poly(SADER_IMAG_NUM, tau) / _poly(SADER_IMAG_DEN, tau))


def gamma_rectangular(re):
    """Gamma of a thin rectangular beam (Sader Eq. 20)."""
    return sader_omega(re) * gamma_circular(re)


def beam_roots(n: int) -> np.ndarray:
    """beta_j of a clamped-free beam: 1 + cos(beta) cosh(beta) = 0."""
    f = lambda b: 1 + math.cos(b) * math.cosh(b)  # noqa: E731
    return np.array([brentq(f, (j - 0.5) * math.pi - 0.6, (j - 0.5) * math.pi + 0.6) for j in range(1, n + 1)])


def sader_resonance(stiffness, inertia, medium_mass, reynolds_scale):
    """Sader's Eqs. (25)-(26) for one mode, dimensionless: the frequency omega in the liquid
    (omega^2 (inertia + mu0 Gamma_r(R0 omega)) = stiffness), the added mass mu0 Gamma_r, the
    damping mu0 omega Gamma_i and Q = (inertia + mu0 Gamma_r)/Gamma_i-form, Re = R0 omega."""
    def residual(w):
        return w * w * (inertia + medium_mass * gamma_rectangular(reynolds_scale * w).real) - stiffness
    w_vac = math.sqrt(stiffness / inertia)
    lo = max(w_vac * 1e-3, RE_RANGE[0] / reynolds_scale)
    w = brentq(residual, lo, w_vac, xtol=1e-15, rtol=1e-15)
    g = complex(gamma_rectangular(reynolds_scale * w))
    added, damping = medium_mass * g.real, medium_mass * w * g.imag
    return {"omega": w, "added_mass": added, "damping": damping,
            "q": (inertia + added) * w / damping, "reynolds": reynolds_scale * w}


def dimensionless(beam: dict, medium: tuple[float, float]) -> dict:
    """t0, mu0 = pi rho_f b/(4 rho h), R0 = rho_f b^2/(4 eta t0) of a beam in a medium (SI in)."""
    rho_f, eta = medium
    inertia = beam["width"] * beam["thickness"] ** 3 / 12
    m = SILICON["density"] * beam["width"] * beam["thickness"]
    t0 = math.sqrt(m * beam["length"] ** 4 / (SILICON["youngs_modulus_tip"] * inertia))
    mu0 = math.pi * rho_f * beam["width"] / (4 * SILICON["density"] * beam["thickness"])
    r0 = rho_f * beam["width"] ** 2 / (4 * eta * t0) if eta > 0 else 0.0
    k = 3 * SILICON["youngs_modulus_tip"] * inertia / beam["length"] ** 3
    return {"t0": t0, "medium_mass": mu0, "medium_reynolds": r0, "spring_constant": k}


def free_decay_input(beam: dict, medium: tuple[float, float], n_modes: int, a0: list[float],
                     tau_end: float, sample_dtau: float) -> dict:
    """A free decay of the beam in the medium: no drive, the sample far away, flight_exact."""
    rho_f, eta = medium
    return {
        "model": {"n_modes": n_modes},
        "physical": {**beam, **SILICON, "tip_mass": 0.0, "beam_damping": 0.0, "tilt": 0.0,
                     "tip_position": beam["length"], "tip_length": 5e-6, "static_offset": 5e-6,
                     "gap": 1e-5, "drive_amplitude": 0.0, "medium_density": rho_f,
                     "medium_viscosity": eta},
        "initial": {"a0": a0},
        "solver": {"method": "flight_exact", "tau_end": tau_end},
        "output": {"sample_dtau": sample_dtau},
    }


def transition_eigenvalues(result, h: float) -> np.ndarray:
    """The eigenvalues lambda of the free system from its samples: the least-squares one-step map
    Phi with y_{k+1} = Phi y_k (y = (a, a')), lambda = log(eig Phi)/h."""
    y = np.hstack([result.a, result.adot])
    phi = np.linalg.lstsq(y[:-1], y[1:], rcond=None)[0].T
    return np.log(np.linalg.eigvals(phi).astype(complex)) / h


def mode_summary(lam: np.ndarray) -> list[dict]:
    """(omega, Q) of each oscillating pair (Im lambda > 0), by rising frequency."""
    pairs = sorted((z for z in lam if z.imag > 0), key=lambda z: abs(z))
    # Q past 1e10 is an undamped mode (vacuum) read through round-off: reported as inf.
    return [{"omega": abs(z), "q": q if (q := abs(z) / (-2 * z.real) if z.real < 0 else math.inf) < 1e10
             else math.inf} for z in pairs]


def study(n_modes: int = 2) -> dict:
    import tmafm

    betas = beam_roots(n_modes)
    out = {"command": "python studies/liquid_q.py", "media": MEDIA, "silicon": SILICON,
           "water_q_range": WATER_Q_RANGE, "cantilevers": {}}
    for name, beam in CANTILEVERS.items():
        entry = {"geometry_m": beam, "media": {}}
        for medium_name, medium in MEDIA.items():
            d = dimensionless(beam, medium)
            entry["spring_constant_n_per_m"] = d["spring_constant"]
            modes = []
            for j, beta in enumerate(betas):
                if medium_name == "vacuum":
                    ref = {"omega": beta**2, "q": math.inf, "added_mass": 0.0, "damping": 0.0, "reynolds": 0.0}
                else:
                    ref = sader_resonance(beta**4, 1.0, d["medium_mass"], d["medium_reynolds"])
                modes.append({"mode": j + 1, "f_hz_sader": ref["omega"] / (2 * math.pi * d["t0"]),
                              "q_sader": ref["q"], "added_mass": ref["added_mass"],
                              "reynolds": ref["reynolds"]})
            # tmafm's free decay: a few periods of mode 1, 200 samples a period of mode n.
            h = 2 * math.pi / betas[-1] ** 2 / 200
            result = tmafm.run(free_decay_input(beam, medium, n_modes, [1e-3] * n_modes,
                                                tau_end=4 * 2 * math.pi / betas[0] ** 2, sample_dtau=h))
            measured = mode_summary(transition_eigenvalues(result, h))
            for mode, got in zip(modes, measured):
                mode["f_hz_tmafm"] = got["omega"] / (2 * math.pi * d["t0"])
                mode["q_tmafm"] = got["q"]
            entry["media"][medium_name] = {"medium_mass": d["medium_mass"],
                                           "medium_reynolds": d["medium_reynolds"], "modes": modes}
        # How many modes Sader's fit covers in water (Re_j <= 1e4 at each mode's own frequency).
        d = dimensionless(beam, MEDIA["water"])
        inside = 0
        for beta in beam_roots(30):
            if sader_resonance(beta**4, 1.0, d["medium_mass"], d["medium_reynolds"])["reynolds"] > RE_RANGE[1]:
                break
            inside += 1
        entry["modes_inside_sader_range"] = inside
        f = {m: entry["media"][m]["modes"][0]["f_hz_tmafm"] for m in MEDIA}
        entry["f1_water_over_air"] = f["water"] / f["air"]
        entry["q1_air"] = entry["media"]["air"]["modes"][0]["q_tmafm"]
        entry["q1_water"] = entry["media"]["water"]["modes"][0]["q_tmafm"]
        out["cantilevers"][name] = entry
    return out


def _json_ready(x):
    if isinstance(x, float) and math.isinf(x):
        return "inf"
    if isinstance(x, dict):
        return {k: _json_ready(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_ready(v) for v in x]
    return x


def main() -> int:
    out = study()
    OUT.write_text(json.dumps(_json_ready(out), indent=1) + "\n")
    for name, entry in out["cantilevers"].items():
        print(f"{name}  (k = {entry['spring_constant_n_per_m']:.3g} N/m)")
        for medium, data in entry["media"].items():
            for m in data["modes"]:
                print(f"  {medium:7s} mode {m['mode']}: f = {m['f_hz_tmafm'] / 1e3:9.3f} kHz "
                      f"(Sader {m['f_hz_sader'] / 1e3:9.3f}), Q = {m['q_tmafm']:8.3f} "
                      f"(Sader {m['q_sader']:8.3f}), Re = {m['reynolds']:.3g}")
        print(f"  f1 water/air = {entry['f1_water_over_air']:.4f}")
    print(f"wrote {OUT.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
