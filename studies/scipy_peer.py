"""The scipy peer: the model's right-hand side written in numpy and integrated with
``scipy.integrate.solve_ivp``, phase by phase, with every switch V_T = 0 a terminal event.

This is deliberately what a Python user would write, and it exists only to be measured
against (benchmarks/period_cost.py, studies/work_precision.py; not part of the package).  Like
the independent reference in ``tests/reference``, it is a second implementation on purpose: it
takes the Galerkin
constants from the core (``tmafm.Model``, in memory) but writes the contact law and the
equations of motion (docs/model.md §6-7) again, in numpy.
"""

from __future__ import annotations

import math
import time

import numpy as np

from tmafm import Model

__all__ = ["ScipyPeer"]


class ScipyPeer:
    """solve_ivp with events on a numpy right-hand side, for one namelist."""

    def __init__(self, nml, **overrides):
        model = Model(nml, **overrides)
        n, scene, resolved = model.n_modes, model.scene, model.config.to_namelist()
        mass, eigen, axial, tip, slope = model.mass, model.eigen, model.axial, model.tip, model.slope
        mass_point, moment_shape, integral, kappas = (model.mass_point, model.moment_shape,
                                                      model.integral, model.kappas)
        self.n = n
        self.scene = scene
        self.resolved = resolved
        errata = str(resolved["model"]["errata"]).upper().split(",")
        self.velocity_damping = "E1" in errata
        self.signed_slope = "E7" in errata
        self.dmt = resolved["model"]["contact_law"] == "dmt"
        inv_mass = np.linalg.inv(mass)
        s = scene
        self.p, self.s, self.r = tip, slope, moment_shape
        self.kappa5, self.kappa6 = kappas
        self.minv = inv_mass
        self.minv_lambda = inv_mass * eigen[None, :]
        self.minv_axial = inv_mass @ axial
        self.minv_p = inv_mass @ tip
        self.minv_r = inv_mass @ moment_shape
        self.drive_sin = s["alpha2"] * s["omega"] ** 2 * inv_mass @ (s["alpha1"] * mass_point + integral)
        self.drive_cos = -s["alpha2"] * s["alpha3"] * s["omega"] * inv_mass @ integral
        self.a0 = np.zeros(n)
        self.adot0 = np.zeros(n)
        initial = resolved.get("initial", {})
        for key, target in (("a0", self.a0), ("adot0", self.adot0)):
            values = np.atleast_1d(np.asarray(initial.get(key, []), dtype=float))
            target[: min(n, values.size)] = values[:n]

    def gap(self, t, y):
        s = self.scene
        return self.p @ y[: self.n] + s["alpha2"] * math.sin(s["omega"] * t) + s["delta_hat"]

    def rhs(self, t, y, in_contact):
        n, s = self.n, self.scene
        a, adot = y[:n], y[n:]
        st, ct = math.sin(s["omega"] * t), math.cos(s["omega"] * t)
        acc = (-s["alpha3"] * (self.minv @ adot) - self.minv_lambda @ a
               + self.drive_sin * st + self.drive_cos * ct)
        if in_contact:
            vt = self.p @ a + s["alpha2"] * st + s["delta_hat"]
            scaled_slope = (self.s @ a) / s["l_over_d"]
            if self.signed_slope:
                theta1 = math.pi / 2 - s["theta"] + math.atan(scaled_slope)
            else:
                theta1 = math.pi / 2 - s["theta"] - math.atan(abs(scaled_slope))
            depth = max(-vt, 0.0)
            radius = math.sqrt(depth * math.sin(theta1) / s["beta"])
            normal = radius**3 - (4.0 / 3.0 if self.dmt else 0.0)
            friction = radius * depth * math.cos(theta1)
            p1 = self.kappa5 * normal * math.sin(theta1) + self.kappa6 * friction * math.cos(theta1)
            p2 = -self.kappa5 * normal * math.cos(theta1) + self.kappa6 * friction * math.sin(theta1)
            if self.velocity_damping:
                base = -s["alpha2"] * s["alpha4"] * s["omega"] * ct
            else:
                base = -s["alpha2"] * s["alpha4"] * st
            push = -s["alpha4"] * (self.p @ adot) + base + s["l_over_d"] * p1
            acc = acc + push * self.minv_p + p2 * (self.minv_axial @ a) + s["g0_over_d"] * p2 * self.minv_r
        return np.concatenate([adot, acc])

    def solve(self, tau_end, sample_dtau, method="DOP853", rtol=1e-8, atol=1e-14):
        """V_T at the samples, the number of right-hand-side evaluations, the switch times
        and the wall time."""
        from scipy.integrate import solve_ivp

        start = time.perf_counter()
        samples = np.arange(int(round(tau_end / sample_dtau)) + 1) * sample_dtau
        vt = np.empty_like(samples)
        y = np.concatenate([self.a0, self.adot0])
        t = 0.0
        g = self.gap(t, y)
        rate = self.p @ y[self.n:] + self.scene["alpha2"] * self.scene["omega"]
        in_contact = g < 0 or (g == 0 and rate <= 0)
        # The switch is placed a little past zero, above V_T's round-off, so that a restart
        # on V_T = 0 does not see the same switch again.
        margin = 1e-15
        nfev, switches, k = 0, [], 0
        while t < samples[-1]:
            side = -1.0 if in_contact else 1.0

            def event(tt, yy, _in_contact, side=side):  # solve_ivp passes args to events too
                return side * self.gap(tt, yy) + margin
            event.terminal = True
            event.direction = -1
            sol = solve_ivp(self.rhs, (t, samples[-1]), y, method=method, rtol=rtol, atol=atol,
                            events=event, dense_output=True, args=(in_contact,))
            nfev += sol.nfev
            if not sol.success:
                raise RuntimeError(f"solve_ivp ({method}) failed at tau = {sol.t[-1]}: {sol.message}")
            t_end = sol.t[-1]
            while k < samples.size and samples[k] <= t_end:
                vt[k] = self.gap(samples[k], sol.sol(samples[k]))
                k += 1
            t, y = t_end, sol.y[:, -1]
            if sol.status == 1:
                switches.append(t)
                in_contact = not in_contact
        while k < samples.size:
            vt[k] = self.gap(samples[k], y)
            k += 1
        return {"vt": vt, "rhs_evaluations": nfev, "switches": np.array(switches),
                "seconds": time.perf_counter() - start}
