"""The published inputs, shipped inside the package (the repository's inputs/ is their source).

>>> import tmafm
>>> "fig2_n4" in tmafm.inputs.names()
True
>>> tmafm.inputs.path("fig2_n4").name
'fig2_n4.nml'
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from .errors import InputFileError

__all__ = ["folder", "names", "path"]


def folder() -> Path:
    """The folder of the packaged inputs."""
    return Path(str(resources.files("tmafm") / "inputs"))


def names() -> list[str]:
    """Names of the packaged inputs (without .nml), sorted."""
    return sorted(p.stem for p in folder().glob("*.nml"))


def path(name: str) -> Path:
    """The packaged input `name` (with or without .nml); InputFileError if there is none."""
    stem = str(name)[:-4] if str(name).endswith(".nml") else str(name)
    candidate = folder() / f"{stem}.nml"
    if "/" in stem or not candidate.is_file():
        raise InputFileError(f"no packaged input named {name!r} (known: {', '.join(names())})")
    return candidate
