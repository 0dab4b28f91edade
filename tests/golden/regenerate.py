"""Regenerate the golden trajectories in this folder.  Never edit the .npz files by hand.

    /opt/tmafm-venv/bin/python tests/golden/regenerate.py

Each case is a short run (tau <= 10) of an input of inputs/, in one convention, stored as
<case>.npz with the arrays of tmafm.run and the resolved input (JSON) that produced them.
analysis.json holds the analysis outputs (tmafm.analysis.summary: classification, contact
fraction, V_T range, modal amplitudes, dissipation) of every figure input, with both the
paper's scheme and flight_exact, over 16 drive periods.
Rerun this only when a change of the numbers is intended, and say why in the commit.

    /opt/tmafm-venv/bin/python tests/golden/regenerate.py --errors

writes only the error estimates the golden tests derive their tolerances from (the goldens
themselves are left untouched; rerun it after regenerating them):
- errors.npz: per trajectory case and array, the running maximum over time of |stored - a much
  more accurate run of the same scene| (the same method at a 16x smaller step, or the adaptive
  methods at a 100x tighter rtol and atol), per column; and the largest difference between the
  stored arrays and the same case computed under each BLAS configuration of BLAS_CONFIGS;
  and the round-off spread: the running maximum of |stored - the same run with the drive
  frequency nudged by a few ulps| (NUDGES), per column;
- analysis_errors.json: the same three estimates for the analysis outputs, plus the trajectory
  error over the analysed window and the Poincare-section distances that decide the
  classification, for the stored run and the accurate one.
tests/test_golden.py states how the tolerances follow from them.
"""

import json
import math
import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import tmafm

HERE = Path(__file__).resolve().parent
INPUTS = HERE.parent.parent / "inputs"

FIGURE_INPUTS = ("fig2_n1", "fig2_n2", "fig2_n3", "fig2_n4", "fig3", "fig4a", "fig4c", "fig5a",
                 "fig5c", "fig6", "fig7_hertz", "fig7_dmt")

#: case name -> (input file, overrides): three scenes in both conventions with the paper's
#: scheme, and every figure input with both integrators (the located one at rtol 1e-10).
CASES = {
    f"{name}_{convention}": (f"{name}.nml", {"model": {"convention": convention},
                                             "solver": {"tau_end": 10.0},
                                             "output": {"sample_dtau": 0.05}})
    for name in ("fig2_n4", "fig6", "fig7_dmt")
    for convention in ("paper", "consistent")
}
CASES.update({
    f"{name}_paper_{method}": (f"{name}.nml", {"model": {"convention": "paper"},
                                               "solver": {**settings, "tau_end": 10.0},
                                               "output": {"sample_dtau": 0.05}})
    for name in FIGURE_INPUTS
    for method, settings in (("rk4_paper", {"method": "rk4_paper"}),
                             ("flight_exact", {"method": "flight_exact", "rtol": 1e-10, "atol": 1e-16}))
})

ARRAYS = ("tau", "vt", "vtdot", "contact", "a", "adot")
ANALYSIS_METHODS = {"rk4_paper": {"method": "rk4_paper"},
                    "flight_exact": {"method": "flight_exact", "rtol": 1e-9, "atol": 1e-15}}
ANALYSIS_PERIODS = 16
#: The analysis outputs kept in the golden file.
ANALYSIS_KEYS = ("classification", "period", "contact_fraction", "contacts_per_period", "vt_min",
                 "vt_max", "max_indentation", "dissipated_per_period", "modal_amplitudes")


def analysis_run(name: str, method: str, accurate: bool = False, nudge: float = 1.0):
    """The run the golden analysis of one figure input and method reads (tmafm.Result);
    `accurate` gives the much more accurate run of the same scene (see `more_accurate`), and
    `nudge` a factor on the drive frequency (see NUDGES)."""
    period = math.pi  # 2 pi / Omega with Omega = 2 in every figure
    solver = {**ANALYSIS_METHODS[method], "tau_end": ANALYSIS_PERIODS * period}
    output = {"sample_dtau": period / 200}
    if accurate:
        solver = {**solver, **more_accurate(_resolved_solver(f"{name}.nml", solver=solver, output=output))}
    overrides = {"solver": solver, "output": output}
    if nudge != 1.0:
        overrides = nudged(f"{name}.nml", overrides, nudge)
    return tmafm.run(INPUTS / f"{name}.nml", **overrides)


