"""Would an integrating-factor (Lawson) form of dop853 take fewer contact steps?  A probe.

    /opt/tmafm-venv/bin/python studies/lawson_probe.py

For one contact of each scene (Fig. 2 and tilted_hertz_3 of benchmarks/period_cost.py), late in
a 30-period flight_exact run at rtol 1e-12: integrate the inner part of the contact (from the
second output sample after its entry to the second before its exit, every 0.01, so that the
kinks at entry and exit stay outside) with the DOP853 tableau (scipy's coefficients) and the
classical controller (safety 0.9, factors 1/3..6), on the right-hand side of tmafm.Model, in two
forms:
  plain   y' = f(tau, y);
  Lawson  y = exp(A (tau - tau_n)) v on each step, v' = exp(-A s) (f - A y), A the free
          flight's Jacobian (the linear part that flight_exact solves exactly), so that the
          modes' own oscillation is exact and only the contact force and drive are integrated.
Both use the same error norm (per component, atol + rtol x the component's largest size over
the run's second half; the Lawson error estimate mapped back by exp(A h)), at rtol 1e-7/atol
1e-10 and rtol 1e-10/atol 1e-14, and print steps, rejected steps and the end state's error
against the run's sample; and the largest |eigenvalue| of the free flight's Jacobian against
that of the contact right-hand side's at the contact's samples (central differences), which
says how far the contact moves the stiffest mode.  A study for docs/performance.md, not a method of tmafm: it calls
scipy.linalg.expm per stage, which a real implementation would tabulate.
"""

import math

import numpy as np
import scipy.integrate._ivp.dop853_coefficients as dop
from scipy.linalg import expm

import tmafm

A_STAGE, B_WEIGHT, NODES = dop.A[:12, :12], dop.B, dop.C[:12]
E3, E5 = dop.E3[:12], dop.E5[:12]
PERIOD = math.pi  # Omega = 2
SCENES = {
    "fig2": {},
    "tilted_hertz_3": {"model": {"n_modes": 3, "convention": "paper"}, "scene": {"alpha2": 7e-4, "theta": 0.2},
                       "initial": {"a0": [2e-4, 0.0, 0.0]}},
}


def free_jacobian(model, n):
    """The free flight's right-hand side is affine in y: its matrix, by central differences."""
    jac = np.zeros((2 * n, 2 * n))
    for k in range(2 * n):
        e = np.zeros(2 * n)
        e[k] = 1e-3
        jac[:, k] = (model.derivative(0.3, e, False) - model.derivative(0.3, -e, False)) / 2e-3
    return jac


def contact_spectrum(model, states, taus, n):
    """Largest |eigenvalue| of the in-contact Jacobian at each given state (central differences)."""
    largest = []
    for y, tau in zip(states, taus):
        jac = np.zeros((2 * n, 2 * n))
        for k in range(2 * n):
            e = np.zeros(2 * n)
            e[k] = 1e-7 * max(1e-6, abs(y[k]))
            jac[:, k] = (model.derivative(tau, y + e, True) - model.derivative(tau, y - e, True)) / (2 * e[k])
        largest.append(np.max(np.abs(np.linalg.eigvals(jac))))
    return min(largest), max(largest)


def integrate(model, jac, y0, t0, t1, rtol, atol, scale, lawson):
    t, y, h = t0, y0.copy(), 1e-3
    steps = rejected = 0
    weight = atol + rtol * scale
    while t < t1 - 1e-14:
        h = min(h, t1 - t)
        k = np.zeros((12, len(y)))
        if lawson:
            turn = [expm(jac * c * h) for c in NODES]
            back = [np.linalg.inv(m) for m in turn]

            def g(i, v):
                yy = turn[i] @ v
                return back[i] @ (model.derivative(t + NODES[i] * h, yy, True) - jac @ yy)
        else:
            def g(i, v):
                return model.derivative(t + NODES[i] * h, v, True)
        k[0] = g(0, y)
        for s in range(1, 12):
            k[s] = g(s, y + h * (k[:s].T @ A_STAGE[s, :s]))
        y_new = y + h * (k.T @ B_WEIGHT)
        err5, err3 = h * (k.T @ E5), h * (k.T @ E3)
        if lawson:
            end = expm(jac * h)
            y_new, err5, err3 = end @ y_new, end @ err5, end @ err3
        s5, s3 = np.sum((err5 / weight) ** 2), np.sum((err3 / weight) ** 2)
        norm = s5 / np.sqrt((s5 + 0.01 * s3) * len(y)) if s5 + s3 > 0 else 0.0
        if norm <= 1:
            t, y, steps = t + h, y_new, steps + 1
            h *= min(6.0, max(1 / 3, 0.9 * norm ** (-1 / 8))) if norm > 0 else 6.0
        else:
            rejected += 1
            h *= max(1 / 3, 0.9 * norm ** (-1 / 8))
    return y, steps, rejected


def reference_contact(overrides):
    """A 30-period flight_exact run of the scene at rtol 1e-12 and one contact late in it: the run,
    its model, the sampled states, each component's largest size over the second half, and the
    sample indices of the contact's first and last samples."""
    cfg = tmafm.Config("fig2_n4", **overrides,
                       solver={"method": "flight_exact", "tau_end": 30 * PERIOD,
                               "rtol": 1e-12, "atol": 1e-15})
    run, model = tmafm.run(cfg), tmafm.Model(cfg)
    contact = run.contact.astype(bool)
    edges = np.nonzero(np.diff(contact.astype(int)))[0]
    first = [i + 1 for i in edges if contact[i + 1] and i > 0.6 * len(contact)][0]
    last = [i for i in edges if contact[i] and i > first][0]
    states = np.hstack([run.a, run.adot])
    scale = np.max(np.abs(states[len(states) // 2:]), axis=0)
    return run, model, states, scale, first, last


def main() -> None:
    print("| scene | rtol, atol | span | plain: steps, rejected | Lawson: steps, rejected "
          "| end error / scale, plain, Lawson |")
    print("|---|---|---|---|---|---|")
    spectra = []
    for name, overrides in SCENES.items():
        run, model, states, scale, first, last = reference_contact(overrides)
        jac = free_jacobian(model, run.n_modes)
        t0, t1 = run.tau[first + 2], run.tau[last - 2]
        low, high = contact_spectrum(model, states[first:last + 1], run.tau[first:last + 1], run.n_modes)
        spectra.append(f"{name}: largest |eigenvalue| free {np.max(np.abs(np.linalg.eigvals(jac))):.2f}, "
                       f"in contact {low:.2f} to {high:.2f}")
        for rtol, atol in ((1e-7, 1e-10), (1e-10, 1e-14)):
            out = [integrate(model, jac, states[first + 2], t0, t1, rtol, atol, scale, law)
                   for law in (False, True)]
            errors = [np.max(np.abs(y - states[last - 2]) / scale) for y, _, _ in out]
            print(f"| {name} | {rtol:g}, {atol:g} | {t1 - t0:.2f} | {out[0][1]}, {out[0][2]} | "
                  f"{out[1][1]}, {out[1][2]} | {errors[0]:.1e}, {errors[1]:.1e} |")
    print("\n".join(spectra))


if __name__ == "__main__":
    main()
