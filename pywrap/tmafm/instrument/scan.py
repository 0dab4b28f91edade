"""AM imaging: one scan line with the Z feedback over a topography and two materials
(docs/instrument.md, "AM imaging").  The scan runs in the core (fortran/src/instrument/
tmafm_am_scan.f90); this module builds its settings, calls it and labels the result."""

from __future__ import annotations

import math

import numpy as np

from .. import _fortran
from .._extras import require
from .._run import Config
from ..errors import InputError, InputTypeError, raise_for

__all__ = ["MATERIAL_KEYS", "scan_line", "plot_scan"]

#: The &physical keys a second material may set (the sample under the same cantilever).
MATERIAL_KEYS = ("youngs_modulus_sample", "poisson_ratio_sample", "adhesion_energy", "contact_damping",
                 "hamaker", "intermolecular_distance", "sample_relaxation_time", "sample_modulus_relaxed")

_api = _fortran._objects.tmafm_api_scan
_settings_t = _fortran._objects.tmafm_scan_settings.scan_settings_t


def _table(which: str):
    names, units, meanings = _api.am_scan_names(which)
    split = [_fortran.text(t).split("|")[:-1] for t in (names, units, meanings)]
    return split[0], split[1], split[2] if split[2] else [""] * len(split[0])


_PIXELS = _table("pixels")
_INFO = _table("info")
_RECORD = _table("record")