def summarize(result, tol: float | None = None) -> dict:
    """The golden analysis outputs (ANALYSIS_KEYS of tmafm.analysis.summary) of a run."""
    from tmafm import analysis
    summary = analysis.summary(result, tol=tol)
    return json.loads(json.dumps({key: summary[key] for key in ANALYSIS_KEYS}))


def compute_analysis(name: str, method: str) -> dict:
    """The golden analysis outputs of one figure input and method."""
    return summarize(analysis_run(name, method))


#: How much more accurate the reference run of an error estimate is: fixed-step methods take
#: a 16x smaller step (the step in contact shrinks with it), adaptive ones a 100x tighter
#: rtol and atol.  rk4_paper is first order, so the stored run's error is then
#: 16/15 |stored - reference|; the others converge faster still.
STEP_DIVISOR = 16
TOLERANCE_DIVISOR = 100

#: Round-off nudges: the same run with the drive frequency Omega times each factor.  Another
#: compiler, instruction set (FMA) or libm changes a run by round-off at every step; a nudge of
#: a few ulps does so on purpose.  Where an adaptive run's accept/reject decision or a located
#: event's last iteration then goes the other way, the result moves by the method's error, not
#: by round-off, and |stored - accurate| may by chance be smaller than that (fig6's located V_T
#: maximum with flight_exact, under the PI gains before the pow-free controller: a build with
#: fused multiply-adds failed its golden).  The spread over the nudges measures it.
NUDGES = (1 + 4 * np.finfo(float).eps, 1 - 4 * np.finfo(float).eps)


def nudged(file: str, overrides: dict, factor: float) -> dict:
    """`overrides` with the resolved drive frequency of input `file` (under them) times factor."""
    resolved = tmafm.resolve(INPUTS / file, **overrides)
    omega = (resolved[0] if isinstance(resolved, tuple) else resolved)["scene"]["omega"]
    return {**overrides, "scene": {**overrides.get("scene", {}), "omega": omega * factor}}


def _resolved_solver(file: str, **overrides):
    """The resolved &solver group of an input of inputs/ with overrides."""
    resolved = tmafm.resolve(INPUTS / file, **overrides)
    return (resolved[0] if isinstance(resolved, tuple) else resolved)["solver"]


def more_accurate(solver) -> dict:
    """Solver overrides for a much more accurate run of the same method."""
    if solver["method"] in ("rk4_paper", "rk4_event"):
        return {"dtau": solver["dtau"] / STEP_DIVISOR}
    return {"rtol": solver["rtol"] / TOLERANCE_DIVISOR, "atol": solver["atol"] / TOLERANCE_DIVISOR}


def case_run(case: str, accurate: bool = False, nudge: float = 1.0):
    """The run of one golden case (tmafm.Result), its much more accurate twin, or the same run
    with the drive frequency times `nudge` (see NUDGES)."""
    file, overrides = CASES[case]
    if accurate:
        more = more_accurate(_resolved_solver(file, **overrides))
        overrides = {**overrides, "solver": {**overrides["solver"], **more}}
    if nudge != 1.0:
        overrides = nudged(file, overrides, nudge)
    return tmafm.run(INPUTS / file, **overrides)


def compute(case: str) -> dict:
    """The arrays and metadata of one golden case, as tmafm computes them now."""
    result = case_run(case)
    data = {key: getattr(result, key) for key in ARRAYS}
    data["resolved"] = np.array(json.dumps(result.resolved.todict(complex_tuple=False), default=str))
    data["counters"] = np.array(json.dumps(result.counters))
    return data


