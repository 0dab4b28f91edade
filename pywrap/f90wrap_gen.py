"""Generate the Python extensions' wrappers at build time (meson custom_target): f90wrap, then
f2py-f90wrap for tmafm._fwrap (the package's one extension), and numpy.f2py for the test-only
tmafm_testcore (tests/tmafm_testcore.f90, never installed).

    python f90wrap_gen.py f90wrap OUTDIR KIND_MAP SOURCE...   -> f90wrap_<module>.f90, _objects.py
    python f90wrap_gen.py f2py OUTDIR WRAPPER...              -> _fwrapmodule.c, _fwrap-f2pywrappers.f
    python f90wrap_gen.py testcore OUTDIR SOURCE F2CMAP       -> tmafm_testcoremodule.c, ...-f2pywrappers.f

The tools write into the current folder, so each step runs inside OUTDIR, with this
interpreter (nothing depends on PATH).  After f90wrap, the wrapper of the run entry point
gets an ``!f2py threadsafe`` line, so the extension releases the GIL while the core integrates.
After f2py, every wrapper in _fwrapmodule.c loses f90wrap's SIGINT handler and setjmp
(drop_abort_handler below).  The observed runs (batch_run, observe_states_of) write into arrays
that Python made before the call, so a Ctrl-C that stops them leaks nothing.  Type-bound procedures named
in SKIP are hidden from f90wrap (hide_bindings below: its --skip keeps bindings).
"""

import os
import re
import subprocess
import sys
from pathlib import Path

#: Wrapped routines that run without the GIL (they touch no Python object; choosing N in
#: config_from_text(s) runs the comparison runs).  The core keeps no state between calls, and
#: returns no deferred-length function result (gfortran 12 keeps the length of one in a static
#: variable of the caller: docs/model-notes.md, finding 11; tests/test_threads.py checks it).
THREADSAFE = ("f90wrap_tmafm_api__run_config", "f90wrap_tmafm_api__config_from_text",
              "f90wrap_tmafm_api__config_from_texts", "f90wrap_tmafm_api__trajectory_energy_flow",
              "f90wrap_tmafm_api__batch_run", "f90wrap_tmafm_api__observe_states_of",
              "f90wrap_tmafm_api_instrument__z_schedule_run",
              "f90wrap_tmafm_api_scan__am_scan_run",
              "f90wrap_tmafm_api_fm__fm_approach_run")
#: Core entities that Python never calls (the integrators' own helpers).  f90wrap's --skip
#: leaves type-bound procedures wrapped, so those named here are hidden from it
#: (hide_bindings below).
SKIP = ["check_blowup", "init_trajectory", "scene_from_physical", "errata_for_convention", "parse_errata",
        "errata_label", "contact_angle", "contact_radius", "normal_force_group", "friction_group",
        "contact_brackets", "init_model", "sample_count",
        # Explicit-shape arrays and row ranges that nothing checks (the test-only
        # tmafm_testcore.gap_rows checks them).
        "gap_rows"]


_BINDING = r"^(?P<indent>[ \t]*)procedure[ \t]*::[ \t]*(?P<name>{names})\b"


def hide_bindings(sources: list[str], names=SKIP) -> list[str]:
    """The sources f90wrap reads, with each type-bound procedure named in `names` made private
    in a copy under the same name in ./hidden_bindings (f90wrap names its wrappers after the
    file; it then drops the binding; the build compiles the originals).

    A binding such as model_t%gap_rows takes explicit-shape arrays and a row range that nothing
    checks: wrapped, `Model._f.gap_rows(4, 1, 200000, ...)` wrote out of bounds and crashed."""
    pattern = re.compile(_BINDING.format(names="|".join(map(re.escape, names))), re.M | re.I)
    out = []
    for source in sources:
        text = Path(source).read_text()
        if pattern.search(text) is None:
            out.append(source)
            continue
        copy = Path("hidden_bindings") / Path(source).name
        copy.parent.mkdir(exist_ok=True)
        copy.write_text(pattern.sub(lambda m: f"{m['indent']}procedure, private :: {m['name']}", text))
        out.append(str(copy.resolve()))
    return out


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


