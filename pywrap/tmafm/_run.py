"""Configurations and runs held in memory: Python input -> namelist text -> the core -> numpy.

No physics here and no file on the way: a dict is checked and written as namelist text
(``_namelist``), a path is read once, and the core parses the text (``tmafm_api``), runs it
without the GIL, and hands the arrays back from its own memory.  The resolved input is parsed
with f90nml only when ``.resolved`` is asked for.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Union

import f90nml
import numpy as np

from . import inputs as _inputs
from ._fortran import api as _api
from ._fortran import text as _text
from ._fortran import config_t as _config_t
from ._fortran import polls
from ._namelist import _NOT_NUMBERS, KEY_TYPES, check_groups, shown, to_text
from .errors import InputError, InputFileError, InputTypeError, SolverError, raise_for

__all__ = ["Config", "Result", "run", "resolve", "SCENE_KEYS", "COUNTER_KEYS"]

#: The dimensionless groups of a scene, in the core's order (its key table's &scene keys).
SCENE_KEYS = tuple(KEY_TYPES["scene"])
#: The work counters of a run, in the core's order.
COUNTER_KEYS = ("steps", "contact_steps", "rejected_steps", "rhs_evaluations", "phase_switches")

NamelistLike = Union[str, os.PathLike, Mapping, "Config"]


def _input_path(nml) -> Path:
    """An existing file, or the packaged input of that name; InputFileError otherwise."""
    try:
        path = Path(nml)
    except TypeError as exc:  # an os.PathLike whose __fspath__ gives neither str nor bytes
        raise InputTypeError(f"nml: {exc}") from None
    name = shown(str(path))
    try:
        if path.is_file():
            return path
        if path.exists():
            raise InputFileError(f"input file {name} is not a regular file")
        # exists() is False for a link to nothing, a link loop and an unreadable folder alike:
        # only a plain missing name goes on to the packaged inputs.
        try:
            path.stat()
        except FileNotFoundError:
            if path.is_symlink():
                raise InputFileError(f"input file {name} is a symbolic link to a missing file") from None
        if path.suffix in ("", ".nml") and (len(path.parts) == 1 or (
                len(path.parts) == 2 and path.parts[0] in _inputs.SUBFOLDERS)):
            try:
                return _inputs.path("/".join(path.parts))
            except InputFileError:
                pass
    except InputFileError:
        raise
    except (OSError, ValueError) as exc:  # a name too long, with a NUL byte, a link loop
        raise InputFileError(f"input file {name} cannot be used: "
                             f"{getattr(exc, 'strerror', None) or exc}") from None
    raise InputFileError(f"input file {name} not found, and no packaged input has that name "
                         f"(tmafm.inputs.names(): {', '.join(_inputs.names())})")


#: Largest input file, as the executable reads it (tmafm_input_file max_input_bytes).
MAX_INPUT_BYTES = 2**20
#: The first bytes of a tmafm output file (tmafm_nml_syntax output_header_mark).
_OUTPUT_MARK = b"# tmafm "


def _header_end(data: bytes) -> int:
    """Where the header of an output file ends in `data`: the start of the first line after the
    first that does not start with '#' (an empty one included), or len(data) if none does."""
    start = 0
    while True:
        end = data.find(b"\n", start)
        if end < 0 or end + 1 >= len(data):
            return len(data)
        start = end + 1
        if data[start:start + 1] != b"#":
            return start


def _read_text(path: Path) -> bytes:
    """The bytes of an input file, read as the executable reads them: at most 1 MiB, no NUL
    byte (f2py would end the text there, silently), and no decoding (a non-UTF-8 comment is
    fine; the core checks the bytes outside strings and comments)."""
    name = shown(str(path))
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_INPUT_BYTES + 1)
    except OSError as exc:
        raise InputFileError(f"input file {name} cannot be read: {exc.strerror}") from exc
    if data.startswith(_OUTPUT_MARK):
        # A tmafm output file: only its header is input (it ends at the first line that does
        # not start with '#'), however long the rows after it.
        data = data[:_header_end(data)]
    if len(data) > MAX_INPUT_BYTES:
        raise InputError(f"input file {name} is larger than {MAX_INPUT_BYTES} bytes: not a tmafm "
                         f"namelist")
    nul = data.find(b"\0")
    if nul >= 0 and not data.startswith((b"\xff\xfe", b"\xfe\xff")):  # UTF-16: the core says so
        line = data.count(b"\n", 0, nul) + 1
        raise InputError(f"{name}: line {line}: a NUL byte: the input is not a text file")
    return data


def _for_core(text) -> bytes:
    """Text for the core's character arguments: UTF-8 bytes, as the executable reads a file
    (the bytes of a file are passed as they are).
    (f2py turns a str with non-ASCII characters into no argument at all: a TypeError "function
    takes exactly 5 arguments (1 given)"; the core reports a non-ASCII value in its one-line
    message as \\xNN escapes.)"""
    if isinstance(text, bytes):
        return text
    try:  # the bytes of a non-UTF-8 file come back from Config.text as surrogate escapes
        return text.encode("utf-8", "surrogateescape")
    except UnicodeEncodeError:
        return text.encode("utf-8", "backslashreplace")


def _checked_max_switches(max_switches):
    if max_switches is None:
        return None
    if isinstance(max_switches, _NOT_NUMBERS) \
            or not isinstance(max_switches, (int, np.integer)) or max_switches < 0:
        raise InputError(f"max_switches = {shown(max_switches)}: must be an integer >= 0 or None")
    return int(max_switches)


def _check_known(groups: Mapping, what: str) -> None:
    """Unknown keys are named here, against the input they came from."""
    for group, values in groups.items():
        for key in values:
            if key not in KEY_TYPES[group]:
                raise InputError(f"{what}: &{group} {key}: unknown key (known: "
                                 f"{', '.join(KEY_TYPES[group])})")


def _source(nml, overrides: Mapping) -> tuple[str | bytes, str, str | None]:
    """(namelist text, label for messages, override text or None) of any accepted input.

    A text base (a file or a Config) keeps its own text; the core patches it with the
    override text key by key (tmafm_api config_from_texts), so no Python namelist parser runs.
    """
    override_text = None
    if overrides:
        what = f"override {shown(dict(overrides))}"
        overrides = check_groups(overrides, what)
        _check_known(overrides, what)
        override_text = to_text(overrides, what)
    if isinstance(nml, Config):
        return nml.text, nml.label, override_text
    if isinstance(nml, (str, os.PathLike)):
        path = _input_path(nml)
        return _read_text(path), str(path), override_text
    if isinstance(nml, Mapping):
        groups = check_groups(nml, "<dict input>")
        _check_known(groups, "<dict input>")
        if not groups:
            # As an empty file is refused, with overrides or without (the core says so for text).
            raise InputError("<dict input>: no namelist group given (an empty input is refused, "
                             "also with overrides; give {'model': {}} to run every default)")
        # Patched by the core like a file, so that a bad override is named as one.
        return to_text(groups), "<dict input>", override_text
    raise InputTypeError(f"nml must be a path, a packaged input name, a dict of groups or a Config, "
                         f"not {type(nml).__name__}")


class Config:
    """A validated, resolved input held in memory (the core's ``config_t``).

    Build it from a namelist path, a packaged input name (``tmafm.inputs.names()``), a dict of
    groups or another Config, plus overrides: ``Config("fig2_n4", solver={"tau_end": 10})``.
    The input is read once; N is chosen here when ``&model n_modes = 0``.
    """

    def __init__(self, nml: NamelistLike = None, **overrides):
        text, label, override_text = _source({} if nml is None else nml, overrides)
        # The handle exists before the call: a Ctrl-C in the comparison runs of an automatic N
        # raises out of the call, and a handle made inside it would be lost (tmafm_api).
        handle = _config_t()
        if override_text is None:
            ierr, errmsg = _api.config_from_text(_for_core(text), _for_core(label), handle, polls())
        else:
            label = f"{label} + overrides"
            ierr, errmsg = _api.config_from_texts(_for_core(text), _for_core(label[:-12]),
                                                  _for_core(override_text), _for_core(label),
                                                  handle, polls())
        raise_for(ierr, errmsg)
        self.label = label
        self._f = handle
        self._text = None
        self._scene = None

    def __reduce__(self):
        # The core's config_t lives in this process's memory: a copy for another process (a
        # pickle: multiprocessing, Dask) carries the resolved text and is read there again.
        return (_config_from_resolved_text, (self.text, self.label))

    @property
    def n_modes(self) -> int:
        """Number of Galerkin modes N (the chosen one when automatic)."""
        return int(self._f.n_modes)

    @property
    def n_samples(self) -> int:
        """Number of output samples a run gives."""
        return int(_api.config_sample_count(self._f))

    @property
    def mode_search(self) -> dict | None:
        """How N was chosen when ``&model n_modes = 0`` (None for a fixed N), as the header of
        the executable's output states it: ``n_modes`` (the N chosen), ``quantity`` (what was
        compared), ``differences`` ({N: that quantity for N against N+1}, each N compared, the
        core's values), ``mode_tol`` and ``mode_horizon``."""
        count = int(self._f.n_mode_differences)
        differences = {j + 1: float(self._f.mode_differences[j]) for j in range(count)}
        return _mode_search(self.text, differences)

    @property
    def scene(self) -> dict:
        """The dimensionless groups (also when the input gave &physical)."""
        if self._scene is None:
            s = self._f.scene
            self._scene = {key: float(getattr(s, key)) for key in SCENE_KEYS}
        return dict(self._scene)

    @property
    def derived(self) -> dict | None:
        """The values the core derives from ``&physical`` ({name: value}, in the units of
        ``tmafm.DERIVED_UNITS``), as the output header prints them: the beam (E1 I, m, C, M),
        the gap and drive the run uses, the N-mode model's own spring constant, first resonance,
        Q and free amplitude, the continuum 3 E1 I/x0^3 and the scales; None for an input given
        in ``&scene`` (docs/model.md section 12)."""
        names = list(DERIVED_UNITS)
        values = np.zeros(len(names))
        has_values, ierr, errmsg = _api.config_derived(self._f, values)
        raise_for(ierr, errmsg)
        return dict(zip(names, map(float, values))) if has_values else None

    @property
    def text(self) -> str:
        """The resolved input as namelist text (every key, defaults included)."""
        if self._text is None:
            codes = np.zeros(int(_api.config_text_length(self._f)), dtype=np.int32)
            _api.config_text_codes(self._f, codes)
            # UTF-8: the core holds the bytes _for_core gave it (a non-ASCII &output file);
            # bytes that are not UTF-8 (a Latin-1 file name) stay surrogate escapes, so that the
            # text gives back the same bytes (_for_core, write, pickles).
            self._text = codes.astype(np.uint8).tobytes().decode("utf-8", "surrogateescape")
        return self._text

    def to_namelist(self) -> f90nml.Namelist:
        """The resolved input as an f90nml Namelist."""
        return f90nml.reads(self.text)

    def to_dict(self) -> dict:
        """The resolved input as a dict of groups."""
        return {g: dict(v) for g, v in self.to_namelist().todict(complex_tuple=False).items()
                if not g.startswith("_")}

    def write(self, path) -> Path:
        """Write the resolved input to `path` (atomically: a temporary file, then a rename; a
        device or FIFO is written directly; InputFileError if it cannot be written)."""
        return _atomic_write(path, self.text.encode("utf-8", "surrogateescape"))

    def model(self):
        """The model of this configuration (a tmafm.Model)."""
        from ._model import Model
        return Model(self)

    def run(self, max_switches: int | None = None) -> "Result":
        """Run this configuration; the GIL is released while the core integrates."""
        max_switches = _checked_max_switches(max_switches)
        # A Ctrl-C stops the run: the exception Python's handler raised comes out of run_config
        # (tmafm_api_poll; on the main thread only); the handle, made here, is freed with it.
        handle = _api.run_t()
        ierr, errmsg = _api.run_config(self._f, handle, polls())
        raise_for(ierr, errmsg)
        n_samples, n_modes, n_switches = _api.run_sizes(handle)
        if max_switches is not None and n_switches > max_switches:
            raise SolverError(f"the run changed phase {n_switches} times, more than "
                              f"max_switches = {max_switches}")
        try:
            tau, vt, vtdot = (np.empty(n_samples) for _ in range(3))
            contact = np.empty(n_samples, dtype=np.int32)
            a, adot = (np.empty((n_samples, n_modes), order="F") for _ in range(2))
        except MemoryError as exc:
            raise SolverError(f"not enough memory to return {n_samples} samples of N = {n_modes} "
                              f"modes: raise &output sample_dtau") from exc
        _api.run_samples(handle, tau, vt, vtdot, contact, a, adot)
        switches = np.empty(n_switches)
        _api.run_switches(handle, switches)
        counters = np.zeros(5, dtype=np.int64)
        _api.run_counters(handle, counters)
        physical = None
        if bool(self._f.from_physical):
            # The SI series, from the core (tmafm_physical_series), as the executable writes them.
            series = np.empty((n_samples, len(SERIES_UNITS)), order="F")
            ierr, errmsg = _api.run_physical_series(self._f, handle, series)
            raise_for(ierr, errmsg)
            physical = {name: series[:, k].copy() for k, name in enumerate(SERIES_UNITS)}
        return Result(tau=tau, vt=vt, vtdot=vtdot, contact=contact.astype(np.int8), a=a,
                      adot=adot, counters=dict(zip(COUNTER_KEYS, map(int, counters))),
                      switches=switches, config=self, physical=physical)

    def __repr__(self) -> str:
        return f"tmafm.Config({self.label!r}, n_modes={self.n_modes})"


def _atomic_write(path, data: bytes) -> Path:
    """Write `data` to `path` as the executable writes its output: through a temporary and a
    rename for a file, directly for a device or FIFO (tmafm._safefile)."""
    from ._safefile import write_bytes
    return write_bytes(path, data)


class Result:
    """A sampled trajectory and the resolved input that produced it.

    Arrays have one row per sample, at ``tau = k * sample_dtau``.  ``a`` and ``adot`` are
    samples x N (Fortran order).  ``contact`` is 1 where V_T <= 0 at the sample.
    ``switches`` holds the times of the phase changes: located switches for the located
    methods, and the step starts where the phase changed for ``rk4_paper``.
    ``counters`` has steps, contact_steps, rejected_steps, rhs_evaluations, phase_switches.
    ``resolved`` (an f90nml Namelist) and ``scene`` are computed when first asked for.
    ``physical``, for a scene given in ``&physical``, holds the SI series the core computes
    (``tmafm.SERIES_UNITS``: time t_s, tip-sample distance distance_m, tip deflection
    deflection_m, normal_force_N and friction_force_N), one value per sample; None otherwise.
    """

    def __init__(self, tau, vt, vtdot, contact, a, adot, resolved=None, scene=None,
                 counters=None, switches=None, *, config: Config | None = None,
                 resolved_text: str | None = None, physical: dict | None = None):
        self.tau, self.vt, self.vtdot, self.contact, self.a, self.adot = (
            tau, vt, vtdot, contact, a, adot)
        self.physical = physical
        self.counters = dict(counters or {})
        self.switches = np.zeros(0) if switches is None else switches
        self.config = config
        self._resolved = resolved
        self._scene = scene
        self._resolved_text = resolved_text

    @property
    def n_modes(self) -> int:
        """Number of Galerkin modes N."""
        return self.a.shape[1]

    @property
    def resolved_text(self) -> str:
        """The resolved input as namelist text."""
        if self._resolved_text is None:
            if self.config is not None:
                self._resolved_text = self.config.text
            elif self._resolved is not None:
                self._resolved_text = str(self._resolved)
            else:
                raise AttributeError("this Result has no resolved input")
        return self._resolved_text

    @property
    def resolved(self) -> f90nml.Namelist:
        """The fully resolved input (an f90nml Namelist), parsed on first use."""
        if self._resolved is None:
            self._resolved = f90nml.reads(self.resolved_text)
        return self._resolved

    @resolved.setter
    def resolved(self, value) -> None:
        self._resolved = value

    @property
    def scene(self) -> dict:
        """The dimensionless groups actually used (also when given in SI units)."""
        if self._scene is None:
            if self.config is not None:
                self._scene = self.config.scene
            else:
                self._scene = _scene_of_text(self.resolved_text)
        return self._scene

    @scene.setter
    def scene(self, value) -> None:
        self._scene = value

    @property
    def derived(self) -> dict | None:
        """Config.derived of the run's input (for a Result read from a file, the header's
        ``! derived:`` lines); None for an input given in ``&scene``."""
        if self.config is not None:
            return self.config.derived
        return _derived_of_text(self.resolved_text)

    @property
    def mode_search(self) -> dict | None:
        """How N was chosen when ``&model n_modes = 0`` (None for a fixed N): Config.mode_search;
        for a Result read from a file, the differences as its header prints them (6 digits): its
        config then has N fixed to the recorded choice (tmafm.load runs no search) and no search."""
        if self.config is not None and self.config.mode_search is not None:
            return self.config.mode_search
        return _mode_search(self.resolved_text)

    def force_distance(self) -> tuple[np.ndarray, np.ndarray]:
        """The last drive period's (tip-sample distance in m, normal contact force in N), the
        samples with tau >= tau_end - 2 pi/Omega, straight from ``physical`` (the core's
        series): the force-distance curve of one tap.  InputError for a Result without SI
        series (a scene given in &scene), and for an undriven one (omega = 0: no period)."""
        if self.physical is None:
            raise InputError("Result.force_distance: this Result has no SI series (its scene "
                             "was not given in &physical)")
        omega = float(self.scene["omega"])
        if not omega > 0:
            raise InputError(f"Result.force_distance: &scene omega = {omega!r} (a drive frequency "
                             f"of 0): there is no drive period, so no last tap to take")
        period = 2 * np.pi / omega
        last = self.tau >= self.tau[-1] - period * (1 + 1e-12)
        return self.physical["distance_m"][last], self.physical["normal_force_N"][last]

    def save(self, path):
        """Save as .npz in the executable's binary layout (atomically); tmafm.load reads it."""
        from ._resultio import save
        return save(self, path)

    def __repr__(self) -> str:
        return (f"tmafm.Result({self.tau.size} samples, N = {self.n_modes}, "
                f"tau in [0, {self.tau[-1] if self.tau.size else 0:g}])")


#: The header line of an automatic N (tmafm_namelist config_text): the N chosen, the search's
#: note if a nonzero initial value raised it, the quantity, each N's value, mode_tol.
_SEARCH_LINE = re.compile(r"^\s*! chosen n_modes = (\d+)(?: \([^)]*\))?: (.*?): (N=1: .*) "
                          r"\(mode_tol = ([^)\s]+)\)\s*$", re.MULTILINE)
_HORIZON_LINE = re.compile(r"^\s*mode_horizon = (\S+)\s*$", re.MULTILINE)


def _mode_search(text: str, differences: dict | None = None) -> dict | None:
    """The automatic-N search a resolved text records (None if it records none); `differences`,
    if given, replace the printed ones (the core's values)."""
    line = _SEARCH_LINE.search(text)
    if line is None:
        return None
    if differences is None:
        differences = {int(n): float(v) for n, v in re.findall(r"N=(\d+): ([^,\s]+)", line[3])}
    horizon = _HORIZON_LINE.search(text)
    return {"n_modes": int(line[1]), "quantity": line[2], "differences": differences,
            "mode_tol": float(line[4]), "mode_horizon": float(horizon[1]) if horizon else None}


def _derived_table() -> dict:
    """{name: unit} of the core's derived values of a physical scene, in the core's order."""
    table = {}
    for k in range(1, int(_api.derived_count()) + 1):
        name, unit, _ = (_text(field) for field in _api.derived_entry(k))
        table[name] = unit
    return table


#: {name: unit} of Config.derived (the core's tmafm_calibration derived_names, derived_units).
DERIVED_UNITS = _derived_table()


def _series_table() -> dict:
    """{name: unit} of the core's SI series of a physical run, in the core's order."""
    return dict((_text(name), _text(unit)) for name, unit in
                (_api.series_entry(k) for k in range(1, int(_api.series_count()) + 1)))


#: {name: unit} of Result.physical (the core's tmafm_physical_series series_names, series_units).
SERIES_UNITS = _series_table()

#: A derived value in a resolved text's header: '! derived: name = value unit (meaning)'.
_DERIVED_LINE = re.compile(r"^\s*! derived: (\w+) = (\S+) ", re.MULTILINE)


def _derived_of_text(text: str) -> dict | None:
    """The derived values a resolved text records (None if it records none)."""
    found = {m[1]: float(m[2]) for m in _DERIVED_LINE.finditer(text)}
    return found or None


def _scene_of_text(text: str) -> dict:
    """The &scene of a resolved text; a &physical input carries it as derived comment lines."""
    marker = "! derived by Eq. (12): "
    lines = []
    for line in text.splitlines():
        stripped = line.lstrip()
        lines.append(stripped[len(marker):] if stripped.startswith(marker) else line)
    groups = f90nml.reads("\n".join(lines) + "\n")
    scene = groups.get("scene", {})
    return {key: float(scene[key]) for key in SCENE_KEYS if key in scene}


def resolve(nml: NamelistLike, **overrides) -> tuple[f90nml.Namelist, dict]:
    """Validate an input and return (the resolved namelist, the dimensionless scene).

    ``overrides`` are groups to patch, e.g. ``resolve(path, solver={'tau_end': 5})``.
    """
    config = Config(nml, **overrides)
    return config.to_namelist(), config.scene


def run(nml: NamelistLike, max_switches: int | None = None, **overrides) -> Result:
    """Run a namelist path, a packaged input name, a dict of groups or a Config; return a Result.

    ``overrides`` patch groups, e.g. ``run('fig2_n4', solver={'tau_end': 10})``.  Nothing is
    written to disk.  ``max_switches``, if given, is the most phase changes accepted.
    Raises InputError (a ValueError) for bad values, InputFileError for a missing file
    and BlowUpError when the integration diverges.
    """
    return Config(nml, **overrides).run(max_switches)


def _config_from_resolved_text(text: str, label: str, override: str | None = None) -> Config:
    """A Config rebuilt from its resolved text (how a pickled Config is unpickled); ``override``
    (namelist text) patches it key by key, as Config's overrides do (tmafm.load fixes an
    automatic N so: tmafm._resultio)."""
    config = Config.__new__(Config)
    handle = _config_t()
    if override is None:
        ierr, errmsg = _api.config_from_text(_for_core(text), _for_core(label), handle, polls())
    else:
        ierr, errmsg = _api.config_from_texts(_for_core(text), _for_core(label),
                                              _for_core(override), _for_core(label), handle,
                                              polls())
        text = None  # the Config's text is the patched one, read back from the core
    raise_for(ierr, errmsg)
    config.label, config._f, config._text, config._scene = label, handle, text, None
    return config
