"""Sweep datasets: the steady values of the runs as xarray variables with their units,
the attributes every dataset carries, the summary docs/sweeps.md quotes, and NetCDF files
(written as the executable writes its output, and read back)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._namelist import shown
from .._run import Config
from ..errors import InputError, InputFileError, InputTypeError
from ..observe import _SI_VALUE, CF_UNITS, PHYSICAL_CF_UNITS, PHYSICAL_UNITS, UNITS
from .points import _input_name
from .runs import _names


def _units(base_config: Config) -> tuple[dict, dict]:
    """(model units, physical units) of the observables as ``units`` attributes: the core's
    table (tmafm.observe.UNITS, PHYSICAL_CF_UNITS), the phase spelled 'degree' (CF)."""
    return ({name: CF_UNITS.get(unit, unit) for name, unit in UNITS.items()},
            dict(PHYSICAL_CF_UNITS))


#: The units attribute and long name of the dissipated power of a &physical scene: the energy
#: dissipated per drive period (aJ) over the period (s), in pW.
POWER = ("pW", "steady power dissipated (dissipated_energy over the drive period)")
#: The power dissipated in the tip-sample contact alone, as AM-AFM reads it from the phase
#: (contact damping and friction; not the cantilever's own damping), in pW.
TIP_SAMPLE = ("pW", "steady power dissipated in the tip-sample contact ((dissipated_contact_"
                    "damping + dissipated_friction + dissipated_viscoelastic + dissipated_adhesion) over "
                    "the drive period)")


def _steady_variables(summaries: list[dict], shape: tuple, dims: tuple, units: dict,
                      physical_units: dict) -> dict:
    """The steady variables of a list of summaries (one per point, in grid order)."""
    good = [s for s in summaries if "error" not in s]
    names = [name for name in _names() if any(name in s["values"] for s in summaries)]
    columns = {name: np.array([s["values"].get(name, np.nan) for s in summaries], dtype=float)
               for name in names}
    physical = {}
    harmonics = ("harmonic_amplitude", "harmonic_phase")
    for name in names:
        if good and all(name in s["physical"] for s in good):
            physical[name] = np.array([s["physical"][name] if "error" not in s else np.nan
                                       for s in summaries], dtype=float)
    for name in harmonics:
        if good and all(name in s for s in good):
            size = len(good[0][name])
            columns[name] = np.array([s[name] if "error" not in s else np.full(size, np.nan)
                                      for s in summaries], dtype=float)
            if all(name in s["physical"] for s in good):
                physical[name] = np.array([s["physical"][name] if "error" not in s
                                           else np.full(size, np.nan) for s in summaries],
                                          dtype=float)
    drive_period = None
    if physical and all("drive_period_s" in s for s in good):
        drive_period = np.array([s.get("drive_period_s", np.nan) for s in summaries])
    return _steady_columns(columns, physical, np.array([s["period"] for s in summaries]),
                           np.array([s["steady"] for s in summaries]),
                           np.array(["error" in s for s in summaries]),
                           np.array([s["periods"] for s in summaries]), shape, dims, units,
                           physical_units, drive_period)


def _steady_columns(columns: dict, physical: dict, period, steady, failed, periods,
                    shape: tuple, dims: tuple, units: dict, physical_units: dict,
                    drive_period=None) -> dict:
    """The steady variables from arrays over the points (grid order): ``columns`` {name: (n,)
    or (n, harmonics)} in model units, ``physical`` {name: (n,) or (n, harmonics)} in
    SI-derived units (empty for a dimensionless scene), and period, steady, failed, periods
    (n,); ``drive_period`` (n,) in s adds ``dissipated_power``.  A &physical scene's variables
    are its SI-derived values (nm, degree, nN, us, aJ), the unit in ``units``; a dimensionless
    scene's are in model units (d, tau, E1 I/L^2, ...)."""
    import xarray as xr
    data = {}
    for name in (*_names(), "harmonic_amplitude", "harmonic_phase"):
        if name not in columns:
            continue
        if name in physical:
            values, unit, system = physical[name], physical_units.get(name, "1"), "physical"
        else:
            values, unit, system = columns[name], units.get(name, "1"), "model"
        harmonic = name.startswith("harmonic_")
        data[name] = xr.Variable((*dims, "harmonic") if harmonic else dims,
                                 values.reshape(*shape, -1) if harmonic else values.reshape(shape),
                                 attrs={"units": unit, "units_system": system,
                                        "long_name": f"steady {name}" + (
                                            " (harmonics 1, 2, ...)" if harmonic else "")})
    if "min_gap" in data:
        # The indentation, -min_gap where the tip went into the sample (0 elsewhere, NaN where
        # min_gap is): the plot computed it, the dataset did not hold it (issue 27).
        gap = data["min_gap"]
        data["indentation"] = xr.Variable(
            dims, np.maximum(-np.asarray(gap.values), 0.0),
            attrs={"units": gap.attrs["units"], "units_system": gap.attrs["units_system"],
                   "long_name": "steady indentation (-min_gap where < 0, else 0)"})
    if drive_period is not None and "dissipated_energy" in physical:
        joule = _SI_VALUE[PHYSICAL_UNITS["dissipated_energy"]]
        per_second = 1.0 / np.asarray(drive_period, dtype=float)
        data["dissipated_power"] = xr.Variable(
            dims, (physical["dissipated_energy"] * joule * per_second / 1e-12).reshape(shape),
            attrs={"units": POWER[0], "units_system": "physical", "long_name": POWER[1]})
        if "dissipated_contact_damping" in physical and "dissipated_friction" in physical:
            # Every tip-sample loss channel: the contact damper, friction and the sample's own
            # viscoelastic loss (docs/model.md §16).
            contact = physical["dissipated_contact_damping"] + physical["dissipated_friction"]
            for channel in ("dissipated_viscoelastic", "dissipated_adhesion"):
                if channel in physical:
                    contact = contact + physical[channel]
            data["tip_sample_power"] = xr.Variable(
                dims, (contact * joule * per_second / 1e-12).reshape(shape),
                attrs={"units": POWER[0], "units_system": "physical", "long_name": TIP_SAMPLE[1]})
    data["period"] = xr.Variable(dims, np.asarray(period, dtype=np.int32).reshape(shape),
                                 attrs={"units": "1", "long_name": "period of the steady motion "
                                        "in drive periods (0: none found)"})
    data["steady"] = xr.Variable(dims, np.asarray(steady, dtype=np.int8).reshape(shape),
                                 attrs={"units": "1",
                                        "long_name": "1 where steady state was reached"})
    data["failed"] = xr.Variable(dims, np.asarray(failed, dtype=np.int8).reshape(shape),
                                 attrs={"units": "1",
                                        "long_name": "1 where the run failed (SolverError); "
                                                     "its values are NaN"})
    data["periods"] = xr.Variable(dims, np.asarray(periods, dtype=np.int32).reshape(shape),
                                  attrs={"units": "1", "long_name": "drive periods run"})
    return data


