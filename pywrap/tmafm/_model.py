"""The equations of motion in Python's hands: a thin class over the core's ``model_t``.

Every method calls the type-bound procedure of ``model_t`` that the integrators call
(``fortran/src/physics/tmafm_model.f90``); no physics is written here.  The arrays of the model
(p, s, q, G, M, ...) are returned as copies, so they never dangle.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._fortran import api as _api
from ._namelist import _NOT_NUMBERS, shown
from ._run import Config
from .errors import InputError, raise_for

__all__ = ["Model", "ContactState", "POWER_NAMES"]

#: The powers of Model.energy_flow, in the core's order (tmafm_model power_* indices).
POWER_NAMES = ("drive", "beam_damping", "contact_damping", "contact_normal", "contact_friction",
               "contact_viscoelastic", "contact_adhesion")


class ContactState(NamedTuple):
    """The contact at one state: tip gap, angle, radius, force groups and the brackets of Eq. (11)."""

    vt: float
    theta1: float
    radius: float
    normal: float
    friction: float
    transverse: float
    axial: float


def _finite_array(name: str, value, dtype=np.float64, order="C") -> np.ndarray:
    """`value` as a float array; InputError for anything that is not finite real numbers."""
    try:
        array = np.asarray(value)
        if np.iscomplexobj(array):
            raise TypeError("complex numbers are not real")
        array = np.require(array, dtype=dtype, requirements=order)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"{name} must be real numbers: {shown(str(exc))[1:-1]}") from None
    if not np.all(np.isfinite(array)):
        raise InputError(f"{name} must be finite numbers, got {shown(value)}")
    return array


def _vector(name: str, value, size: int) -> np.ndarray:
    array = _finite_array(name, value)
    if array.shape != (size,):
        raise InputError(f"{name} must have shape ({size},), got {array.shape}")
    return array


#: The largest |tau| the methods take: the largest &solver tau_end (tmafm_namelist), so every
#: time a run reaches is in range (Omega tau, and so the drive, stays finite).
MAX_TAU = 1.0e7


def _time(tau) -> float:
    if isinstance(tau, (str, bytes, bool, np.bool_)):
        raise InputError(f"tau must be a number, got {shown(tau)}")
    try:
        value = float(tau)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"tau must be a finite number, got {shown(tau)}") from None
    if not np.isfinite(value):
        raise InputError(f"tau = {shown(tau)}: must be finite")
    if abs(value) > MAX_TAU:
        raise InputError(f"tau = {shown(tau)}: must be within +-{MAX_TAU:g} (the largest &solver "
                         f"tau_end)")
    return value


def _finite_result(method: str, arguments: dict, **outputs) -> None:
    """InputError naming the state `arguments` ({name: value}) when an output of `method` is
    not finite: the state lies outside what the model covers (e.g. an indentation past the
    tip's geometry, or values so large that the forces overflow)."""
    for name, value in outputs.items():
        if not np.isfinite(value).all():
            given = ", ".join(f"{key} = {shown(array)}" for key, array in arguments.items())
            raise InputError(f"Model.{method}: {given} gives {name} = {shown(value)}, not "
                             f"finite: the state is outside the range the model covers")


def _phase(in_contact) -> bool:
    """in_contact: a bool (or 0/1); anything else ("no", None, 2) is an InputError."""
    if isinstance(in_contact, (bool, np.bool_)) or (
            isinstance(in_contact, (int, np.integer)) and not isinstance(in_contact, _NOT_NUMBERS)
            and in_contact in (0, 1)):
        return bool(in_contact)
    raise InputError(f"in_contact must be True or False, got {shown(in_contact)}")


class Model:
    """The model of an input: ``Model("fig2_n4")``, ``Model({"model": {"n_modes": 3}})``,
    ``Model(path, model={"convention": "consistent"})`` or ``Model(config)``.

    Properties (copies): n_modes, scene, beta (mode roots), tip (p = phi(xi0)),
    slope (s = phi'(xi0)), integral (q), axial (G), mass (M), eigen (Lambda = beta^4).
    """

    def __init__(self, nml=None, **overrides):
        config = nml if isinstance(nml, Config) and not overrides else Config(nml, **overrides)
        handle, ierr, errmsg = _api.model_of_config(config._f)
        raise_for(ierr, errmsg)
        self.config = config
        self._f = handle
        self.n_modes = int(handle.n_modes)

    def __reduce__(self):
        # The core's model_t lives in this process: a pickle rebuilds it from the Config.
        return (Model, (self.config,))

    @property
    def scene(self) -> dict:
        """The dimensionless groups."""
        return self.config.scene

    def _copy(self, name: str) -> np.ndarray:
        return np.array(getattr(self._f, name), order="F", copy=True)

    beta = property(lambda self: self._copy("beta"), doc="Mode roots beta_j.")
    eigen = property(lambda self: self._copy("eigen"), doc="Modal stiffnesses Lambda = beta^4.")
    tip = property(lambda self: self._copy("tip"), doc="p = phi(xi0), where the contact acts.")
    slope = property(lambda self: self._copy("slope"), doc="s = phi'(xi0), the tip slopes.")
    integral = property(lambda self: self._copy("integral"), doc="q = int_0^1 phi.")
    axial = property(lambda self: self._copy("axial"), doc="G_ij = int phi_i phi_j''.")
    mass = property(lambda self: self._copy("mass"), doc="M = I + alpha1 m m^T.")
    mass_point = property(lambda self: self._copy("mass_point"), doc="m: where the tip mass sits.")
    moment_shape = property(lambda self: self._copy("moment_shape"), doc="r: the moment shape.")
    kappas = property(lambda self: (float(self._f.kappa5), float(self._f.kappa6)),
                      doc="(kappa5, kappa6): the force scales of the brackets.")

    def derivative(self, tau: float, y, in_contact: bool) -> np.ndarray:
        """dy/dtau of the state y = (a, a') in a phase: (a', a''), length 2N.  With a viscoelastic
        sample (scene sls_relaxation_time > 0) y = (a, a', w, 0) and dy/dtau = (a', a'', w', 0),
        length 2N + 2 (docs/model.md, section 14)."""
        n = self.n_modes
        size = 2 * n + (2 if self.scene.get("sls_relaxation_time", 0.0) > 0 else 0)
        y = _vector("y", y, size)
        rate = np.zeros(size)
        self._f.derivative(_time(tau), y, _phase(in_contact), rate)
        _finite_result("derivative", {"y": y}, rate=rate)
        return rate

    def matrices(self, tau: float, a, in_contact: bool):
        """(M, C, K, F) of Eq. (15) at displacements a: M a'' + C a' + K a = F."""
        n = self.n_modes
        a = _vector("a", a, n)
        mass, damping, stiffness = (np.zeros((n, n), order="F") for _ in range(3))
        force = np.zeros(n)
        self._f.matrices(_time(tau), a, _phase(in_contact), mass, damping, stiffness, force)
        _finite_result("matrices", {"a": a}, M=mass, C=damping, K=stiffness, F=force)
        return mass, damping, stiffness, force

    def contact(self, tau: float, a) -> ContactState:
        """V_T and the contact state (theta1, radius A, f_c, h, P1, P2) at displacements a."""
        n = self.n_modes
        a = _vector("a", a, n)
        vt = float(self._f.tip_gap(_time(tau), a))
        s = self._f.contact(_time(tau), a)
        state = ContactState(vt, float(s.theta1), float(s.radius), float(s.normal),
                             float(s.friction), float(s.transverse), float(s.axial))
        _finite_result("contact", {"a": a},
                       **{name: getattr(state, name) for name in ContactState._fields})
        return state

    def energy_flow(self, tau: float, a, adot, in_contact: bool) -> dict:
        """The power of each generalized force (POWER_NAMES) and the modal energy ('energy')."""
        n = self.n_modes
        a = _vector("a", a, n)
        adot = _vector("adot", adot, n)
        power = np.zeros(len(POWER_NAMES))
        energy = self._f.energy_flow(_time(tau), a, adot, _phase(in_contact), power)
        out = dict(zip(POWER_NAMES, map(float, power)))
        out["energy"] = float(energy)
        _finite_result("energy_flow", {"a": a, "adot": adot}, **out)
        return out

    def trajectory_energy_flow(self, tau, a, adot, contact):
        """Along samples: (powers samples x 5, energy, contact state samples x 6)."""
        tau = _finite_array("tau", tau)
        if tau.size and np.max(np.abs(tau)) > MAX_TAU:
            raise InputError(f"tau must be within +-{MAX_TAU:g} (the largest &solver tau_end)")
        a = _finite_array("a", a, order="F")
        adot = _finite_array("adot", adot, order="F")
        try:
            phases = np.asarray(contact)
        except (TypeError, ValueError) as exc:
            raise InputError(f"contact must be 0 or 1 per sample: {shown(str(exc))[1:-1]}") \
                from None
        if phases.dtype.kind not in "biuf" or not np.all((phases == 0) | (phases == 1)):
            raise InputError(f"contact must be 0 or 1 (or bools) per sample, got {shown(contact)}")
        contact = np.ascontiguousarray(phases, dtype=np.int32)
        k = tau.size
        if tau.ndim != 1 or a.shape != (k, self.n_modes) or adot.shape != a.shape \
                or contact.shape != (k,):
            raise InputError(f"a and adot must be samples x N = ({k}, {self.n_modes}), and "
                             f"contact of length {k}")
        power = np.zeros((k, len(POWER_NAMES)), order="F")
        energy = np.zeros(k)
        state = np.zeros((k, 6), order="F")
        _api.trajectory_energy_flow(self._f, tau, a, adot, contact, power, energy, state)
        finite = np.isfinite(power).all(axis=1) & np.isfinite(energy) & np.isfinite(state).all(axis=1)
        if not finite.all():
            k = int(np.flatnonzero(~finite)[0])
            raise InputError(f"Model.trajectory_energy_flow: sample {k} (a = {shown(a[k])}, adot = "
                             f"{shown(adot[k])}) gives powers or a contact state that are not "
                             f"finite: the state is outside the range the model covers")
        return power, energy, state

    def __repr__(self) -> str:
        return f"tmafm.Model({self.config.label!r}, n_modes={self.n_modes})"
