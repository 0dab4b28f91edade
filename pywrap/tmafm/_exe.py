"""Locating the installed ``tmafm`` executable (pip puts it next to the interpreter)."""

import os
import shutil
import sys
import sysconfig
from pathlib import Path

from .errors import InputFileError

__all__ = ["executable"]


def executable() -> str:
    """Path of the ``tmafm`` command: $TMAFM_EXE, the interpreter's scripts folder, or PATH."""
    candidates = [os.environ.get("TMAFM_EXE"),
                  str(Path(sysconfig.get_path("scripts")) / "tmafm"),
                  str(Path(sys.executable).parent / "tmafm"),
                  shutil.which("tmafm")]
    for candidate in candidates:
        if candidate and os.access(candidate, os.X_OK) and Path(candidate).is_file():
            return candidate
    # InputFileError is a FileNotFoundError: callers that caught that still do.
    raise InputFileError("the tmafm executable is not installed (pip install . builds it)")
