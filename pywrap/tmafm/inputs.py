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

from ._namelist import shown
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
    if not isinstance(name, str):
        raise InputFileError(f"no packaged input named {shown(name)}: a name is a str (known: "
                             f"{', '.join(names())})")
    stem = name[:-4] if name.endswith(".nml") else name
    candidate = folder() / f"{stem}.nml"
    try:
        found = "/" not in stem and "\0" not in stem and candidate.is_file()
    except (OSError, ValueError):  # a name too long
        found = False
    if not found:
        raise InputFileError(f"no packaged input named {name!r} (known: {', '.join(names())})")
    return candidate
