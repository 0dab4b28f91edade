"""The golden tests under other BLAS/LAPACK builds: Debian's reference BLAS and LAPACK, and
OpenBLAS forced to each kernel family (OPENBLAS_CORETYPE).  Each configuration runs the golden
trajectory and analysis tests of tests/test_golden.py (every case, both integrators) in a
subprocess, and that subprocess proves the swap took effect: the libraries mapped into it
(/proc/self/maps) and OpenBLAS's own core name, after the tests ran.  The executable is checked
too: the loader's view of its libraries (LD_TRACE_LOADED_OBJECTS, as ldd does) and the core
OpenBLAS reports for it (OPENBLAS_VERBOSE=2).  A configuration that cannot be applied fails.
When LAPACK and BLAS are linked statically into both (meson.build may do so), no shared BLAS is
mapped at all: the golden tests then run once, and the check is that nothing was mapped.

    python tests/test_blas.py CONFIG      # what each subprocess runs (CONFIG of BLAS_CONFIGS)
"""

import functools
import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("regenerate", HERE / "golden" / "regenerate.py")
regenerate = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(regenerate)

#: The golden tests each configuration runs: every trajectory and every analysis.
SELECTION = "test_golden_trajectory or test_golden_analysis"
MARK = "test_blas result: "


def executable_libraries(exe: str, env: dict) -> dict:
    """The BLAS/LAPACK files the loader maps for the executable under `env`, and the core
    OpenBLAS reports when the executable starts (None without OpenBLAS)."""
    trace = subprocess.run([exe], env={**env, "LD_TRACE_LOADED_OBJECTS": "1"}, capture_output=True,
                           text=True, timeout=60)
    paths = [line.split("=>")[1].split("(")[0].strip() for line in trace.stdout.splitlines()
             if "=>" in line and ("blas" in line or "lapack" in line)]
    run = subprocess.run([exe, "--version"], env={**env, "OPENBLAS_VERBOSE": "2"},
                         capture_output=True, text=True, timeout=60)
    core = None
    for line in (run.stdout + run.stderr).splitlines():
        if line.strip().startswith("Core:"):
            core = line.split(":", 1)[1].strip()
    return {"paths": paths, "openblas_core": core}


def run_configuration(name: str) -> int:
    """In the subprocess: the golden tests, then proof of what was loaded.  When neither the
    extension nor the executable maps any shared BLAS/LAPACK (LAPACK linked statically into
    both), there is nothing to swap and the results cannot depend on the system's BLAS."""
    import pytest as _pytest
    import tmafm
    code = _pytest.main(["-q", "-p", "no:cacheprovider", str(HERE / "test_golden.py"),
                         "-k", SELECTION])
    ext = regenerate.loaded_blas()
    exe = executable_libraries(tmafm.executable(), dict(os.environ))
    static = not ext["paths"] and not exe["paths"]
    problems = [] if static else (
        [f"extension: {p}" for p in regenerate.check_blas(name, ext)]
        + [f"executable: {p}" for p in regenerate.check_blas(name, exe)])
    print(MARK + json.dumps({"pytest": int(code), "problems": problems, "static": static}), flush=True)
    return 0 if code == 0 and not problems else 1


@functools.lru_cache(maxsize=1)
def linked_statically() -> bool:
    """Whether neither the extension nor the executable loads a shared BLAS/LAPACK."""
    import tmafm
    probe = subprocess.run([sys.executable, "-c", "import tmafm._fwrap, json, regenerate; "
                            "print(json.dumps(regenerate.loaded_blas()))"],
                           capture_output=True, text=True, timeout=120, cwd=HERE / "golden", check=True)
    ext = json.loads(probe.stdout.strip().splitlines()[-1])
    exe = executable_libraries(tmafm.executable(), dict(os.environ))
    return not ext["paths"] and not exe["paths"]


@pytest.mark.parametrize("name", list(regenerate.BLAS_CONFIGS))
def test_golden_under_blas(name):
    if name not in regenerate.usable_blas_configs():
        pytest.skip(f"{name} kernels need AVX-512, which this CPU lacks")
    if name != "reference" and linked_statically():
        pytest.skip("LAPACK and BLAS are linked statically: no shared BLAS to swap (the "
                    "reference run checks that none is mapped)")
    for path in ("/usr/lib/x86_64-linux-gnu/lapack/liblapack.so.3",
                 "/usr/lib/x86_64-linux-gnu/blas/libblas.so.3",
                 "/usr/lib/x86_64-linux-gnu/openblas-pthread/liblapack.so.3"):
        assert Path(path).exists(), f"{path} is missing: run .ci/setup (libblas3, liblapack3, libopenblas0)"
    proc = subprocess.run([sys.executable, __file__, name], env=regenerate.blas_environment(name),
                          capture_output=True, text=True, timeout=600, cwd=HERE.parent)
    report = [line for line in proc.stdout.splitlines() if line.startswith(MARK)]
    assert report, f"{name}: no result from the subprocess\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    result = json.loads(report[-1][len(MARK):])
    assert not result["problems"], f"{name}: the configuration did not take effect: {result['problems']}"
    assert result["pytest"] == 0 and proc.returncode == 0, f"{name}:\n{proc.stdout[-5000:]}"


def test_a_wrong_library_is_detected():
    """The check fails loudly when the swap did not happen: OpenBLAS loaded where the
    reference build was asked for, or another OpenBLAS core than the one forced."""
    lapack = "/usr/lib/x86_64-linux-gnu/openblas-pthread/liblapack.so.3"
    openblas = "/usr/lib/x86_64-linux-gnu/openblas-pthread/libopenblas.so.0"
    assert regenerate.check_blas("reference", {"paths": [lapack, openblas], "openblas_core": "Haswell"})
    assert regenerate.check_blas("NEHALEM", {"paths": [lapack, openblas], "openblas_core": "Haswell"})
    assert not regenerate.check_blas("NEHALEM", {"paths": [lapack, openblas], "openblas_core": "Nehalem"})


if __name__ == "__main__":
    sys.exit(run_configuration(sys.argv[1]))