def key_units(key: str) -> str:
    """The ``units`` attribute of a swept input key ('group.key'): the core's key table's unit
    (SI for &physical keys), '1' for a dimensionless one (d, tau, a pure number)."""
    from .._namelist import KEYS
    group, _, name = key.partition(".")
    unit = next((k.unit for k in KEYS if k.group == group and k.name == name), "1")
    return "1" if unit in ("", "-", "d", "tau", "1") else unit


def _coordinate(key: str, values, long_name: str | None = None):
    """The coordinate of a swept key, with its ``units``."""
    import xarray as xr
    return xr.Variable((key,), np.asarray(values),
                       attrs={"units": key_units(key), "long_name": long_name or key})


def _index_coordinates(data: dict) -> dict:
    """Coordinates 1, 2, ... (units '1') for the index dimensions of the variables
    (harmonic, kept)."""
    import xarray as xr
    coords = {}
    for dim, what in (("harmonic", "harmonic number (1: the drive frequency)"),
                      ("kept", "section point kept (the last is the final one)")):
        size = next((v.sizes[dim] for v in data.values() if dim in v.dims), 0)
        if size:
            coords[dim] = xr.Variable((dim,), np.arange(1, size + 1, dtype=np.int32),
                                      attrs={"units": "1", "long_name": what})
    return coords


def _attrs(base, kind: str, keywords: dict) -> dict:
    from .. import __version__
    attrs = {"tmafm_kind": kind, "tmafm_version": str(__version__),
             "base": base.label if isinstance(base, Config) else str(base)
             if isinstance(base, (str, os.PathLike)) else "<dict input>"}
    for key, value in keywords.items():
        if key == "observables":  # a list of groups: NetCDF attributes want one text
            value = "all" if value is None else ",".join(value)
        attrs[f"observe_{key}"] = int(value) if isinstance(value, bool) else value
    return attrs


def _failure_attrs(summaries: list[dict]) -> dict:
    """The count of failed runs and the first one's message, for the Dataset's attributes."""
    errors = [s["error"] for s in summaries if "error" in s]
    return {"failures": len(errors), "first_failure": errors[0] if errors else ""}


def _grid_dataset(base, base_config, axes, summaries, keywords, kind):
    import xarray as xr
    keys = list(axes)
    shape = tuple(len(v) for v in axes.values())
    units, physical_units = _units(base_config)
    data = _steady_variables(summaries, shape, tuple(keys), units, physical_units)
    coords = {key: _coordinate(key, values) for key, values in axes.items()}
    coords.update(_index_coordinates(data))
    attrs = _attrs(base, kind, keywords)
    attrs.update(_failure_attrs(summaries))
    return xr.Dataset(data, coords=coords, attrs=attrs)


