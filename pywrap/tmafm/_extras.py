"""Optional dependencies: a missing one gives a one-line message naming the extra to install."""

from __future__ import annotations

import importlib

__all__ = ["require"]

#: module -> extra of pyproject.toml that provides it
EXTRAS = {"scipy": "bench", "matplotlib": "plot", "xarray": "sweep", "dask": "sweep",
          "tqdm": "sweep", "hypothesis": "test", "mpmath": "test"}


def require(module: str, user: str):
    """Import `module` for `user`, or raise ImportError: '<user> needs <module>: pip install ...'."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        extra = EXTRAS.get(top, "test")
        raise ImportError(f"{user} needs {top}: pip install 'tmafm[{extra}]'") from exc
