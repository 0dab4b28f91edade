"""Generate the f90wrap layer at build time (meson custom_target): f90wrap, then f2py-f90wrap.

    python f90wrap_gen.py f90wrap OUTDIR KIND_MAP SOURCE...   -> f90wrap_<module>.f90, _objects.py
    python f90wrap_gen.py f2py OUTDIR WRAPPER...              -> _fwrapmodule.c, _fwrap-f2pywrappers.f

Both tools write into the current folder, so each step runs inside OUTDIR, with this
interpreter (nothing depends on PATH).  After f90wrap, the wrapper of the run entry point
gets an ``!f2py threadsafe`` line, so the extension releases the GIL while the core integrates.
"""

import os
import subprocess
import sys
from pathlib import Path

#: Wrapped routines that run without the GIL (they touch no Python object; choosing N in
#: config_from_text(s) runs the comparison runs).  The core keeps no state between calls, and
#: returns no deferred-length function result (gfortran 12 keeps the length of one in a static
#: variable of the caller: docs/model-notes.md, finding 11; tests/test_threads.py checks it).
THREADSAFE = ("f90wrap_tmafm_api__run_config", "f90wrap_tmafm_api__config_from_text",
              "f90wrap_tmafm_api__config_from_texts", "f90wrap_tmafm_api__trajectory_energy_flow")
#: Core entities that Python never calls (the integrators' own helpers).
SKIP = ["check_blowup", "init_trajectory", "scene_from_physical", "errata_for_convention", "parse_errata",
        "errata_label", "contact_angle", "contact_radius", "normal_force_group", "friction_group",
        "contact_brackets", "init_model", "sample_count"]


def mark_threadsafe(path: Path) -> None:
    """Insert ``!f2py threadsafe`` after the declarations' ``implicit none`` of THREADSAFE routines."""
    lines = path.read_text().splitlines(keepends=True)
    out, pending = [], False
    for line in lines:
        out.append(line)
        stripped = line.strip().lower()
        if stripped.startswith("subroutine ") and stripped.split("(")[0].split()[-1] in THREADSAFE:
            pending = True
        elif pending and stripped == "implicit none":
            out.append("    !f2py threadsafe\n")
            pending = False
    path.write_text("".join(out))


def main() -> None:
    step, outdir, *rest = sys.argv[1:]
    sources = [str(Path(p).resolve()) for p in rest]
    os.chdir(outdir)
    if step == "f90wrap":
        kind_map, *sources = sources
        subprocess.run([sys.executable, "-m", "f90wrap", "--f90wrap", "-m", "_objects", "-k", kind_map,
                        "--f90-mod-name", "tmafm._fwrap", "--skip", *SKIP,
                        "--", *sources], check=True, stdout=subprocess.DEVNULL)
        for wrapper in Path(".").glob("f90wrap_tmafm_api.f90"):
            mark_threadsafe(wrapper)
    elif step == "f2py":
        sources = [s for s in sources if s.endswith(".f90")]
        subprocess.run([sys.executable, "-c",
                        "from f90wrap.scripts.f2py_f90wrap import main; main()",
                        "-m", "_fwrap", "--lower", *sources], check=True, stdout=subprocess.DEVNULL)
        for expected in ("_fwrap-f2pywrappers.f",):
            Path(expected).touch()
    else:
        raise SystemExit(f"unknown step {step!r}")


if __name__ == "__main__":
    main()
