"""The published inputs, shipped inside the package (the repository's inputs/ is their source).

The run inputs are named by their stem (``"fig2_n4"``); the sweep files of docs/sweeps.md and
their bases, from inputs/sweeps/, by ``"sweeps/<stem>"`` (``"sweeps/approach"``,
``"sweeps/bistable_n2"``), and the bimodal example by ``"bimodal/tapping"``, so that every
example of the docs runs after ``pip install``.  names() lists every run input (the bimodal
example included), sweep_names() the sweep files and their bases; path() takes either.

>>> import tmafm
>>> "fig2_n4" in tmafm.inputs.names()
True
>>> tmafm.inputs.path("fig2_n4").name
'fig2_n4.nml'
>>> tmafm.inputs.path("sweeps/approach").parent.name
'sweeps'
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from ._namelist import shown
from .errors import InputFileError

__all__ = ["folder", "names", "path", "sweep_names", "SWEEPS"]

#: The subfolder of the sweep files (and their bases): names "sweeps/<stem>".
SWEEPS = "sweeps"
#: Every subfolder of packaged inputs: names "<subfolder>/<stem>".
SUBFOLDERS = (SWEEPS, "bimodal")


def folder() -> Path:
    """The folder of the packaged inputs."""
    return Path(str(resources.files("tmafm") / "inputs"))


def names() -> list[str]:
    """Names of every packaged run input (without .nml): the top folder's stems, sorted, then
    the run inputs of the other subfolders but sweeps ("bimodal/tapping"), sorted.  The sweep
    files and their bases are sweep_names()."""
    return sorted(p.stem for p in folder().glob("*.nml")) + sorted(
        f"{sub}/{p.stem}" for sub in SUBFOLDERS if sub != SWEEPS for p in (folder() / sub).glob("*.nml"))


def sweep_names() -> list[str]:
    """Names of the packaged sweep files and their bases ("sweeps/<stem>"), sorted."""
    return sorted(f"{SWEEPS}/{p.stem}" for p in (folder() / SWEEPS).glob("*.nml"))


def path(name: str) -> Path:
    """The packaged input `name` (with or without .nml; "<subfolder>/<stem>" for inputs/sweeps/
    and inputs/bimodal/);
    InputFileError if there is none."""
    if not isinstance(name, str):
        raise InputFileError(f"no packaged input named {shown(name)}: a name is a str (known: "
                             f"{', '.join(names())})")
    stem = name[:-4] if name.endswith(".nml") else name
    sub, _, leaf = stem.rpartition("/")
    candidate = folder() / (sub or ".") / f"{leaf}.nml"
    try:
        found = sub in ("", *SUBFOLDERS) and leaf not in ("", ".", "..") and "\0" not in stem \
            and candidate.is_file()
    except (OSError, ValueError):  # a name too long
        found = False
    if not found:
        raise InputFileError(f"no packaged input named {name!r} (known: "
                             f"{', '.join(names() + sweep_names())})")
    return candidate