#: BLAS/LAPACK configurations the golden results are checked under (tests/test_blas.py) and
#: whose spread sets the round-off floor of the golden tolerances: name -> (environment,
#: what must then be loaded).  "reference" swaps in Debian's reference BLAS and LAPACK
#: (libblas3, liblapack3) through LD_LIBRARY_PATH; the others are OpenBLAS (libopenblas0)
#: forced to one kernel family with OPENBLAS_CORETYPE.  SKYLAKEX needs AVX-512.
LIBDIR = "/usr/lib/x86_64-linux-gnu"
BLAS_CONFIGS = {
    "reference": ({"LD_LIBRARY_PATH": f"{LIBDIR}/lapack:{LIBDIR}/blas"},
                  {"lapack": f"{LIBDIR}/lapack/liblapack.so.3", "blas": f"{LIBDIR}/blas/libblas.so.3",
                   "openblas_core": None}),
    **{core: ({"OPENBLAS_CORETYPE": core},
              {"lapack": f"{LIBDIR}/openblas-pthread/liblapack.so.3", "blas": "libopenblas",
               "openblas_core": core})
       for core in ("PRESCOTT", "NEHALEM", "SANDYBRIDGE", "HASWELL", "SKYLAKEX")},
}


def cpu_has_avx512() -> bool:
    """Whether this CPU can run the SKYLAKEX kernels."""
    try:
        return " avx512f " in f" {Path('/proc/cpuinfo').read_text()} ".replace("\n", " ")
    except OSError:
        return False


def usable_blas_configs() -> list[str]:
    """The BLAS_CONFIGS this machine can run."""
    return [name for name in BLAS_CONFIGS if name != "SKYLAKEX" or cpu_has_avx512()]


def blas_environment(name: str) -> dict:
    """os.environ with BLAS configuration `name` applied (and no stray BLAS settings)."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("LD_LIBRARY_PATH", "LD_PRELOAD", "OPENBLAS_CORETYPE")}
    env.update(BLAS_CONFIGS[name][0])
    return env


def loaded_blas() -> dict:
    """The BLAS and LAPACK libraries this process has mapped (from /proc/self/maps) and
    OpenBLAS's core name, if OpenBLAS is loaded.  numpy's own bundled OpenBLAS is ignored."""
    import ctypes
    paths = sorted({line.split()[-1] for line in Path("/proc/self/maps").read_text().splitlines()
                    if ("blas" in line or "lapack" in line) and "numpy.libs" not in line
                    and "scipy" not in line and line.split()[-1].startswith("/")})
    core = None
    openblas = [p for p in paths if "libopenblas" in Path(p).name]
    if openblas:
        lib = ctypes.CDLL(openblas[0])
        lib.openblas_get_corename.restype = ctypes.c_char_p
        core = lib.openblas_get_corename().decode()
    return {"paths": paths, "openblas_core": core}


def check_blas(name: str, loaded: dict) -> list[str]:
    """What is wrong with `loaded` (from loaded_blas) for configuration `name`; [] if right."""
    want = BLAS_CONFIGS[name][1]
    real = [os.path.realpath(p) for p in loaded["paths"]]
    problems = []
    if not any(r == os.path.realpath(want["lapack"]) for r in real):
        problems.append(f"LAPACK is not {want['lapack']}: loaded {loaded['paths']}")
    if want["blas"] == "libopenblas":
        if not any("libopenblas" in Path(r).name for r in real):
            problems.append(f"OpenBLAS is not loaded: {loaded['paths']}")
    elif not any(r == os.path.realpath(want["blas"]) for r in real):
        problems.append(f"BLAS is not {want['blas']}: loaded {loaded['paths']}")
    if any("libopenblas" in Path(r).name for r in real) and want["openblas_core"] is None:
        problems.append(f"OpenBLAS is loaded but should not be: {loaded['paths']}")
    core = loaded["openblas_core"]
    if want["openblas_core"] is not None and (core or "").lower() != want["openblas_core"].lower():
        problems.append(f"OpenBLAS runs the {core!r} kernels, not {want['openblas_core']}")
    return problems


def dump_all() -> dict:
    """Every golden case's arrays and every analysis, computed in this process."""
    cases = {case: {key: np.asarray(value) for key, value in compute(case).items() if key in ARRAYS}
             for case in CASES}
    from tmafm import analysis
    table, sections = {}, {}
    for name in FIGURE_INPUTS:
        for method in ANALYSIS_METHODS:
            result = analysis_run(name, method)
            table[f"{name}/{method}"] = summarize(result)
            sections[f"{name}/{method}"] = section_evidence(result, analysis.default_tolerance(result))
    return {"cases": cases, "analysis": table, "sections": sections, "loaded": loaded_blas()}