#: f90wrap's "custom abort handler" around each call in _fwrapmodule.c: it installs a SIGINT
#: handler that longjmps to ONE global jmp_buf, calls the routine, and puts the saved handler
#: back.  Around a call that releases the GIL this is wrong three ways: two overlapping calls
#: save each other's handler, so the last to return can leave f90wrap's handler installed for
#: good; a Ctrl-C longjmps out of the Fortran without the GIL (Py_END_ALLOW_THREADS skipped) and
#: crashed the interpreter; and the handler runs in the main thread, but the jmp_buf may be
#: another thread's, or stale.  Around a short call that holds the GIL it can still jump out of
#: the middle of a malloc, or into another thread's stack.  The core never calls the abort hook
#: (no stop in the library; errors come back as ierr), so the only thing the handler does is
#: turn Ctrl-C into that jump.  Without it, Python's own handler notes the signal and
#: KeyboardInterrupt is raised when the call returns (docs/model-notes.md, finding 12).
_ABORT_BLOCK = re.compile(
    r"/\* setjmp\(\) exception handling added by James Kermode \*/\n"
    r".*?/\*callfortranroutine\*/\n"
    r"(?P<call>.*?)"
    r"\n[ \t]*PyOS_setsig\(SIGINT, _npy_sig_save\);\n[ \t]*\}\n[ \t]*/\* End addition \*/",
    re.S)
_SETJMP_DECL = re.compile(r"^[ \t]*int setjmpvalue; /\* James Kermode - for setjmp \*/\n", re.M)


def drop_abort_handler(path: Path) -> None:
    """Replace f90wrap's SIGINT handler + setjmp block around every call by the bare call.

    Fails the build if any trace of it is left (a new f90wrap that writes it differently)."""
    text = path.read_text()
    blocks = text.count("/* setjmp() exception handling added by James Kermode */")
    text, replaced = _ABORT_BLOCK.subn(
        lambda m: "/* tmafm: no SIGINT handler or setjmp here (f90wrap_gen.py) */\n" + m["call"], text)
    text = _SETJMP_DECL.sub("", text)
    left = [s for s in ("PyOS_setsig(SIGINT", "setjmp(environment_buffer)", "setjmpvalue")
            if s in text]
    if replaced != blocks or blocks == 0 or left:
        raise SystemExit(f"f90wrap_gen: {path}: replaced {replaced} of {blocks} abort-handler "
                         f"blocks, left {left}; has f90wrap changed how it writes them?")
    path.write_text(text)


def main() -> None:
    step, outdir, *rest = sys.argv[1:]
    sources = [str(Path(p).resolve()) for p in rest]
    os.chdir(outdir)
    if step == "f90wrap":
        kind_map, *sources = sources
        sources = hide_bindings(sources)
        subprocess.run([sys.executable, "-m", "f90wrap", "--f90wrap", "-m", "_objects", "-k", kind_map,
                        "--f90-mod-name", "tmafm._fwrap", "--skip", *SKIP,
                        "--", *sources], check=True, stdout=subprocess.DEVNULL)
        for wrapper in Path(".").glob("f90wrap_tmafm_api*.f90"):
            mark_threadsafe(wrapper)
    elif step == "f2py":
        sources = [s for s in sources if s.endswith(".f90")]
        subprocess.run([sys.executable, "-c",
                        "from f90wrap.scripts.f2py_f90wrap import main; main()",
                        "-m", "_fwrap", "--lower", *sources], check=True, stdout=subprocess.DEVNULL)
        for expected in ("_fwrap-f2pywrappers.f",):
            Path(expected).touch()
        drop_abort_handler(Path("_fwrapmodule.c"))
    elif step == "testcore":
        source, f2cmap = sources
        subprocess.run([sys.executable, "-m", "numpy.f2py", source, "-m", "tmafm_testcore", "--lower",
                        "--f2cmap", f2cmap, "--build-dir", "."], check=True,
                       stdout=subprocess.DEVNULL)
        Path("tmafm_testcore-f2pywrappers.f").touch()
    else:
        raise SystemExit(f"unknown step {step!r}")


if __name__ == "__main__":
    main()
