"""Hostile Python input to tmafm.Config / tmafm.run: every case ends in one of tmafm's typed
exceptions with a one-line, short message that names the key, never a raw Python exception,
a crash or a hang.  Each case here escaped as a raw exception, a multi-line or a silently
accepted input before the fix named next to it (pywrap/tmafm/_namelist.py, _run.py)."""

import math
import pickle
import re
import subprocess
import sys

import numpy as np
import pytest

import tmafm

hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies

#: Longest message accepted: the core's errmsg is 1024 characters; Python's are cut reprs.
MAX_MESSAGE = 1200


class _BrokenRepr:
    def __repr__(self):
        raise RuntimeError("a __repr__ that raises")


class _MultilineRepr(float):
    def __repr__(self):
        return "1.0\n2.0"


def _deep_list(depth):
    top = inner = []
    for _ in range(depth):
        inner.append([])
        inner = inner[0]
    return top


def _check_message(exc, *names):
    message = str(exc)
    assert message and "\n" not in message and "\r" not in message, repr(message)
    assert len(message) <= MAX_MESSAGE, len(message)
    for name in names:
        assert name in message.lower(), (name, message)


# (id, overrides, exception, names the message must contain)
OVERRIDE_CASES = [
    # float() of a huge int raised OverflowError
    ("int_too_large_for_a_real", {"initial": {"a0": [10**400, 0, 0, 0]}}, tmafm.InputError,
     ["&initial a0"]),
    # f2py refused a str with non-ASCII characters with a raw TypeError ("function takes
    # exactly 5 arguments (1 given)"); the text now goes to the core as UTF-8 bytes
    ("non_ascii_string", {"solver": {"method": "dopri5\u00e9"}}, tmafm.InputError,
     ["&solver method", "\\xc3\\xa9"]),
    ("emoji_string", {"model": {"contact_law": "\U0001F600"}}, tmafm.InputError,
     ["&model contact_law"]),
    ("lone_surrogate", {"solver": {"method": "\ud800"}}, tmafm.InputError, ["&solver method"]),
    # a __repr__ that raised escaped; one that spans lines, or a 2-D array's repr, gave a
    # multi-line message; a list nested 10**5 deep raised RecursionError in repr
    ("broken_repr", {"solver": {"tau_end": _BrokenRepr()}}, tmafm.InputError, ["&solver tau_end"]),
    ("multiline_repr", {"solver": {"method": _MultilineRepr(1.0)}}, tmafm.InputError,
     ["&solver method"]),
    ("two_d_array", {"initial": {"a0": np.zeros((2, 2))}}, tmafm.InputError, ["&initial a0"]),
    ("deeply_nested_list", {"initial": {"a0": _deep_list(100_000)}}, tmafm.InputError,
     ["&initial a0"]),
    # a million-entry list put megabytes of repr into the message
    ("huge_bad_list", {"initial": {"a0": [0.0] * 10**6 + [math.nan]}}, tmafm.InputError,
     ["&initial a0"]),
    # two spellings of one key (or group) ran silently with the last one; the core refuses
    # a key or a group given twice in a file
    ("key_twice", {"solver": {"tau_end": 0.1, "TAU_END": 0.2}}, tmafm.InputError,
     ["&solver tau_end", "twice"]),
    ("group_twice", {"solver": {"tau_end": 0.1}, "SOLVER": {"dtau": 0.01}}, tmafm.InputError,
     ["&solver", "twice"]),
    # already refused before; kept as the attack surface's inventory
    ("nul_in_string", {"output": {"file": "a\0b.npz"}}, tmafm.InputError, ["&output file"]),
    ("newline_in_string", {"solver": {"method": "dopri5'\n&solver tau_end = 1e9 /"}},
     tmafm.InputError, ["&solver method"]),
    ("quote_injection", {"solver": {"method": "dopri5', tau_end = 1e6, method = 'dopri5"}},
     tmafm.InputError, ["&solver method"]),
    ("very_long_string", {"solver": {"method": "x" * 10**6}}, tmafm.InputError, ["&solver method"]),
    ("nan", {"solver": {"rtol": math.nan}}, tmafm.InputError, ["&solver rtol"]),
    ("inf", {"scene": {"alpha2": -math.inf}}, tmafm.InputError, ["&scene alpha2"]),
    ("huge_n_modes", {"model": {"n_modes": 10**20}}, tmafm.InputError, ["&model n_modes"]),
    ("negative_max_steps", {"solver": {"max_steps": -5}}, tmafm.InputError, ["&solver max_steps"]),
    ("unknown_key", {"solver": {"tau_end_": 1.0}}, tmafm.InputError, ["&solver tau_end_"]),
    ("non_ascii_key", {"solver": {"t\u00e5u": 1.0}}, tmafm.InputError, ["&solver key"]),
    ("non_ascii_group", {"s\u00f8lver": {"tau_end": 1.0}}, tmafm.InputError, ["unknown namelist group"]),
    ("newline_group", {"solver\n": {"tau_end": 1.0}}, tmafm.InputError, ["unknown namelist group"]),
    ("bytes_value", {"solver": {"method": b"dopri5"}}, tmafm.InputError, ["&solver method"]),
    ("set_value", {"initial": {"adot0": {1.0}}}, tmafm.InputError, ["&initial adot0"]),
    ("group_not_a_dict", {"solver": [1, 2]}, tmafm.InputError, ["&solver"]),
]


@pytest.mark.parametrize("overrides, error, names", [c[1:] for c in OVERRIDE_CASES],
                         ids=[c[0] for c in OVERRIDE_CASES])
def test_hostile_overrides_raise_a_typed_one_line_error(overrides, error, names):
    with pytest.raises(error) as info:
        tmafm.Config("fig2_n4", **overrides)
    _check_message(info.value, *names)
    with pytest.raises(error) as info:  # the same values as a dict input
        tmafm.Config({"solver": {"tau_end": 0.1}, **overrides}
                     if "solver" not in {g.lower() for g in overrides} else overrides)
    _check_message(info.value, *names)


class _BadPath:
    def __fspath__(self):
        return 3


@pytest.mark.parametrize("nml, error", [
    ("x" * 5000, tmafm.InputFileError),            # ENAMETOOLONG escaped as a raw OSError
    ("x" * 300 + ".nml", tmafm.InputFileError),
    ("fig2\0n4", tmafm.InputFileError),
    ("no\nsuch\rfile", tmafm.InputFileError),
    (_BadPath(), tmafm.InputTypeError),             # a raw TypeError from os.fspath
    (b"fig2_n4", tmafm.InputTypeError),
    (42, tmafm.InputTypeError),
], ids=["long_name", "long_nml_name", "nul", "newlines", "bad_fspath", "bytes", "int"])
def test_hostile_input_names_raise_a_typed_one_line_error(nml, error):
    with pytest.raises(error) as info:
        tmafm.Config(nml)
    _check_message(info.value)


def test_a_file_with_non_ascii_text_reads_as_the_executable_reads_it(tmp_path):
    """A non-ASCII comment and a non-ASCII folder name were a raw TypeError from f2py; the
    executable accepts the comment and names a non-ASCII value with \\xNN escapes."""
    base = (tmafm.inputs.path("fig2_n4")).read_text()
    folder = tmp_path / "\u00e4\u00f6"
    folder.mkdir()
    good = folder / "comment.nml"
    good.write_text("! a comment with \u00e9 and \u2713\n" + base, encoding="utf-8")
    assert tmafm.Config(good).text == tmafm.Config("fig2_n4").text
    bad = folder / "value.nml"
    assert "method = 'rk4_paper'" in base
    bad.write_text(base.replace("method = 'rk4_paper'", "method = 'rk4_pap\u00e9r'"), encoding="utf-8")
    with pytest.raises(tmafm.InputError) as info:
        tmafm.Config(bad)
    _check_message(info.value, "&solver method", "\\xc3\\xa9")


