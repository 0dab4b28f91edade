"""Every public entry point, called with one argument of a wrong type or a hostile value, ends
in a typed tmafm exception (tmafm.TmafmError: InputError, InputTypeError, ...) with a one-line
message, or succeeds; never a raw Python exception or a crash.  The entry points: tmafm.__all__
and the public functions of tmafm.sweeps, tmafm.observe, tmafm.analysis, tmafm.sweeps.plots,
tmafm.figures, the methods of Config, Result and Model.  Before (issue 18), among others:
``write_dataset(None)`` and ``summarize(None)`` raised AttributeError, ``observe_batch(None)``
TypeError, ``bifurcation`` over ``model.n_modes = [10**400]`` ValueError ("Maximum allowed
dimension exceeded"), a bad ``client`` AttributeError, ``steady_tol = 10**400`` OverflowError,
``read_sweep_file(None)`` TypeError, ``mark_jumps`` and ``steady_period`` of strings
ValueError, ``tmafm.inputs.path(10**400)`` OSError, and every analysis function given a
non-Result AttributeError."""

import importlib
import inspect
import math
import sys

import numpy as np
import pytest

import tmafm
from tmafm import analysis, sweeps
from tmafm.sweeps import plots as sweepplots

hypothesis = pytest.importorskip("hypothesis")
pytest.importorskip("xarray")
st = hypothesis.strategies
observe_module = importlib.import_module("tmafm.observe")


class _Odd:
    """An object of no type tmafm knows, whose repr raises."""

    def __repr__(self):
        raise RuntimeError("a __repr__ that raises")


#: Hostile values: none of the types an argument wants, or a value out of any range.  Integers
#: stay small or absurd (a small one may be a valid max_periods: the run stays short).
HOSTILE = st.one_of(
    st.none(), st.booleans(), st.integers(-3, 3), st.sampled_from([10**400, -10**400, 2**63]),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=6), st.binary(max_size=6),
    st.recursive(st.lists(st.floats(allow_nan=True), max_size=2),
                 lambda inner: st.lists(inner, max_size=2), max_leaves=5),
    st.just(np.array([object(), None], dtype=object)), st.just(np.array([[1.0, 2.0], [3.0, np.nan]])),
    st.just({"a": 1}), st.just(_Odd()), st.just(np.float64("nan")), st.just(np.int64(-1)),
    st.just(1e308), st.just(-1e308),
)


@pytest.fixture(scope="module")
def entry_points(tmp_path_factory):
    """(name, function, good args, good keywords) of every public entry point; the good
    arguments make a cheap call (a few drive periods)."""
    folder = tmp_path_factory.mktemp("entry")
    period = 2 * math.pi / 2.0
    result = tmafm.run("fig2_n4", solver={"tau_end": 52 * period},
                       output={"sample_dtau": analysis.sample_dtau_for(2.0, 20)})
    model = result.config.model()
    n = model.n_modes
    ds = sweeps.sweep("fig2_n4", {"scene.delta_hat": [0.2]}, max_periods=2, workers=1)
    sections = np.zeros((60, 2 * n))
    few = {"max_periods": 2, "workers": 1}
    table = [
        ("run", tmafm.run, ["fig2_n4"], {"solver": {"tau_end": 0.1}}),
        ("resolve", tmafm.resolve, ["fig2_n4"], {}),
        ("load", tmafm.load, [folder / "missing.npz"], {}),
        ("Config", tmafm.Config, ["fig2_n4"], {}),
        ("Config.run", result.config.run, [None], {}),
        ("Config.write", result.config.write, [folder / "c.nml"], {}),
        ("Model", tmafm.Model, ["fig2_n4"], {}),
        ("Result.save", result.save, [folder / "r.npz"], {}),
        ("observe", tmafm.observe, ["fig2_n4"], {"max_periods": 2}),
        ("observe_batch", tmafm.observe_batch, [["fig2_n4"]], {"max_periods": 2}),
        ("observe_states", observe_module.observe_states, ["fig2_n4", np.zeros((1, 2 * n))],
         {"max_periods": 2}),
        ("steady_period", observe_module.steady_period, [np.zeros((5, 2)), 2, 1e-6, 3], {}),
        ("observable_groups", observe_module.observable_groups, [None], {}),
        ("Model.derivative", model.derivative, [0.0, np.zeros(2 * n), False], {}),
        ("Model.matrices", model.matrices, [0.0, np.zeros(n), False], {}),
        ("Model.contact", model.contact, [0.0, np.zeros(n)], {}),
        ("Model.energy_flow", model.energy_flow, [0.0, np.zeros(n), np.zeros(n), False], {}),
        ("Model.trajectory_energy_flow", model.trajectory_energy_flow,
         [result.tau, result.a, result.adot, result.contact], {}),
        ("sweep", tmafm.sweep, ["fig2_n4", {"scene.delta_hat": [0.2]}], few),
        ("sweep axis", lambda v: tmafm.sweep("fig2_n4", {"model.n_modes": [v]}, **few), [4], {}),
        ("approach", tmafm.approach, ["fig2_n4", [0.2, 0.1]], few),
        ("frequency_sweep", tmafm.frequency_sweep, ["fig2_n4", [2.0, 2.1]], few),
        ("bifurcation", tmafm.bifurcation, ["fig2_n4", "scene.delta_hat", [0.2]],
         {"max_periods": 3, "periods_kept": 2, "workers": 1}),
        ("bifurcation axis", lambda v: tmafm.bifurcation("fig2_n4", "model.n_modes", [v],
                                                         max_periods=3, periods_kept=2, workers=1),
         [4], {}),
        ("basin", tmafm.basin, ["fig2_n4", [0.0], [0.0]], {"max_periods": 3, "workers": 1}),
        ("read_sweep_file", sweeps.read_sweep_file, [folder / "none.nml"], {}),
        ("run_sweep_file", sweeps.run_sweep_file, [folder / "none.nml"], {}),
        ("write_dataset", sweeps.write_dataset, [ds, folder / "d.nc"], {}),
        ("read_dataset", sweeps.read_dataset, [folder / "none.nc"], {}),
        ("summarize", sweeps.summarize, [ds], {}),
        ("mark_jumps", sweeps.mark_jumps, [[1.0, 2.0, 5.0], 0.2, 2.0], {}),
        ("sweeps.main", sweeps.main, [[str(folder / "none.nml")]], {}),
        ("figures.main", importlib.import_module("tmafm.figures").main, [["--help"]], {}),
        ("inputs.path", tmafm.inputs.path, ["fig2_n4"], {}),
        ("plot", sweepplots.plot, [ds, folder / "p.png"], {}),
        ("plot_grid", sweepplots.plot_grid, [ds, folder / "g.png"], {}),
    ]
    if hasattr(sweepplots, "render"):  # new with issue 18: the plot drawn in memory
        table.append(("render", sweepplots.render, [ds], {}))
    for name in analysis.__all__:
        function = getattr(analysis, name)
        if not callable(function):
            continue
        first = next(iter(inspect.signature(function).parameters))
        args = {"sample_dtau_for": [2.0], "section_distances": [sections, 1],
                "classify_sections": [sections],
                "energy_balance": [result, 0.0, 5 * period]}.get(name, [result] if first == "result" else [])
        table.append((f"analysis.{name}", function, args, {}))
    return table


def _slots(entry_points):
    """(entry point index, 'position' or keyword name) of every argument of every entry point."""
    slots = []
    for k, (_, function, args, keywords) in enumerate(entry_points):
        slots += [(k, i) for i in range(len(args))]
        try:
            parameters = inspect.signature(function).parameters.values()
        except (TypeError, ValueError):
            continue
        names = list(inspect.signature(function).parameters)
        slots += [(k, p.name) for p in parameters
                  if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
                  and p.default is not p.empty and names.index(p.name) >= len(args)]
    return slots


def test_the_entry_points_with_good_arguments_succeed(entry_points, tmp_path):
    """The table's good calls work (so a refusal below is the hostile value's)."""
    for name, function, args, keywords in entry_points:
        if name in ("load", "read_sweep_file", "run_sweep_file", "read_dataset"):
            continue  # the good arguments name a missing file
        try:
            function(*args, **keywords)
        except SystemExit as exc:  # --help
            assert name == "figures.main" and exc.code == 0
        except tmafm.TmafmError as exc:
            pytest.fail(f"{name}: {exc}")
    assert "matplotlib" in sys.modules  # the plots ran too


def test_every_entry_point_refuses_a_hostile_argument_with_a_typed_error(entry_points, capsys,
                                                                         tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a text drawn as a file name is written here, if anywhere
    slots = _slots(entry_points)
    assert len(slots) > 150, len(slots)

    @hypothesis.settings(max_examples=400, deadline=None, database=None, derandomize=True,
                         suppress_health_check=list(hypothesis.HealthCheck))
    @hypothesis.given(st.sampled_from(slots), HOSTILE)
    def check(slot, value):
        k, where = slot
        name, function, args, keywords = entry_points[k]
        args, keywords = list(args), dict(keywords)
        if isinstance(where, int):
            args[where] = value
        else:
            keywords[where] = value
        try:
            function(*args, **keywords)
        except tmafm.TmafmError as exc:
            message = str(exc)
            assert message and "\n" not in message and len(message) < 1200, (name, where, message)
        except SystemExit as exc:  # argparse: a usage error (2) or --help (0), as documented
            assert name.endswith("main") and exc.code in (0, 2), (name, where, exc)
        except BaseException as exc:  # noqa: B036 (the assertion names what escaped)
            raise AssertionError(f"{name}({where} = {value!r:.80}) raised "
                                 f"{type(exc).__name__}: {str(exc)[:200]}") from exc
        finally:
            capsys.readouterr()

    check()


@pytest.mark.parametrize("shape", [(2, 0), (0, 3), (0, 0)])
def test_analysis_refuses_sections_with_no_values(shape):
    """Found by the campaign above: section_distances on a (2, 0) array raised numpy's
    zero-size ValueError instead of a tmafm error."""
    with pytest.raises(tmafm.InputError, match="has no values"):
        analysis.section_distances(np.zeros(shape), 1)
    with pytest.raises(tmafm.InputError, match="has no values"):
        analysis.classify_sections(np.zeros(shape), max_period=1, window=1)


@pytest.mark.parametrize("warn", [None, 1, "yes", np.array([True, False])])
def test_observe_batch_warn_must_be_a_bool(warn):
    """Found by the campaign above on the new ``warn`` argument: an array raised numpy's
    ambiguous-truth ValueError after the runs."""
    with pytest.raises(tmafm.InputTypeError, match="warn"):
        tmafm.observe_batch(["fig2_n4"], max_periods=1, warn=warn)


@pytest.mark.parametrize("keywords", [{"scale": "x"}, {"scale": float("nan")}, {"scale": -2.0},
                                      {"floor": "abc"}, {"floor": [1.0, 2.0]},
                                      {"floor": float("nan")}, {"floor": -1.0}])
def test_steady_test_refuses_a_bad_scale_or_floor(keywords):
    """Found in review: a string scale or floor escaped as numpy's ValueError, and a NaN scale
    or floor was taken (every comparison with NaN passes) and declared the points period 1."""
    from tmafm.observe import steady_test
    with pytest.raises(tmafm.InputError):
        steady_test(np.ones((10, 2)), **keywords)
