"""Optional dependencies: a missing one gives a one-line message naming the extra to install."""

from __future__ import annotations

import importlib

from .errors import MissingExtraError

__all__ = ["require", "netcdf_engine"]

#: module -> extra of pyproject.toml that provides it
EXTRAS = {"scipy": "bench", "matplotlib": "plot", "xarray": "sweep", "dask": "sweep",
          "distributed": "sweep", "tqdm": "sweep", "h5netcdf": "sweep", "h5py": "sweep",
          "netCDF4": "sweep", "hypothesis": "test", "mpmath": "test"}


def require(module: str, user: str):
    """Import `module` for `user`, or raise tmafm.MissingExtraError (an ImportError):
    '<user> needs <module>: pip install ...'."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        extra = EXTRAS.get(top, "test")
        raise MissingExtraError(f"{user} needs {top}: pip install 'tmafm[{extra}]'") from exc


#: The NetCDF back ends a sweep dataset is written with, in xarray's order of preference, and
#: the modules each needs.  scipy's NetCDF-3 writer is not one: it cannot write the datasets'
#: int8 flags and text coordinates as they are.
NETCDF_ENGINES = (("netcdf4", ("netCDF4",)), ("h5netcdf", ("h5netcdf", "h5py")))


def netcdf_engine(user: str) -> str:
    """The xarray engine that writes sweep datasets here (NETCDF_ENGINES), or MissingExtraError
    naming the [sweep] extra when none is installed."""
    for engine, modules in NETCDF_ENGINES:
        try:
            for module in modules:
                importlib.import_module(module)
        except ImportError:
            continue
        return engine
    raise MissingExtraError(f"{user} needs a NetCDF writer (h5netcdf with h5py, or netCDF4): "
                            f"pip install 'tmafm[sweep]'")