@pytest.mark.parametrize("max_switches", ["3", 2.5, math.nan, -1, True, [1]])
def test_max_switches_is_checked_before_the_run(max_switches):
    """A string raised a raw TypeError after the run; NaN was accepted and meant no limit."""
    with pytest.raises(tmafm.InputError) as info:
        tmafm.run("fig2_n4", max_switches=max_switches, solver={"tau_end": 0.1})
    _check_message(info.value, "max_switches")


texts = st.text(st.characters(codec="utf-8"), max_size=40) | st.sampled_from(
    ["\0", "\n", "'", "''", "/", "&", "!", "a\rb", "\u00e9", "\U0001F600", "x" * 5000, "\ud800"])
hostile = st.one_of(
    texts, st.binary(max_size=8), st.integers(-10**400, 10**400),
    st.floats(allow_nan=True, allow_infinity=True), st.complex_numbers(),
    st.lists(st.one_of(st.floats(), texts, st.none()), max_size=4),
    st.lists(st.lists(st.floats(), max_size=2), min_size=1, max_size=2),
    st.dictionaries(texts, st.floats(), max_size=2), st.none(), st.booleans())
keys = st.sampled_from([("model", "contact_law"), ("model", "errata"), ("model", "n_modes"),
                        ("solver", "method"), ("solver", "rtol"), ("solver", "tau_end"),
                        ("output", "file"), ("output", "format"), ("initial", "a0"),
                        ("scene", "theta"), ("physical", "tilt")])


@hypothesis.settings(max_examples=400, deadline=None, derandomize=True,
                     suppress_health_check=list(hypothesis.HealthCheck))
@hypothesis.given(keys, hostile)
def test_any_hostile_value_builds_a_config_or_raises_a_typed_error_naming_the_key(where, value):
    group, key = where
    if group == "physical":  # a physical value only counts with the whole physical group
        base = "physical_polystyrene"
    else:
        base = "fig2_n4"
    try:
        config = tmafm.Config(base, **{group: {key: value}})
    except tmafm.TmafmError as exc:
        _check_message(exc)
        # The key itself, or (a value in range that breaks a rule between two keys, e.g. a
        # tau_end below &output sample_dtau) the other key of the rule.
        assert f"&{group} {key}" in str(exc) or re.search(r"&[a-z]+ [a-z0-9_]+ = ", str(exc)), exc
        return
    assert config.n_modes >= 1
    # An accepted value reads back as the core holds it, and a copy in another process (a
    # pickle carries the resolved text) is the same configuration.
    assert "\ufffd" not in config.text
    assert pickle.loads(pickle.dumps(config)).text == config.text



@pytest.fixture(scope="module")
def model():
    return tmafm.Model("fig2_n4")


def _model_cases(n):
    zeros, state = np.zeros(n), np.zeros(2 * n)
    one = (np.zeros(1), np.zeros((1, n)), np.zeros((1, n)))
    return [
        # NaN/inf states gave NaN rates silently; a huge int was a raw OverflowError; complex
        # values lost their imaginary part with only a ComplexWarning
        ("nan_state", lambda m: m.derivative(0.0, [math.nan] * (2 * n), False), "y"),
        ("inf_displacement", lambda m: m.matrices(0.0, [math.inf] * n, False), "a"),
        ("huge_int_state", lambda m: m.derivative(0.0, [10**400] * (2 * n), False), "y"),
        ("complex_state", lambda m: m.derivative(0.0, state.astype(complex), False), "y"),
        ("nan_contact_point", lambda m: m.contact(0.0, [math.nan] * n), "a"),
        ("inf_velocity", lambda m: m.energy_flow(0.0, zeros, [math.inf] * n, True), "adot"),
        ("huge_int_tau", lambda m: m.derivative(10**400, state, False), "tau"),
        ("string_tau", lambda m: m.derivative("1.5", state, False), "tau"),
        # any object was taken as a phase by its truth value ("no" meant contact)
        ("string_phase", lambda m: m.derivative(0.0, state, "no"), "in_contact"),
        ("none_phase", lambda m: m.matrices(0.0, zeros, None), "in_contact"),
        ("two_phase", lambda m: m.energy_flow(0.0, zeros, zeros, 2), "in_contact"),
        # contact flags were cast to int32: 0.5 became 0, 5 was passed on
        ("half_contact", lambda m: m.trajectory_energy_flow(*one, [0.5]), "contact"),
        ("five_contact", lambda m: m.trajectory_energy_flow(*one, [5]), "contact"),
        ("nan_trajectory", lambda m: m.trajectory_energy_flow(one[0], np.full((1, n), math.nan),
                                                              one[2], [0]), "a"),
        ("huge_int_trajectory", lambda m: m.trajectory_energy_flow(one[0], [[10**400] * n],
                                                                   one[2], [0]), "a"),
        # already refused before
        ("wrong_shape", lambda m: m.derivative(0.0, np.zeros((2, n)), False), "y"),
        ("ragged", lambda m: m.derivative(0.0, [[1.0, 2.0], [3.0]], False), "y"),
        ("three_d_trajectory", lambda m: m.trajectory_energy_flow(one[0], np.zeros((1, n, 1)),
                                                                  np.zeros((1, n, 1)), [0]), "a"),
    ]