def _number(key, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputTypeError(f"scan: {key} = {value!r} must be a number")
    return float(value)


def scan_line(base, *, scan_length, pixels, line_rate, lockin_bandwidth, setpoint=None,
              setpoint_ratio=None, feedback_bandwidth=None, proportional_gain=None, integral_gain=None,
              topography="flat", step_height=0.0, step_position=None, sphere_radius=0.0,
              sphere_position=None, material_b=None, material_boundary=None, retrace=True,
              record=False, **overrides):
    """Scan one line of AM-AFM imaging with the Z feedback; returns an xarray Dataset.

    ``base`` is an input with a &physical scene (``overrides`` patch it, as in tmafm.Config):
    the cantilever, the first material, and in its tip_sample_distance the rest distance the
    engage starts from (out of contact).  The line runs from x = 0 to ``scan_length`` (m) in
    ``pixels`` pixels at ``line_rate`` (Hz: trace and retrace together take 1/line_rate; with
    ``retrace=False`` the trace alone).  The setpoint is ``setpoint`` (m) or
    ``setpoint_ratio`` (A_set/A0, A0 the free amplitude measured before the engage); the
    lock-in's output filter has ``lockin_bandwidth`` (Hz); the feedback's gains come from the
    closed-loop ``feedback_bandwidth`` (Hz) or are given (``proportional_gain``, m/m;
    ``integral_gain``, 1/s).  ``topography``: 'flat', 'step' (``step_height`` m at
    ``step_position`` m) or 'sphere' (``sphere_radius`` m resting on the plane at
    ``sphere_position`` m).  ``material_b``: a dict of &physical sample keys (MATERIAL_KEYS)
    of a second material at x >= ``material_boundary`` (m).

    The Dataset has dims ('direction', 'x'): direction 'trace' (and 'retrace'), x the pixel
    centres (nm); variables height (the piezo Z, nm), amplitude_error, phase, peak_force,
    dissipated, amplitude, topography, distance, material, each the mean over the pixel's drive
    periods, with attrs units and long_name; attrs the settings and the engage's summary
    (free amplitude, slope dA/dZ, gains, time constants).  ``record=True`` adds each scan
    period's values (dim 'period', variables period_<name>)."""
    xr = require("xarray", "tmafm.instrument.scan_line")
    config = base if isinstance(base, Config) and not overrides else Config(base, **overrides)
    scan = _settings_t()
    values = {"scan_length": scan_length, "line_rate": line_rate, "lockin_bandwidth": lockin_bandwidth,
              "setpoint": 0.0 if setpoint is None else setpoint,
              "setpoint_ratio": 0.0 if setpoint_ratio is None else setpoint_ratio,
              "feedback_bandwidth": 0.0 if feedback_bandwidth is None else feedback_bandwidth,
              "proportional_gain": 0.0 if proportional_gain is None else proportional_gain,
              "integral_gain": 0.0 if integral_gain is None else integral_gain,
              "step_height": step_height,
              "step_position": 0.0 if step_position is None else step_position,
              "sphere_radius": sphere_radius,
              "sphere_position": 0.0 if sphere_position is None else sphere_position,
              "material_boundary": 0.0 if material_boundary is None else material_boundary}
    for key, value in values.items():
        setattr(scan, key, _number(key, value))
    if isinstance(pixels, bool) or not isinstance(pixels, (int, np.integer)):
        raise InputTypeError(f"scan: pixels = {pixels!r} must be an integer")
    scan.pixels = int(pixels)
    if not isinstance(topography, str):
        raise InputTypeError(f"scan: topography = {topography!r} must be a string")
    if len(topography) > 16:
        raise InputError(f"scan: topography = {topography!r} must be 'flat', 'step' or 'sphere'")
    scan.topography = topography
    if topography == "step" and step_position is None:
        raise InputError("scan: topography = 'step' needs step_position (m)")
    if topography == "sphere" and sphere_position is None:
        raise InputError("scan: topography = 'sphere' needs sphere_position (m)")
    scan.retrace = bool(retrace)
    config_b = config
    if material_b is not None:
        if not isinstance(material_b, dict) or not material_b:
            raise InputTypeError(f"material_b = {material_b!r} must be a non-empty dict of &physical sample keys")
        for key in material_b:
            if key not in MATERIAL_KEYS:
                raise InputError(f"material_b: {key} = {material_b[key]!r} is not a sample key "
                                 f"({', '.join(MATERIAL_KEYS)})")
        if material_boundary is None:
            raise InputError("scan: material_b needs material_boundary (m)")
        groups = {k: dict(v) for k, v in overrides.items()}
        groups["physical"] = {**groups.get("physical", {}), **material_b}
        config_b = Config(base, **groups)
        scan.two_materials = True
    elif material_boundary is not None:
        raise InputError(f"scan: material_boundary = {material_boundary!r} needs material_b")

    period, per_pixel, total, ierr, errmsg = _api.am_scan_shape(config._f, scan)
    raise_for(ierr, errmsg)
    passes = 2 if retrace else 1
    out = np.zeros((scan.pixels, len(_PIXELS[0]), passes), order="F")
    info = np.zeros(len(_INFO[0]))
    rec = np.zeros((total if record else 0, len(_RECORD[0])), order="F")
    ierr, errmsg = _api.am_scan_run(config._f, config_b._f, scan, _fortran.polls(), out, info, rec)
    raise_for(ierr, errmsg)

    x = (np.arange(scan.pixels) + 0.5) * scan.scan_length / scan.pixels * 1e9
    directions = ["trace", "retrace"][:passes]
    data = {}
    for k, (name, unit, meaning) in enumerate(zip(*_PIXELS)):
        data[name] = (("direction", "x"), out[:, k, :].T.copy(), {"units": unit, "long_name": meaning})
    if record:
        for k, (name, unit) in enumerate(zip(_RECORD[0], _RECORD[1])):
            data[f"period_{name}"] = (("period",), rec[:, k].copy(),
                                      {"units": unit, "long_name": f"per drive period: {name}"})
    attrs = {"base": config.label, "scan_length_nm": scan.scan_length * 1e9, "pixels": scan.pixels,
             "line_rate_Hz": scan.line_rate, "lockin_bandwidth_Hz": scan.lockin_bandwidth,
             "topography": topography, "two_materials": int(material_b is not None)}
    for key in ("setpoint_ratio", "feedback_bandwidth", "step_height", "step_position", "sphere_radius",
                "sphere_position", "material_boundary"):
        attrs[key] = float(getattr(scan, key))
    if material_b is not None:
        attrs.update({f"material_b_{k}": float(v) for k, v in material_b.items()})
    for name, unit, value in zip(_INFO[0], _INFO[1], info):
        attrs[f"{name}_{unit.replace('/', '_per_')}" if unit != "1" else name] = float(value)
    attrs["periods"] = int(total)
    ds = xr.Dataset(data, coords={"direction": directions,
                                  "x": ("x", x, {"units": "nm", "long_name": "lateral position (pixel centre)"})},
                    attrs=attrs)
    return ds


def plot_scan(ds, path=None):
    """The scan line as a researcher reads it: height (nm), amplitude error (nm), phase (deg)
    and peak force (nN) against x (nm), stacked, trace and retrace overlaid, the true
    topography dashed under the height.  Saved to ``path`` when given; returns the figure."""
    matplotlib = require("matplotlib", "tmafm.instrument.plot_scan")
    if path is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    panels = [("height", "height (nm)"), ("amplitude_error", "amplitude error (nm)"),
              ("phase", "phase (deg)"), ("peak_force", "peak force (nN)")]
    fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(6.4, 8.0))
    x = ds["x"].values
    for ax, (name, label) in zip(axes, panels):
        for direction, style in zip(ds["direction"].values, ("-", "--")):
            ax.plot(x, ds[name].sel(direction=direction).values, style, label=str(direction))
        if name == "height":
            offset = float(ds.attrs.get("engaged_height_nm", 0.0)) - float(ds["topography"].values[0, 0])
            ax.plot(x, ds["topography"].values[0] + offset, ":", color="grey",
                    label="topography (offset)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize="small")
    axes[-1].set_xlabel("x (nm)")
    setpoint = ds.attrs.get("setpoint_nm", math.nan)
    axes[0].set_title(f"AM scan: A_set = {setpoint:.2f} nm, {ds.attrs['pixels']} pixels, "
                      f"{ds.attrs['line_rate_Hz']:g} Hz line rate")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig
