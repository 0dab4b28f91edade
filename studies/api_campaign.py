"""Hostile Python calls campaign (issue 27): seeded calls to the public Python API, each of which
must return finite documented results or raise a typed tmafm exception with one line.

    /opt/tmafm-venv/bin/python studies/api_campaign.py [--calls 3000] [--first-seed 0]
        [--timeout 60] [--out studies/results/api_campaign.json]

Each call is rebuilt from its seed by ``generate(seed)`` (numpy's PCG64): an entry point and its
arguments, most of them good and cheap (a few drive periods), one to three of them hostile.
The entry points: ``tmafm.run`` and ``tmafm.Config`` with overrides of any key (the new ones
too: ``contact_law = 'jkr'``, ``&initial in_contact``, ``tip_bias``, ``debye_length``,
``ionic_strength``, the surface potentials, ``&output sample_from``/``last_periods``, the
capillary meniscus's keys), the
Config's properties and methods, ``tmafm.observe``, the Result's methods and ``tmafm.load``
(also of a damaged archive), ``tmafm.Model``'s methods, the analysis functions,
``tmafm.approach``, ``tmafm.frequency_sweep``, ``tmafm.continuation``, ``tmafm.sweep``,
``sweeps.write_dataset``, ``read_dataset``, ``summarize`` and the sweep command line
(``sweeps.main``, never on a real sweep file).  The hostile values:
wrong types (None, bools, strings, bytes, lists, nested lists, dicts, object arrays, an object
whose repr raises), NaN and infinities, 10**400, huge and tiny reals, negative counts, numpy
scalars, and hostile paths (missing folders, a folder, a NUL byte, 5000 characters).

The calls run in a worker process, one at a time, so a crash (a signal) or a hang (no answer
within --timeout s) is seen and counted, and the worker is started again for the next call.
Outcome classes: ``ok`` (returned; a Result's, an Observation's and a Dataset's arrays are
finite where the docs promise it), ``ok-error`` (a tmafm.TmafmError, or SystemExit 0/2 from a
main, with a one-line message under 1200 characters) keep the contract; ``raw-exception``,
``multi-line-error``, ``non-finite``, ``crash`` and ``hang`` break it.  Writes JSON: the version,
the commit, the counts per class and per entry point, every call that broke the contract (seed,
entry, what was called, the detail), and the CPU time.  tests/test_api_campaign.py runs a
seeded tier of it in CI.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import select
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
BISTABLE = REPO / "inputs" / "sweeps" / "bistable_n2.nml"
GOOD = {"ok", "ok-error"}
#: The inputs a call starts from, with the overrides that keep a run short.
BASES = {
    "fig2_n4": {"solver": {"tau_end": 0.5}},
    "tapping_polystyrene": {"solver": {"tau_end": 2.0}},
    "biased_tip": {"solver": {"tau_end": 2.0}},
    "dlvo_water": {"solver": {"tau_end": 2.0}},
    "sls_polystyrene": {"solver": {"tau_end": 2.0}},
    "fig3": {"solver": {"tau_end": 2.0}},
}
#: Keys that set what a run costs: hostile values only of a wrong type or out of range.
COSTLY = {("solver", "tau_end"), ("solver", "dtau"), ("solver", "max_steps"), ("solver", "rtol"),
          ("solver", "atol"), ("solver", "contact_refine"), ("output", "sample_dtau"),
          ("model", "n_modes"), ("model", "mode_horizon"), ("model", "mode_tol"),
          ("scene", "omega"), ("physical", "drive_frequency"), ("physical", "drive_angular_frequency")}
#: Keys of the new physics and options, drawn more often.
NEW_KEYS = [("model", "contact_law"), ("initial", "in_contact"), ("physical", "tip_bias"),
            ("physical", "debye_length"), ("physical", "ionic_strength"),
            ("physical", "contact_potential"), ("physical", "tip_surface_potential"),
            ("physical", "sample_surface_potential"), ("physical", "temperature"),
            ("physical", "medium_permittivity"), ("physical", "cone_half_angle"),
            ("output", "sample_from"), ("output", "last_periods"), ("physical", "relative_humidity"),
            ("physical", "meniscus_rupture_distance"), ("physical", "water_contact_angle"),
            ("physical", "water_surface_tension"), ("scene", "capillary_strength"), ("scene", "capillary_range")]


class Odd:
    """An object of no type tmafm knows, whose repr raises."""

    def __repr__(self):
        raise RuntimeError("a __repr__ that raises")


def hostile(rng) -> object:
    """One hostile value."""
    pool = [
        lambda: None, lambda: True, lambda: False, lambda: int(rng.integers(-5, 6)),
        lambda: 10**400, lambda: -10**400, lambda: 2**63, lambda: float("nan"), lambda: float("inf"),
        lambda: -float("inf"), lambda: 1e308, lambda: -1e308, lambda: 5e-324, lambda: 1e-300,
        lambda: float(rng.normal() * 10.0 ** rng.integers(-12, 13)), lambda: -0.0,
        lambda: "", lambda: "jkr", lambda: "dopri5", lambda: "nan", lambda: "1e3", lambda: "a'b\"c",
        lambda: "x" * int(rng.integers(60, 2000)), lambda: b"\x00\xff", lambda: [1.0, 2.0],
        lambda: [[0.1], [0.2, 0.3]], lambda: [], lambda: {"a": 1}, lambda: (1,),
        lambda: np.array([object(), None], dtype=object), lambda: np.array([[1.0, np.nan]]),
        lambda: np.float64("nan"), lambda: np.int64(-1), lambda: np.float32(3.5), lambda: np.bool_(True),
        lambda: np.array(2.0), lambda: np.datetime64("2020-01-01"), lambda: np.timedelta64(3, "s"),
        lambda: complex(1, 1), lambda: Odd(), lambda: object(), lambda: Path("x"),
    ]
    return pool[int(rng.integers(len(pool)))]()


def hostile_path(rng, folder: Path) -> object:
    """A hostile place to write to or read from."""
    pool = [
        lambda: None, lambda: 3, lambda: "", lambda: folder / "no" / "such" / "dir" / "x.npz",
        lambda: folder, lambda: str(folder / "a\x00b.npz"), lambda: folder / ("y" * 5000 + ".npz"),
        lambda: folder / "x.txt", lambda: folder / "x.nc", lambda: Path("/proc/version"),
        lambda: Path("/"), lambda: folder / "ok.npz", lambda: b"bytes.npz", lambda: [folder],
        lambda: hostile(rng),
    ]
    return pool[int(rng.integers(len(pool)))]()


def key_types():
    from tmafm._namelist import KEY_TYPES
    return KEY_TYPES


def plausible(rng, group: str, key: str) -> object:
    """A value of the key's own type, mostly inside the range the key table states (so the
    call goes past the reader into the physics), sometimes just outside it."""
    import re
    from tmafm._namelist import KEYS
    row = next(k for k in KEYS if k.group == group and k.name == key)
    if row.type == "string":
        words = re.findall(r"'([^']*)'", row.range) or ["x"]
        return words[int(rng.integers(len(words)))]
    numbers = [float(x) for x in re.findall(r"[-+]?\d+\.?\d*(?:[eE][-+]?\d+)?", row.range)]
    low, high = (numbers[0], numbers[1]) if len(numbers) >= 2 else (0.0, 1.0)
    if row.type == "integer":
        return int(rng.integers(int(low) - 1, min(int(high), int(low) + 8) + 2))
    if row.type.startswith("list"):
        low, high = numbers[-2], numbers[-1]  # each value's bounds, after the count's
        return [float(v) for v in rng.uniform(max(low, -1e-3), min(high, 1e-3), int(rng.integers(1, 6)))]
    if rng.random() < 0.1:
        return [low, high, low - abs(low) * 1e-9 - 1e-300, high * (1 + 1e-9)][int(rng.integers(4))]
    if low > 0:
        return float(math.exp(rng.uniform(math.log(low), math.log(high))))
    top = high if high > 0 else 1.0
    value = top * 10.0 ** rng.uniform(-8, 0)
    return -value if low < 0 and rng.random() < 0.5 else value


def overrides_of(rng, base: str, count: int) -> dict:
    """The base's cheap overrides plus `count` hostile (or valid but unusual) entries."""
    types = key_types()
    groups = {g: dict(v) for g, v in BASES[base].items()}
    keys = [(g, k) for g in types for k in types[g]]
    for _ in range(count):
        if rng.random() < 0.35:
            group, key = NEW_KEYS[int(rng.integers(len(NEW_KEYS)))]
        else:
            group, key = keys[int(rng.integers(len(keys)))]
        if group in ("scene", "physical"):
            # The base gives one of the two; a key of the other group is a refusal to check too.
            if rng.random() < 0.7:
                group = "physical" if base in ("tapping_polystyrene", "biased_tip", "dlvo_water",
                                               "sls_polystyrene") else "scene"
                if key not in types[group]:
                    key = list(types[group])[int(rng.integers(len(types[group])))]
        if key not in types.get(group, {}):
            value = hostile(rng)
        elif rng.random() < 0.5 and (group, key) not in COSTLY:
            value = plausible(rng, group, key)
        else:
            value = hostile(rng)
        if (group, key) in COSTLY and isinstance(value, (int, float)) and not isinstance(value, bool) \
                and value > 0 and (isinstance(value, int) or math.isfinite(value)):
            value = -abs(value)  # a cost key gets no large valid value: the run stays short
        if rng.random() < 0.15:
            value = {"contact_law": "jkr", "in_contact": int(rng.integers(-1, 2)), "method": "dop853",
                     "last_periods": int(rng.integers(0, 4)), "sample_from": float(rng.random()),
                     "relative_humidity": float(rng.random())}.get(key, value)
        groups.setdefault(group, {})[key] = value
    if rng.random() < 0.03:
        groups[["bogus", "Solver", "output"][int(rng.integers(3))]] = hostile(rng)  # a group not a dict
    return groups


class Call:
    """One generated call: what it does (for the report) and the thunk that does it."""

    def __init__(self, seed, entry, what, thunk):
        self.seed, self.entry, self.what, self.thunk = seed, entry, what, thunk


def _short(value) -> str:
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 (Odd: its repr raises on purpose)
        text = f"<{type(value).__name__} whose repr raises>"
    return text if len(text) < 120 else text[:117] + "..."


class Cache:
    """Things a worker makes once: a short Result, its saved archive, a Model, a Config."""

    def __init__(self, folder: Path):
        self.folder = folder
        self._result = None

    def result(self):
        import tmafm
        if self._result is None:
            period = 2 * math.pi / 2.0
            # 52 periods: enough for every analysis function (classify_period needs 48).
            self._result = tmafm.run("fig2_n4", solver={"tau_end": 52 * period},
                                     output={"sample_dtau": period / 20})
            self._result.save(self.folder / "good.npz")
        return self._result

    def dataset(self):
        import tmafm
        if getattr(self, "_dataset", None) is None:
            self._dataset = tmafm.sweep("fig2_n4", {"scene.delta_hat": [0.2, 0.1]}, max_periods=2, workers=1)
        return self._dataset


def generate(seed: int, folder: Path, cache: Cache) -> Call:
    """The call of `seed`; `folder` is where paths it writes point."""
    import tmafm
    from tmafm import analysis
    rng = np.random.Generator(np.random.PCG64(seed))
    base = list(BASES)[int(rng.integers(len(BASES)))]
    family = rng.choice(["run", "config", "observe", "result", "analysis", "model", "load", "curve",
                         "continuation", "sweep", "dataset", "cli"],
                        p=[0.27, 0.12, 0.12, 0.07, 0.09, 0.07, 0.06, 0.05, 0.05, 0.04, 0.03, 0.03])
    count = int(rng.integers(1, 4))
    if family == "run":
        groups = overrides_of(rng, base, count)
        return Call(seed, "run", f"run({base!r}, **{_short(groups)})", lambda: tmafm.run(base, **groups))
    if family == "config":
        groups = overrides_of(rng, base, count - 1) if count > 1 else dict(BASES[base])
        member = rng.choice(["scene", "derived", "text", "n_samples", "n_modes", "mode_search",
                             "to_dict", "write", "model", "run", "pickle"])
        arg = hostile_path(rng, folder) if member == "write" else hostile(rng)

        def config_call():
            config = tmafm.Config(base, **groups)
            if member == "write":
                return config.write(arg)
            if member == "run":
                return config.run(arg if rng.random() < 0.7 else None)
            if member == "model":
                return config.model()
            if member == "pickle":
                import pickle
                return pickle.loads(pickle.dumps(config)).run()
            value = getattr(config, member)
            return value() if callable(value) else value
        return Call(seed, f"Config.{member}", f"Config({base!r}, **{_short(groups)}).{member}({_short(arg)})",
                    config_call)
    if family == "observe":
        groups = overrides_of(rng, base, count - 1) if count > 1 else {}
        keywords = {"max_periods": int(rng.integers(1, 4))}
        name = rng.choice(["max_periods", "p_max", "steady_tol", "steady_repeats", "harmonics",
                           "stop_at_steady", "observables", "none"])
        if name != "none":
            value = hostile(rng)
            if name == "max_periods" and isinstance(value, int) and not isinstance(value, bool) and value > 3:
                value = -value
            if name == "observables" and rng.random() < 0.5:
                value = list(rng.choice(["lockin", "extrema", "peak_force", "energy", "bogus"],
                                        size=int(rng.integers(0, 3))))
            keywords[name] = value
        return Call(seed, "observe", f"observe({base!r}, {_short(keywords)}, **{_short(groups)})",
                    lambda: tmafm.observe(base, **keywords, **groups))
    if family == "result":
        member = rng.choice(["force_distance", "save", "repr", "resolved", "scene", "derived", "mode_search"])
        arg = hostile_path(rng, folder)

        def result_call():
            result = cache.result()
            if member == "save":
                return result.save(arg)
            if member == "repr":
                return repr(result)
            if member == "force_distance":
                physical = tmafm.run("tapping_polystyrene", **BASES["tapping_polystyrene"],
                                     **({"physical": {"drive_frequency": 0.0}} if rng.random() < 0.3 else {}))
                return physical.force_distance()
            return getattr(result, member)
        return Call(seed, f"Result.{member}", f"Result.{member}({_short(arg)})", result_call)
    if family == "analysis":
        names = [n for n in analysis.__all__ if callable(getattr(analysis, n)) and n != "sample_dtau_for"]
        name = names[int(rng.integers(len(names)))]
        value = hostile(rng)
        slot = rng.choice(["since", "tol", "max_period", "hold", "k_max", "harmonics", "window",
                           "tau0", "result"])

        def analysis_call():
            import inspect
            function = getattr(analysis, name)
            parameters = inspect.signature(function).parameters
            result = cache.result()
            args = {"section_distances": [np.zeros((6, 8)), 1], "classify_sections": [np.zeros((6, 8))],
                    "energy_balance": [result, 0.0, 3.0]}.get(name, [result])
            keywords = {}
            if slot == "result":
                args[0] = value
            elif slot == "tau0" and name == "energy_balance":
                args[1] = value
            elif slot in parameters:
                keywords[slot] = value
            return function(*args, **keywords)
        return Call(seed, f"analysis.{name}", f"analysis.{name}({slot} = {_short(value)})", analysis_call)
    if family == "model":
        member = rng.choice(["derivative", "matrices", "contact", "energy_flow", "trajectory_energy_flow"])
        slot = int(rng.integers(0, 3))
        value = hostile(rng)

        def model_call():
            model = tmafm.Model(base)
            n = model.n_modes
            size = 2 * n + (1 if base == "sls_polystyrene" else 0)
            args = {"derivative": [0.0, np.zeros(size), False], "matrices": [0.0, np.zeros(n), False],
                    "contact": [0.0, np.zeros(n)], "energy_flow": [0.0, np.zeros(n), np.zeros(n), False],
                    "trajectory_energy_flow": [np.zeros(3), np.zeros((3, n)), np.zeros((3, n)),
                                               np.zeros(3, dtype=np.int8)]}[member]
            args[min(slot, len(args) - 1)] = value
            return getattr(model, member)(*args)
        return Call(seed, f"Model.{member}", f"Model({base!r}).{member}(#{slot} = {_short(value)})", model_call)
    if family == "load":
        kind = rng.choice(["path", "damaged"])
        arg = hostile_path(rng, folder)
        cut = int(rng.integers(0, 4000))
        flip = int(rng.integers(0, 4000))

        def load_call():
            if kind == "path":
                return tmafm.load(arg)
            cache.result()
            data = bytearray((folder / "good.npz").read_bytes())
            if rng.random() < 0.5:
                data = data[:cut]
            elif data:
                data[flip % len(data)] ^= 0xFF
            target = folder / f"damaged-{seed}.npz"
            target.write_bytes(bytes(data))
            return tmafm.load(target)
        return Call(seed, f"load.{kind}", f"load({kind}, {_short(arg)}, cut {cut}, flip {flip})", load_call)
    if family == "curve":
        which = rng.choice(["approach", "frequency_sweep"])
        values = [hostile(rng) if rng.random() < 0.5 else float(v) for v in rng.uniform(0.1, 0.3, 2)]
        keywords = {"max_periods": int(rng.integers(1, 4)), "workers": 1}
        if rng.random() < 0.5:
            name = rng.choice(["retract", "jump_threshold", "curves", "workers", "max_periods", "steady_tol",
                               "bogus"])
            value = hostile(rng)
            if name in ("workers", "max_periods") and isinstance(value, int) and not isinstance(value, bool) \
                    and value > 3:
                value = -value
            keywords[name] = value
        if rng.random() < 0.2:
            values = hostile(rng)

        def curve_call():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if which == "approach":
                    return tmafm.approach("fig2_n4", values, **keywords)
                omega = values if not isinstance(values, list) else [2.0 + v for v in values
                                                                      if isinstance(v, float)] or values
                return tmafm.frequency_sweep("fig2_n4", omega, **keywords)
        return Call(seed, which, f"{which}(fig2_n4, {_short(values)}, {_short(keywords)})", curve_call)
    if family == "sweep":
        key = str(rng.choice(["scene.delta_hat", "scene.alpha2", "model.n_modes", "physical.tip_bias",
                              "scene.bogus", "solver.rtol", "model.contact_law", "output.last_periods"]))
        values = [hostile(rng) if rng.random() < 0.4 else float(v) for v in rng.uniform(0.05, 0.3, 2)]
        axes = {key: values} if rng.random() < 0.8 else hostile(rng)
        keywords = {"max_periods": int(rng.integers(1, 3)), "workers": 1}
        if rng.random() < 0.4:
            name = str(rng.choice(["chunk", "workers", "progress", "steady_tol", "observables", "bogus"]))
            value = hostile(rng)
            if name in ("chunk", "workers") and isinstance(value, int) and not isinstance(value, bool) \
                    and value > 2:
                value = -value
            keywords[name] = value
        sweep_base = "fig2_n4" if rng.random() < 0.7 else "biased_tip"

        def sweep_call():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return tmafm.sweep(sweep_base, axes, **keywords)
        return Call(seed, "sweep", f"sweep({sweep_base!r}, {_short(axes)}, {_short(keywords)})", sweep_call)
    if family == "dataset":
        which = str(rng.choice(["write_dataset", "read_dataset", "summarize"]))
        arg = hostile_path(rng, folder)
        spoil = rng.random() < 0.5

        def dataset_call():
            from tmafm import sweeps
            ds = cache.dataset()
            if which == "write_dataset":
                return sweeps.write_dataset(hostile(rng) if spoil else ds, arg)
            if which == "read_dataset":
                return sweeps.read_dataset(arg if spoil else folder / "good.npz")
            return sweeps.summarize(hostile(rng) if spoil else ds)
        return Call(seed, f"sweeps.{which}", f"sweeps.{which}({_short(arg)}, spoiled {spoil})", dataset_call)
    if family == "cli":
        # Never a real sweep file (a whole sweep per call): a plain input, a missing file, a folder.
        argv = [str(rng.choice([str(REPO / "inputs" / "fig2_n4.nml"), "none.nml", str(folder)]))] \
            if rng.random() < 0.6 else []
        for _ in range(int(rng.integers(0, 4))):
            argv.append(str(rng.choice(["-o", "--workers", "--plot", "--progress", "--summarize", "--bogus",
                                        "x.nc", "x.png", "nodir/x.nc", "-1", "0", "", "\x00", "x" * 300])))
        if rng.random() < 0.1:
            argv = hostile(rng)

        def cli_call():
            from tmafm import sweeps
            import contextlib
            import io
            with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
                code = sweeps.main(argv)
            if code not in (0, 2):
                raise SystemExit(code)
            return code
        return Call(seed, "sweeps.main", f"sweeps.main({_short(argv)})", cli_call)
    # continuation: the bistable scene's free branch, a few points.
    start, stop = 2.0e-3, 1.98e-3
    key = "scene.delta_hat"
    keywords = {"max_points": int(rng.integers(2, 4)), "settle": int(rng.integers(20, 60)), "workers": 1}
    name = str(rng.choice(["start", "stop", "key", "y0", "period", "direction", "ds", "ds_max", "max_points",
                       "rtol", "tol", "loc_tol", "switch", "max_period", "settle", "cross", "workers",
                       "progress", "bogus", "base"]))
    value = hostile(rng)
    if name in ("max_points", "settle", "max_period", "workers") and isinstance(value, int) \
            and not isinstance(value, bool) and value > 4:
        value = -value
    base_arg = str(BISTABLE)
    if name == "start":
        start = value
    elif name == "stop":
        stop = value
    elif name == "key":
        key = value if rng.random() < 0.5 else rng.choice(["scene.nope", "model.n_modes", "physical.tip_bias",
                                                            "scene.omega", "solver.rtol"])
    elif name == "base":
        base_arg = value if rng.random() < 0.5 else rng.choice(["biased_tip", "dlvo_water", "sls_polystyrene"])
    else:
        keywords[name] = value

    def continuation_call():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return tmafm.continuation(base_arg, key, start, stop, **keywords)
    return Call(seed, "continuation", f"continuation({_short(base_arg)}, {_short(key)}, {_short(start)}, "
                f"{_short(stop)}, {_short(keywords)})", continuation_call)


def _finite(value) -> str | None:
    """What is not finite in a returned value that the docs promise finite, or None."""
    import tmafm
    if isinstance(value, tmafm.Result):
        for name in ("tau", "vt", "vtdot", "a", "adot"):
            array = np.asarray(getattr(value, name))
            if array.size and not np.all(np.isfinite(array)):
                return f"Result.{name}"
        if value.a.shape[0] != value.tau.size:
            return "Result.a rows"
    elif isinstance(value, tmafm.Observation):
        if value.poincare.size and not np.all(np.isfinite(value.poincare)):
            return "Observation.poincare"
    elif isinstance(value, float) and math.isinf(value):
        return "an infinite float"
    elif type(value).__name__ == "Dataset":
        for name, array in value.data_vars.items():
            data = np.asarray(array.values)
            if data.dtype.kind == "f" and np.any(np.isinf(data)):
                return f"Dataset.{name} holds inf"
    return None


def execute(call: Call) -> tuple[str, str]:
    """Run one call: its class and the detail."""
    import tmafm
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            value = call.thunk()
    except tmafm.TmafmError as exc:
        message = str(exc)
        if not message or "\n" in message or len(message) >= 1200:
            return "multi-line-error", message[:600]
        return "ok-error", f"{type(exc).__name__}: {message[:300]}"
    except SystemExit as exc:
        if exc.code in (0, 2):
            return "ok-error", f"SystemExit {exc.code}"
        return "raw-exception", f"SystemExit {exc.code!r}"
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 (every escape is counted)
        tail = traceback.format_exception(exc)[-3:]
        return "raw-exception", f"{type(exc).__name__}: {str(exc)[:300]} | {''.join(tail)[-600:]}"
    bad = _finite(value)
    if bad is not None:
        return "non-finite", bad
    return "ok", type(value).__name__


def worker() -> None:
    """Read seeds from stdin, one a line; answer each with one JSON line."""
    folder = Path(tempfile.mkdtemp(prefix="api-campaign-"))
    os.chdir(folder)  # a text drawn as a file name is written here, if anywhere
    cache = Cache(folder)
    for line in sys.stdin:
        seed = int(line)
        try:
            call = generate(seed, folder, cache)
        except Exception as exc:  # noqa: BLE001 (the campaign's own bug, counted apart)
            sys.stdout.write(json.dumps({"seed": seed, "entry": "?", "outcome": "generator-error",
                                         "what": "", "detail": repr(exc)[:300]}) + "\n")
            sys.stdout.flush()
            continue
        outcome, detail = execute(call)
        sys.stdout.write(json.dumps({"seed": seed, "entry": call.entry, "outcome": outcome,
                                     "what": call.what, "detail": detail}) + "\n")
        sys.stdout.flush()


class Runner:
    """A worker process; restarted after a crash or a hang."""

    def __init__(self, timeout: float):
        self.timeout = timeout
        self.proc = None

    def start(self):
        self.proc = subprocess.Popen([sys.executable, __file__, "--worker"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, bufsize=1)

    def call(self, seed: int) -> dict:
        if self.proc is None or self.proc.poll() is not None:
            self.start()
        self.proc.stdin.write(f"{seed}\n")
        self.proc.stdin.flush()
        ready, _, _ = select.select([self.proc.stdout], [], [], self.timeout)
        if not ready:
            self.proc.kill()
            self.proc.wait()
            self.proc = None
            return {"seed": seed, "outcome": "hang", "detail": f"no answer in {self.timeout} s"}
        line = self.proc.stdout.readline()
        if not line:
            code = self.proc.wait()
            self.proc = None
            return {"seed": seed, "outcome": "crash", "detail": f"the worker died: status {code}"}
        return json.loads(line)

    def close(self):
        if self.proc is not None:
            self.proc.stdin.close()
            self.proc.wait()


def campaign(seeds, timeout: float = 60.0) -> list[dict]:
    """The rows of the calls of `seeds`, run in order in one worker."""
    runner = Runner(timeout)
    try:
        return [runner.call(seed) for seed in seeds]
    finally:
        runner.close()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=3000)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=60.0)
    parser.add_argument("--out", type=Path, default=REPO / "studies" / "results" / "api_campaign.json")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker()
        return
    import tmafm
    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    start, cpu0 = time.time(), resource.getrusage(resource.RUSAGE_CHILDREN)
    seeds = range(args.first_seed, args.first_seed + args.calls)
    rows = campaign(seeds, args.timeout)
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    outcomes = Counter(r["outcome"] for r in rows)
    by_entry = defaultdict(Counter)
    for r in rows:
        by_entry[r.get("entry", "?")][r["outcome"]] += 1
    failures = [r for r in rows if r["outcome"] not in GOOD]
    report = {
        "command": "python studies/api_campaign.py " + " ".join(sys.argv[1:]),
        "tmafm": tmafm.__version__, "commit": commit, "calls": len(rows),
        "seeds": [seeds.start, seeds.stop - 1], "timeout_s": args.timeout,
        "wall_s": round(time.time() - start, 1),
        "cpu_s": round(cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime, 1),
        "outcomes": dict(outcomes.most_common()),
        "broke_contract": len(failures),
        "by_entry": {k: dict(v.most_common()) for k, v in sorted(by_entry.items())},
        "failures": failures,
    }
    # Written as the package writes (a temporary, fsync, rename): a full disk or a limit leaves
    # no partial JSON passed off as a result (tests/test_writer_faults.py).
    from tmafm._safefile import write_text
    try:
        write_text(args.out, json.dumps(report, indent=1) + "\n", "campaign report")
    except tmafm.TmafmError as exc:
        sys.stderr.write(f"api_campaign: error: {exc}\n")
        sys.exit(1)
    print(json.dumps({k: report[k] for k in ("calls", "outcomes", "broke_contract", "wall_s", "cpu_s")}))


if __name__ == "__main__":
    main()
