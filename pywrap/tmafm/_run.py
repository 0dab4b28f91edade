"""Running a namelist through the Fortran core and returning numpy arrays.

No physics here: the input is handed to the core as a namelist file (written with
f90nml when it comes as a dict), and the arrays come back from ``tmafm._core.run``.
"""

from __future__ import annotations

import copy
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Union

import f90nml
import numpy as np

from . import _core
from .errors import InputError, InputFileError, raise_for

__all__ = ["Result", "run", "resolve", "SCENE_KEYS"]

#: The order of the dimensionless groups returned by the core.
SCENE_KEYS = ("alpha1", "alpha2", "alpha3", "alpha4", "alpha5", "alpha6", "beta", "omega",
              "theta", "l_over_d", "g0_over_d", "delta_hat", "xi0")

NamelistLike = Union[str, os.PathLike, Mapping]


@dataclass
class Result:
    """A sampled trajectory and the fully resolved input that produced it.

    Arrays have one row per sample, at ``tau = k * sample_dtau``.  ``a`` and ``adot`` are
    samples x N (Fortran order).  ``contact`` is 1 where V_T <= 0 at the sample.
    ``switches`` holds the times of the phase changes: located switches for the located
    methods, and the step starts where the phase changed for ``rk4_paper``.
    ``counters`` has steps, contact_steps, rejected_steps, rhs_evaluations, phase_switches.
    """

    tau: np.ndarray
    vt: np.ndarray
    vtdot: np.ndarray
    contact: np.ndarray
    a: np.ndarray
    adot: np.ndarray
    resolved: f90nml.Namelist
    scene: dict
    counters: dict = field(default_factory=dict)
    switches: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def n_modes(self) -> int:
        """Number of Galerkin modes N."""
        return self.a.shape[1]


def _merge(base: Mapping, overrides: Mapping) -> dict:
    """Groups of `base` patched key by key with those of `overrides`."""
    merged = {}
    for source in (base, overrides):
        for group, values in source.items():
            if not isinstance(values, Mapping):
                raise InputError(f"&{group}: a group must be a dict of keys, got {values!r}")
            merged.setdefault(str(group).lower(), {}).update(values)
    return merged


class _NamelistFile:
    """The namelist as a file path: the user's own file, or a temporary one written by f90nml."""

    def __init__(self, nml: NamelistLike, overrides: Mapping | None):
        self._temporary = None
        self.label = "<dict input>"
        if isinstance(nml, (str, os.PathLike)):
            path = Path(nml)
            self.label = str(path)
            if not path.is_file():
                raise InputFileError(f"input file '{path}' not found")
            if not overrides:
                self.path = str(path)
                return
            try:
                groups = f90nml.read(str(path))
            except Exception as exc:  # f90nml raises assorted errors on malformed files
                raise InputError(f"{path}: cannot parse namelist: {exc}") from exc
        elif isinstance(nml, Mapping):
            groups = copy.deepcopy(dict(nml))
        else:
            raise TypeError(f"nml must be a path or a dict of groups, not {type(nml).__name__}")
        groups = _merge(groups, overrides or {})
        handle = tempfile.NamedTemporaryFile("w", suffix=".nml", delete=False)
        handle.close()
        self._temporary = handle.name
        f90nml.write(f90nml.Namelist(groups), handle.name, force=True)
        self.path = handle.name

    def check(self, ierr, errmsg) -> None:
        """Raise for a core error, naming the user's input rather than a temporary file."""
        if isinstance(errmsg, (bytes, bytearray)):
            errmsg = errmsg.decode("utf-8", "replace")
        raise_for(ierr, str(errmsg).strip().replace(self.path, self.label))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._temporary is not None:
            os.unlink(self._temporary)


def _resolve_source(source: _NamelistFile):
    with tempfile.TemporaryDirectory() as scratch:
        resolved_file = os.path.join(scratch, "resolved.nml")
        n_modes, n_samples, scene, ierr, errmsg = _core.resolve(source.path, resolved_file)
        source.check(ierr, errmsg)
        resolved = f90nml.read(resolved_file)
    return int(n_modes), int(n_samples), dict(zip(SCENE_KEYS, map(float, scene))), resolved


def resolve(nml: NamelistLike, **overrides) -> tuple[f90nml.Namelist, dict]:
    """Validate an input and return (the resolved namelist, the dimensionless scene).

    ``overrides`` are groups to patch, e.g. ``resolve(path, solver={'tau_end': 5})``.
    """
    with _NamelistFile(nml, overrides) as source:
        _, _, scene, resolved = _resolve_source(source)
    return resolved, scene


def run(nml: NamelistLike, max_switches: int = 100_000, **overrides) -> Result:
    """Run a namelist file (path) or a dict of groups, as f90nml gives, and return a Result.

    ``overrides`` patch groups, e.g. ``run('inputs/fig2_n4.nml', solver={'tau_end': 10})``.
    ``max_switches`` bounds the number of phase changes returned in ``Result.switches``.
    Raises InputError (a ValueError) for bad values, InputFileError for a missing file
    and BlowUpError when the integration diverges.
    """
    with _NamelistFile(nml, overrides) as source:
        n_modes, n_samples, scene, resolved = _resolve_source(source)
        (tau, vt, vtdot, contact, a, adot, switch_tau, counters, ierr, errmsg) = _core.run(
            source.path, n_samples, n_modes, max_switches)
        source.check(ierr, errmsg)
    counters = dict(zip(("steps", "contact_steps", "rejected_steps", "rhs_evaluations",
                         "phase_switches"), map(int, counters)))
    return Result(
        tau=tau, vt=vt, vtdot=vtdot, contact=contact.astype(np.int8), a=a, adot=adot,
        resolved=resolved, scene=scene, counters=counters,
        switches=np.array(switch_tau[:counters["phase_switches"]]))
