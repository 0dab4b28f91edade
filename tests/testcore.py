"""The test-only extension ``tmafm_testcore`` (tests/tmafm_testcore.f90): entry points into the
core that only tests call (model terms, modes, Galerkin integrals, free flights, gap rows, real
texts, the file reader).  It is never installed: the package reaches the core only through
tmafm_api.  On first import this builds the meson target ``tmafm_testcore`` of this checkout in
build-testcore/ (ninja rebuilds only what changed; a lock keeps parallel test workers from
building at once) and imports it from there.

    from testcore import core          # then core.model_terms(...), core.flight_samples(...)
"""

import fcntl
import importlib
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
BUILD = Path(os.environ.get("TMAFM_TESTCORE_BUILD", REPO / "build-testcore"))


def _tool(name: str) -> str:
    """The meson or ninja next to this interpreter (the test venv's), else on PATH."""
    here = Path(sys.executable).parent / name
    return str(here) if here.exists() else name


def build() -> Path:
    """Build (or bring up to date) the extension; the folder that holds it."""
    BUILD.mkdir(parents=True, exist_ok=True)
    with open(BUILD / "testcore.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (BUILD / "build.ninja").exists():
            subprocess.run([_tool("meson"), "setup", str(BUILD), str(REPO), "--buildtype=release",
                            "-Db_ndebug=if-release", "-Dpython.install_env=auto"],
                           check=True, capture_output=True, text=True)
        done = subprocess.run([_tool("ninja"), "-C", str(BUILD), "pywrap/tmafm_testcore" + _suffix()],
                              capture_output=True, text=True)
        if done.returncode:
            raise RuntimeError(f"building tmafm_testcore failed:\n{done.stdout[-4000:]}{done.stderr[-4000:]}")
    return BUILD / "pywrap"


def _suffix() -> str:
    import sysconfig
    return sysconfig.get_config_var("EXT_SUFFIX")


def load():
    """The tmafm_testcore module, built if needed."""
    folder = str(build())
    if folder not in sys.path:
        sys.path.insert(0, folder)
    return importlib.import_module("tmafm_testcore")


core = load()