def summarize(ds) -> dict:
    """The facts docs/sweeps.md quotes, from a sweep Dataset: jump positions per curve and
    direction, attractor counts, period counts, where the bifurcation points split."""
    _check_dataset(ds, "summarize")
    kind = ds.attrs.get("tmafm_kind")
    if kind not in ("sweep", "approach", "frequency_sweep", "bifurcation", "basin") \
            or "period" not in ds:
        raise InputError(f"summarize: not a tmafm sweep dataset (tmafm_kind = {shown(kind)})")
    out = {"kind": kind, "failures": int(ds.attrs.get("failures", 0)),
           "periods_found": {str(int(k)): int((ds["period"].values == k).sum())
                             for k in np.unique(ds["period"].values)}}
    if kind in ("approach", "frequency_sweep"):
        key = ds.attrs["swept_key"]
        curve_dims = [d for d in ds["jump"].dims if d not in ("direction", key)]
        stacked = ds.stack(curve=curve_dims) if curve_dims else ds.expand_dims(curve=[0])
        out["jumps"] = []
        for c in range(stacked.sizes["curve"]):
            for direction in ds["direction"].values:
                part = stacked.isel(curve=c).sel(direction=direction)
                flags = part["jump"].values.astype(bool)
                label = {d: float(part[d].values) for d in curve_dims}
                out["jumps"].append(dict(label, direction=str(direction),
                                         at=part[key].values[flags].tolist(),
                                         amplitude_max=float(np.nanmax(part["amplitude"]))))
    elif kind == "bifurcation":
        key = ds.attrs["swept_key"]
        vt = ds["vt"]
        spread = ((vt.max("kept") - vt.min("kept")) / np.abs(vt).max("kept")).values
        out["split_1e-6_at"] = ds[key].values[spread > 1e-6].tolist()
        out["period"] = dict(zip(map(float, ds[key].values), map(int, ds["period"].values)))
    elif kind == "basin":
        labels = ds["attractor"].values
        out["attractors"] = int(ds.attrs["attractors"])
        out["points_per_label"] = {str(int(k)): int((labels == k).sum()) for k in
                                   np.unique(labels)}
    return out


def _netcdf_bytes(ds, engine: str) -> bytes:
    """The NetCDF file of a Dataset, as bytes, made in memory (h5netcdf): no file is written, so
    a full disk meets only the write of these bytes (tmafm._safefile), never the HDF5 library
    (h5py crashed on ENOSPC, leaving its temporary).  netCDF4, which writes only by name,
    writes in a private temporary folder; an OSError there is an InputFileError."""
    import io
    if engine == "h5netcdf":
        buffer = io.BytesIO()
        ds.to_netcdf(buffer, engine=engine)
        return buffer.getvalue()
    import tempfile
    try:
        with tempfile.TemporaryDirectory() as folder:
            scratch = Path(folder) / "sweep.nc"
            ds.to_netcdf(scratch, engine=engine)
            return scratch.read_bytes()
    except OSError as exc:
        raise InputFileError(f"making the NetCDF file in a temporary folder failed: "
                             f"{exc.strerror or exc}") from None


def _check_dataset(ds, what: str):
    """`ds` if it is an xarray.Dataset; InputTypeError otherwise."""
    import xarray as xr
    if not isinstance(ds, xr.Dataset):
        raise InputTypeError(f"{what}: ds must be an xarray.Dataset (a sweep's result), not "
                             f"{type(ds).__name__}")
    return ds


def read_dataset(path):
    """A sweep NetCDF file, loaded into memory; InputFileError if it is missing, InputError if
    it is not a sweep dataset (what ``--summarize`` reads)."""
    from .._extras import require
    xr = require("xarray", "tmafm.sweeps.read_dataset")
    path = _input_name(path, "sweep dataset")
    try:
        is_file = path.is_file()
    except (OSError, ValueError):
        is_file = False
    if not is_file:
        raise InputFileError(f"sweep dataset {shown(str(path))} not found")
    try:
        with xr.open_dataset(path) as ds:
            ds = ds.load()
    except Exception as exc:  # the NetCDF back ends raise many kinds
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{shown(str(path))}: not a readable NetCDF file: "
                         f"{shown(first)[1:-1]}") from None
    if "tmafm_kind" not in ds.attrs or "period" not in ds:
        raise InputError(f"{shown(str(path))}: not a tmafm sweep dataset (no tmafm_kind "
                         f"attribute or period variable)")
    return ds


def write_dataset(ds, path) -> Path:
    """Write a sweep Dataset to NetCDF as the executable writes its output: the file is made in
    memory, then its bytes written to a new temporary file, synced and renamed (a device or
    FIFO is written directly); InputFileError if it cannot be written (a full disk included).
    Nothing is left behind on a failure or a KeyboardInterrupt."""
    from .._extras import netcdf_engine
    from .._safefile import as_path, check_target, write_bytes
    _check_dataset(ds, "write_dataset")
    path = as_path(path, "NetCDF file")
    engine = netcdf_engine("tmafm.sweeps.write_dataset")
    check_target(path, "NetCDF file")
    return write_bytes(path, _netcdf_bytes(ds, engine), "NetCDF file")