MODEL_CASES = _model_cases(4)


@pytest.mark.parametrize("call, name", [c[1:] for c in MODEL_CASES], ids=[c[0] for c in MODEL_CASES])
def test_hostile_model_arguments_raise_a_typed_one_line_error(model, call, name):
    assert model.n_modes == 4
    with pytest.raises(tmafm.InputError) as info:
        call(model)
    _check_message(info.value, name)


def test_model_arguments_that_are_fine_still_work(model):
    n = model.n_modes
    assert np.array_equal(model.derivative(0.0, np.zeros(2 * n), np.True_),
                          model.derivative(0, [0] * (2 * n), 1))
    power, energy, state = model.trajectory_energy_flow([], np.zeros((0, n)), np.zeros((0, n)), [])
    assert power.shape == (0, len(tmafm.POWER_NAMES)) == (0, 7) and energy.shape == (0,) and state.shape == (0, 6)


def test_observe_refuses_a_thread_count_that_crashed_the_interpreter():
    """observe_batch(threads=100000) asked libgomp for 100000 threads: SIGSEGV.  In a child
    process, so that a regression fails this test instead of killing the test run."""
    code = ("import tmafm\n"
            "from tmafm.observe import observe_states\n"
            "c = tmafm.Config('fig2_n4', solver={'tau_end': 10.0})\n"
            "for call in (lambda: tmafm.observe_batch([c], threads=100000, max_periods=2),\n"
            "             lambda: observe_states(c, [[0.0] * 8], threads=10**5, max_periods=2)):\n"
            "    try:\n"
            "        call()\n"
            "    except tmafm.InputError as exc:\n"
            "        print(exc)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, (proc.returncode, proc.stderr[-2000:])
    lines = proc.stdout.splitlines()
    assert len(lines) == 2 and all("threads = 100000" in line for line in lines), lines


@pytest.mark.parametrize("options, error, name", [
    ({"harmonics": 10**7, "max_periods": 10**7}, tmafm.InputError, "harmonics"),  # the core's 64
    ({"max_periods": _BrokenRepr()}, tmafm.InputTypeError, "max_periods"),         # RuntimeError
    ({"observables": [_MultilineRepr(1.0)]}, tmafm.InputTypeError, "observables"),
], ids=["too_much_memory", "broken_repr", "multiline_repr"])
def test_hostile_observe_options_raise_a_typed_one_line_error(options, error, name):
    with pytest.raises(error) as info:
        tmafm.observe("fig2_n4", solver={"tau_end": 10.0}, **options)
    _check_message(info.value, name)


def test_observe_batch_out_of_memory_is_a_typed_one_line_error():
    """Within the core's limits (10**7 periods, 64 harmonics), 2**15 inputs ask for 153 TiB per
    harmonic array, more than x86-64's 128 TiB of user addresses (and than any machine's memory
    and swap): the MemoryError is a SolverError."""
    config = tmafm.Config("fig2_n4", solver={"tau_end": 10.0})
    with pytest.raises(tmafm.SolverError) as info:
        tmafm.observe_batch([config] * 2**15, max_periods=10**7, harmonics=64)
    _check_message(info.value, "max_periods")


def test_observe_batch_reads_a_config_with_non_ascii_text():
    """The batch joins the configurations' texts and cuts them at offsets: they count bytes,
    so a non-ASCII &output file (UTF-8, several bytes per character) must not shift them."""
    plain = tmafm.Config("fig2_n4", solver={"tau_end": 20.0})
    accented = tmafm.Config("fig2_n4", solver={"tau_end": 20.0},
                            output={"file": "\u00e9\u2713.npz"})
    assert "file = '\u00e9\u2713.npz'" in accented.text
    first, second, third = tmafm.observe_batch([accented, plain, accented], max_periods=4)
    for observation in (first, third):
        assert observation.periods == second.periods
        assert np.array_equal(observation.per_period["contact_time"],
                              second.per_period["contact_time"])


# --- Model methods never return NaN or Inf for finite input (issue 18, item 5) ---------------
# (the module's `model` fixture above: Fig. 2's model)

def _calls(model, tau, a, adot, in_contact):
    return {
        "derivative": lambda: model.derivative(tau, np.concatenate([a, adot]), in_contact),
        "matrices": lambda: model.matrices(tau, a, in_contact),
        "contact": lambda: model.contact(tau, a),
        "energy_flow": lambda: model.energy_flow(tau, a, adot, in_contact),
        "trajectory_energy_flow": lambda: model.trajectory_energy_flow(
            np.full(2, tau), np.tile(a, (2, 1)), np.tile(adot, (2, 1)), np.full(2, int(in_contact))),
    }


def _finite(value):
    if isinstance(value, dict):
        value = list(value.values())
    if isinstance(value, tuple) and not hasattr(value, "_fields"):
        return all(_finite(v) for v in value)
    return bool(np.all(np.isfinite(np.asarray(value, dtype=float))))


@pytest.mark.parametrize("case, tau, a", [
    ("a_1e308", 0.0, [1e308, 0, 0, 0]),   # forces overflow
    ("a_minus_1e3", 0.0, [-1e3, 0, 0, 0]),  # an indentation past the tip's geometry: radius NaN
    ("a_minus_1e10", 0.0, [-1e10, 0, 0, 0]),
    ("tau_1e308", 1e308, [0, 0, 0, 0]),   # Omega tau overflows: the drive is NaN
], ids=lambda x: x if isinstance(x, str) else None)
def test_a_model_method_refuses_a_state_whose_result_is_not_finite(model, case, tau, a):
    """Model.contact(0, [-1e3, 0, 0, 0]) returned radius = nan, derivative(1e308, ...) NaN
    rates, matrices at a = 1e308 inf: silently.  Each is now an InputError naming the
    argument (the state, or tau past the largest tau_end)."""
    a = np.asarray(a, dtype=float)
    for name, call in _calls(model, tau, a, a, True).items():
        try:
            out = call()
        except tmafm.InputError as exc:
            message = str(exc)
            assert "\n" not in message and ("tau" in message or "a = " in message
                                            or "y = " in message), (name, message)
        else:
            assert _finite(out), (case, name, out)


def test_model_methods_are_finite_or_refuse_over_finite_input(model):
    """Property: for finite tau and states (any magnitude), each method returns finite values
    or raises InputError; never NaN or Inf."""
    finite = st.floats(allow_nan=False, allow_infinity=False)
    n = model.n_modes

    @hypothesis.settings(max_examples=150, deadline=None, database=None)
    @hypothesis.given(finite, st.lists(finite, min_size=2 * n, max_size=2 * n), st.booleans())
    def check(tau, state, in_contact):
        a, adot = np.array(state[:n]), np.array(state[n:])
        for name, call in _calls(model, tau, a, adot, in_contact).items():
            try:
                out = call()
            except tmafm.InputError:
                continue
            assert _finite(out), (name, tau, state, out)

    check()
