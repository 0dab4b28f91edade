"""The composed peer: every optional part of the model (a drive of one or two tones with phases,
a liquid, a viscoelastic sample, van der Waals attraction, the electrostatic and double-layer
forces at a distance, a JKR neck, a capillary meniscus) written again in numpy from
docs/model.md, and integrated with ``scipy.integrate.solve_ivp`` (DOP853) phase by phase, with
every switch (V_T = 0, a neck's pull-off, a meniscus's rupture) a terminal event.

It is a second implementation on purpose, the oracle of tests/test_compose.py: it takes the
Galerkin constants and the liquid's per-mode mass and damping from the core (``tmafm.Model``,
in memory: the matrices of Eq. (15) out of contact), and writes the drive, the contact law, the
sample, the attraction and the way they add up (docs/model.md, "How the parts compose") itself.
Not part of the package.
"""

from __future__ import annotations

import math

import numpy as np

from tmafm import Model

__all__ = ["ComposedPeer"]


class ComposedPeer:
    """solve_ivp with events on a numpy right-hand side that composes all the parts."""

    def __init__(self, nml, **overrides):
        model = Model(nml, **overrides)
        n, s, resolved = model.n_modes, model.scene, model.config.to_namelist()
        self.n, self.scene = n, s
        errata = str(resolved["model"]["errata"]).upper().split(",")
        self.velocity_damping = "E1" in errata
        self.signed_slope = "E7" in errata
        self.law = resolved["model"]["contact_law"]
        # M (with a liquid's added mass mu) and C (alpha3 + the liquid's damping) per mode: the
        # matrices of Eq. (15) out of contact, at tau = 0 and a = 0.
        mass, damping, _, _ = model.matrices(0.0, np.zeros(n), False)
        self.minv = np.linalg.inv(mass)
        self.c = np.diag(damping).copy()
        bare = np.eye(n) + s["alpha1"] * np.outer(model.mass_point, model.mass_point)
        self.mu = np.diag(mass) - np.diag(bare)
        q = model.integral
        self.inertial = self.minv @ (s["alpha1"] * model.mass_point + (1 + self.mu) * q)
        self.damped = self.minv @ (self.c * q)
        self.minv_lambda = self.minv * model.eigen[None, :]
        self.minv_axial = self.minv @ model.axial
        self.minv_p = self.minv @ model.tip
        self.minv_r = self.minv @ model.moment_shape
        self.p, self.slope = model.tip, model.slope
        self.kappa5, self.kappa6 = model.kappas
        self.tones = [(s["alpha2"], s["omega"], s["drive_phase"])]
        if s["alpha2_2"] != 0:
            self.tones.append((s["alpha2_2"], s["omega_2"], s["drive_phase_2"]))
        self.sls = s["sls_relaxation_time"] > 0
        # The forces at a distance (docs/model.md §17): on when their strengths are.
        self.electrostatic = s["electrostatic_strength"] > 0
        self.double_layer = s["double_layer_strength"] != 0
        self.far = self.law == "dmt_vdw" or self.electrostatic or self.double_layer
        # The capillary meniscus (docs/model.md §19): -c_C in contact, -c_C (1 - g/D) in a flight
        # it holds, g = V_T sin(theta1) the normal gap; it breaks at g = D.
        self.meniscus = s["capillary_strength"] > 0
        self.size = 2 * n + (1 if self.sls else 0)

    def base(self, t):
        """Y, Y' and Y'' of the drive at t."""
        y = sum(a * math.sin(w * t + phi) for a, w, phi in self.tones)
        rate = sum(a * w * math.cos(w * t + phi) for a, w, phi in self.tones)
        accel = -sum(a * w * w * math.sin(w * t + phi) for a, w, phi in self.tones)
        return y, rate, accel

    def gap(self, t, y):
        """V_T = p.a + Y + delta_hat."""
        return self.p @ y[: self.n] + self.base(t)[0] + self.scene["delta_hat"]

    def theta1(self, a):
        s = self.scene
        t = (self.slope @ a) / s["l_over_d"]
        if self.signed_slope:
            return math.pi / 2 - s["theta"] + math.atan(t)
        return math.pi / 2 - s["theta"] - math.atan(abs(t))

    def distant(self, separation):
        """The forces at a distance at separation s/d: Hudlet's sphere + cone and the screened
        double layer, in the units of §6 (docs/model.md §17)."""
        s = self.scene
        f = 0.0
        if self.electrostatic:
            rho, angle, height = s["electrostatic_radius"], s["cone_half_angle"], s["g0_over_d"]
            b = rho * (1 - math.sin(angle))
            sphere = rho**2 * (1 - math.sin(angle)) / (separation * (separation + b))
            cone = (math.log(height / (separation + b)) - 1
                    + rho * math.cos(angle)**2 / math.sin(angle) / (separation + b)) / math.log(math.tan(angle / 2))**2
            f -= s["electrostatic_strength"] * (sphere + cone)
        if self.double_layer:
            f += s["double_layer_strength"] * math.exp(-separation / s["double_layer_range"])
        return f

    def normal_group(self, vt, theta1, w, in_contact, wet=False):
        """The normal force group f (units of §6) and the Hertz variable X; wet: a meniscus holds
        the tip in flight."""
        s = self.scene
        eps = s["vdw_range"]
        if not in_contact:
            f = 0.0
            if wet:
                f -= s["capillary_strength"] * (1 - vt * math.sin(theta1) / s["capillary_range"])
            if self.law == "dmt_vdw":
                ratio = max(1 + vt * max(math.sin(theta1), 0.0) / eps, 0.5)
                f -= s["vdw_adhesion"] / ratio**2
            if self.electrostatic or self.double_layer:
                f += self.distant(max(eps + vt * max(math.sin(theta1), 0.0), eps / 2))
            return f, 0.0
        if self.law == "jkr":
            # The JKR neck (docs/model.md §18): D = A^2 - (4/3) sqrt(A), f = A^3 - 2 A^1.5 on the
            # stable branch sqrt(A) >= 3^(-1/3), the largest real root of x^4 - (4/3) x - D.
            x = math.sqrt(self.jkr_radius(vt, theta1))
            f = x**6 - 2 * x**3
            if self.electrostatic or self.double_layer:
                f += self.distant(max(s["vdw_range"] + vt * max(math.sin(theta1), 0.0), s["vdw_range"]))
            return f, 0.0
        x = (max(-vt, 0.0) * math.sin(theta1) / s["beta"]) ** 1.5
        f = max(x - (1 - s["sls_modulus_ratio"]) * w, 0.0) if self.sls else x
        if self.law == "dmt":
            f -= 4.0 / 3.0
        elif self.law == "dmt_vdw":
            f -= s["vdw_adhesion"]
        if self.electrostatic or self.double_layer:
            f += self.distant(eps)
        if self.meniscus:
            f -= s["capillary_strength"]
        return f, x

    def rhs(self, t, y, in_contact, wet=False):
        n, s = self.n, self.scene
        a, adot = y[:n], y[n:2 * n]
        w = y[2 * n] if self.sls else 0.0
        base, rate, accel = self.base(t)
        acc = (-self.minv @ (self.c * adot) - self.minv_lambda @ a
               - accel * self.inertial - rate * self.damped)
        x = 0.0
        if in_contact or self.far or wet:
            vt = self.p @ a + base + s["delta_hat"]
            th = self.theta1(a)
            f, x = self.normal_group(vt, th, w, in_contact, wet)
            depth = max(-vt, 0.0)
            friction = math.sqrt(depth * math.sin(th) / s["beta"]) * depth * math.cos(th) if in_contact else 0.0
            if in_contact and self.law == "jkr":
                # The neck's radius (A = x^2) with the signed depth.
                depth = -vt
                radius = self.jkr_radius(vt, th)
                friction = radius * depth * math.cos(th)
            p1 = self.kappa5 * f * math.sin(th) + self.kappa6 * friction * math.cos(th)
            p2 = -self.kappa5 * f * math.cos(th) + self.kappa6 * friction * math.sin(th)
            push = s["l_over_d"] * p1
            if in_contact:
                damper_base = rate if self.velocity_damping else base
                push += -s["alpha4"] * (self.p @ adot) - s["alpha4"] * damper_base
            acc = acc + push * self.minv_p + p2 * (self.minv_axial @ a) + s["g0_over_d"] * p2 * self.minv_r
        out = [adot, acc]
        if self.sls:
            relaxing = 1 - s["sls_modulus_ratio"]
            out.append([(max(x, relaxing * w) - w) / s["sls_relaxation_time"]])
        return np.concatenate(out)

    def jkr_radius(self, vt, theta1):
        """The JKR contact radius A at gap vt (the root of normal_group's quartic, squared)."""
        depth = -vt * math.sin(theta1) / self.scene["beta"]
        roots = np.roots([1.0, 0.0, 0.0, -4.0 / 3.0, -depth])
        real = [r.real for r in roots if abs(r.imag) <= 1e-9 * max(1.0, abs(r))]
        # Below the pull-off (a stage past the event) no root is real: the branch's end.
        x = max(real + [3 ** (-1 / 3)])
        return x * x

    def pull_off_gap(self, y):
        """The gap at which a JKR neck breaks, V_T = 3^(-1/3) beta/sin(theta1) (0 for other laws)."""
        if self.law != "jkr":
            return 0.0
        return 3 ** (-1 / 3) * self.scene["beta"] / math.sin(self.theta1(y[: self.n]))

    def solve(self, tau_end, sample_dtau, rtol=1e-11, atol=1e-15):
        """V_T at the samples 0, sample_dtau, ..., tau_end, from the state at rest."""
        from scipy.integrate import solve_ivp

        samples = np.arange(int(round(tau_end / sample_dtau)) + 1) * sample_dtau
        vt = np.empty_like(samples)
        y = np.zeros(self.size)
        t = 0.0
        g = self.gap(t, y)
        in_contact = g < 0 or (g == 0 and self.base(0.0)[1] <= 0)
        # The switch is placed a little past zero, above V_T's round-off, so that a restart on
        # V_T = 0 does not see the same switch again.
        margin = 1e-15
        k = 0
        wet = False
        while t < samples[-1]:
            side = -1.0 if in_contact else 1.0

            def event(tt, yy, _in_contact, _wet, side=side, in_contact=in_contact):
                offset = self.pull_off_gap(yy) if in_contact else 0.0
                return side * (self.gap(tt, yy) - offset) + margin

            def rupture(tt, yy, _in_contact, _wet):
                """A held flight ends where the normal gap reaches D."""
                return (self.scene["capillary_range"] - self.gap(tt, yy) * math.sin(self.theta1(yy[: self.n]))
                        + margin)
            events = [event, rupture] if wet else [event]
            for e in events:
                e.terminal = True
                e.direction = -1
            sol = solve_ivp(self.rhs, (t, samples[-1]), y, method="DOP853", rtol=rtol, atol=atol,
                            events=events, dense_output=True, args=(in_contact, wet))
            if not sol.success:
                raise RuntimeError(f"solve_ivp failed at tau = {sol.t[-1]}: {sol.message}")
            t_end = sol.t[-1]
            while k < samples.size and samples[k] <= t_end:
                vt[k] = self.gap(samples[k], sol.sol(samples[k]))
                k += 1
            t, y = t_end, sol.y[:, -1]
            if sol.status == 1:
                if wet and sol.t_events[1].size:
                    wet = False  # the meniscus breaks: a free flight
                elif in_contact:
                    in_contact, wet = False, self.meniscus  # it holds the tip as it leaves
                else:
                    in_contact = True
        return samples, vt