def under_blas(name: str) -> dict:
    """dump_all computed in a subprocess under BLAS configuration `name`; fails loudly when
    the configuration did not take effect."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "dump.pkl"
        subprocess.run([sys.executable, __file__, "--dump", str(out)], env=blas_environment(name),
                       check=True)
        data = pickle.loads(out.read_bytes())
    problems = check_blas(name, data["loaded"])
    if problems:
        raise RuntimeError(f"BLAS configuration {name}: " + "; ".join(problems))
    return data


def _leaves(value, path="", numbers_only=True):
    """(path, value) for every number (or, with numbers_only=False, every leaf) of a nested
    analysis table."""
    if isinstance(value, dict):
        for key in sorted(value):
            yield from _leaves(value[key], f"{path}.{key}", numbers_only)
    elif isinstance(value, list):
        for k, item in enumerate(value):
            yield from _leaves(item, f"{path}[{k}]", numbers_only)
    elif not numbers_only or (isinstance(value, (int, float)) and not isinstance(value, bool)):
        yield path, value


def running_max(diff: np.ndarray) -> np.ndarray:
    """Running maximum over time (axis 0)."""
    return np.maximum.accumulate(diff, axis=0)


def window_error(stored, accurate) -> dict:
    """Largest |stored - accurate| of V_T and of each a_j, over the analysed second half."""
    keep = stored.tau >= stored.tau[-1] / 2 - math.pi
    return {"vt": float(np.abs(stored.vt - accurate.vt)[keep].max()),
            "a": np.abs(stored.a - accurate.a)[keep].max(axis=0).tolist()}


def section_evidence(result, tol: float) -> dict:
    """The Poincare-section distances that decide the classification of `result`."""
    from tmafm import analysis
    evidence = analysis.classify_period(result, tol=tol, max_period=8, window=8)["distances"]
    return {str(n): d for n, d in evidence.items()}


def write_errors() -> None:
    """errors.npz and analysis_errors.json: the error estimates of every golden."""
    # A build that links LAPACK and BLAS statically (meson.build) maps no shared BLAS: no
    # configuration can swap it, so there is no BLAS spread to measure (it is zero).
    swappable = bool(loaded_blas()["paths"])
    spread = {name: under_blas(name) for name in usable_blas_configs()} if swappable else {}
    arrays = {}
    for case in CASES:
        stored = np.load(HERE / f"{case}.npz")
        accurate = case_run(case, accurate=True)
        nudges = [case_run(case, nudge=factor) for factor in NUDGES]
        for key in ARRAYS:
            old = np.asarray(stored[key], float)
            if key != "contact":
                arrays[f"{case}/{key}/method"] = running_max(np.abs(old - np.asarray(getattr(accurate, key), float)))
                arrays[f"{case}/{key}/roundoff"] = running_max(np.max(
                    [np.abs(old - np.asarray(getattr(run, key), float)) for run in nudges], axis=0))
            arrays[f"{case}/{key}/blas"] = np.max(
                [np.abs(np.asarray(d["cases"][case][key], float) - old).max(axis=0) for d in spread.values()]
                or [np.zeros(old.shape[1:])], axis=0)
    np.savez_compressed(HERE / "errors.npz", **arrays)
    print(f"wrote {HERE / 'errors.npz'}")

    from tmafm import analysis
    stored_table = json.loads((HERE / "analysis.json").read_text())
    table = {}
    for name in FIGURE_INPUTS:
        for method in ANALYSIS_METHODS:
            key = f"{name}/{method}"
            stored_run = analysis_run(name, method)
            accurate_run = analysis_run(name, method, accurate=True)
            nudged_runs = [analysis_run(name, method, nudge=factor) for factor in NUDGES]
            tol = analysis.default_tolerance(stored_run)
            accurate = summarize(accurate_run, tol=tol)
            old = dict(_leaves(stored_table[key]))
            new = dict(_leaves(accurate))
            nudged_leaves = [dict(_leaves(summarize(run, tol=tol))) for run in nudged_runs]
            nudged_sections = [section_evidence(run, tol) for run in nudged_runs]
            blas = {path: max([abs(dict(_leaves(d["analysis"][key])).get(path, value) - value)
                               for d in spread.values()], default=0.0)
                    for path, value in old.items()}
            table[key] = {"method": {path: abs(new[path] - value) if path in new else None
                                     for path, value in old.items()},
                          "blas": blas,
                          "roundoff": {path: max(abs(leaves[path] - value) if leaves.get(path) is not None
                                                 and value is not None else 0.0 for leaves in nudged_leaves)
                                       for path, value in old.items()},
                          "trajectory": window_error(stored_run, accurate_run),
                          "classification_tolerance": tol,
                          "sections": section_evidence(stored_run, tol),
                          "sections_blas": {n: max([abs(d["sections"][key][n] - value) for d in spread.values()],
                                                   default=0.0)
                                            for n, value in section_evidence(stored_run, tol).items()},
                          "sections_roundoff": {n: max(abs(sections[n] - value) for sections in nudged_sections)
                                                for n, value in section_evidence(stored_run, tol).items()},
                          "sections_accurate": section_evidence(accurate_run, tol),
                          "classification_accurate": accurate["classification"]}
    (HERE / "analysis_errors.json").write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")
    print(f"wrote {HERE / 'analysis_errors.json'}")


def summarize_errors() -> None:
    """Print, per method, the largest method error estimate and BLAS spread of V_T and a
    (from errors.npz), and how many analysis classifications are well conditioned."""
    errors = np.load(HERE / "errors.npz")
    methods = {"rk4_paper": [c for c in CASES if not c.endswith("flight_exact")],
               "flight_exact": [c for c in CASES if c.endswith("flight_exact")]}
    for method, cases in methods.items():
        for key in ("vt", "a"):
            m = max(float(errors[f"{c}/{key}/method"].max()) for c in cases)
            b = max(float(errors[f"{c}/{key}/blas"].max()) for c in cases)
            r = max(float(errors[f"{c}/{key}/roundoff"].max()) for c in cases)
            print(f"{method:13s} {key:3s} method error <= {m:.1e}   BLAS spread <= {b:.1e}   "
                  f"round-off spread <= {r:.1e}   ({len(cases)} cases)")
    table = json.loads((HERE / "analysis_errors.json").read_text())
    for method in ANALYSIS_METHODS:
        rel = [abs(v) / abs(old) for key, t in table.items() if key.endswith(method)
               for path, old in _leaves(json.loads((HERE / "analysis.json").read_text())[key])
               for v in [t["blas"].get(path, 0.0)] if isinstance(old, float) and old]
        print(f"analysis {method}: largest relative BLAS spread {max(rel):.1e}")
        over = [(t["roundoff"][path] / (t["method"].get(path) or 0.0) if t["method"].get(path) else math.inf,
                 key + path)
                for key, t in table.items() if key.endswith(method)
                for path in t["roundoff"] if t["roundoff"][path] > (t["method"].get(path) or 0.0)]
        print(f"analysis {method}: {len(over)} numbers whose round-off spread exceeds their method error"
              + (f", most {max(over)[0]:.0f}x ({max(over)[1]})" if over else ""))


def main() -> None:
    if sys.argv[1:] == ["--summary"]:
        summarize_errors()
        return
    if sys.argv[1:2] == ["--dump"]:
        Path(sys.argv[2]).write_bytes(pickle.dumps(dump_all()))
        return
    if sys.argv[1:] == ["--errors"]:
        write_errors()
        return
    for case in CASES:
        np.savez_compressed(HERE / f"{case}.npz", **compute(case))
        print(f"wrote {HERE / (case + '.npz')}")
    table = {f"{name}/{method}": compute_analysis(name, method)
             for name in FIGURE_INPUTS for method in ANALYSIS_METHODS}
    (HERE / "analysis.json").write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")
    print(f"wrote {HERE / 'analysis.json'}")
    write_errors()


if __name__ == "__main__":
    main()
