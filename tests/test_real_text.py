"""The resolved input's reals: config_text writes each one with tmafm_float_format's
shortest_text_padded, which must give exactly the text of tmafm_text's real_text_padded (the
first of 2 .. 17 significant digits whose correctly rounded es text reads back to the same
double, found by trial formatted writes and reads).  Both are checked here against each other
and against Python's own correctly rounded formatting, on values that stress every branch:
short decimals, ties near a decimal half-unit, powers of two (whose gap below is half the gap
above), neighbours of round numbers, random bit patterns, signed zeros (written directly), and the
values handed back to the slow path (infinities, NaN, subnormals, beyond 1e260)."""

import math

import numpy as np
import pytest

import tmafm
from testcore import core as _core


def shortest_es(value: float) -> str:
    """The text real_text_padded gives: es(d+10).(d-1)e3 for the first d in 2..17 that reads back."""
    for digits in range(2, 18):
        text = f"{value:.{digits - 1}E}"
        if float(text) == value:
            break
    mantissa, exponent = text.split("E")
    exponent = int(exponent)
    return f"{mantissa}E{'-' if exponent < 0 else '+'}{abs(exponent):03d}"


def texts(values):
    fast, slow = _core.real_texts(np.asarray(values, dtype=np.float64))
    decode = lambda codes: [bytes(column.astype(np.uint8)).decode() for column in codes.T]
    return decode(fast), decode(slow)


def stress_values(rng):
    values = [0.05, 5e-4, 6.7665e-5, 0.7413, 1.128e-4, 0.2617993877991494, 314.1592653589793,
              0.1, 0.3, 1 / 3, 2 / 3, 9.999999999999999e22, 1e23, 5e-324, 1e-300, 1e300,
              1e-260, 1e260, 1.0000000000000001e-260, 9.999999999999999e259, 2.2250738585072014e-308]
    values += [2.0**k for k in range(-880, 870, 3)]
    values += [math.nextafter(2.0**k, 0) for k in range(-880, 870, 11)]
    values += [math.nextafter(10.0**k, direction) for k in range(-250, 250, 7) for direction in (0, math.inf)]
    values += list(rng.uniform(-1, 1, 1000))
    values += list(10.0 ** rng.uniform(-250, 250, 1000))
    values += [round(float(x), int(k)) for x, k in zip(rng.uniform(0, 100, 1000), rng.integers(1, 17, 1000))]
    bits = rng.integers(0, 2**63 - 1, 1000, dtype=np.int64).view(np.float64)
    values += [float(x) for x in bits if math.isfinite(x)]
    # Halfway between two short decimals, and a hair either side.
    for k in range(2, 17):
        half = float(f"1.{'2' * (k - 2)}25E-3")
        values += [half, math.nextafter(half, 0), math.nextafter(half, 1)]
    return values


def test_fast_text_is_real_text_padded_and_correctly_rounded():
    values = stress_values(np.random.default_rng(20261122))
    values += [-v for v in values[:400]]
    fast, slow = texts(values)
    for value, f, s in zip(values, fast, slow):
        assert f == s, (repr(value), f, s)
        assert f.rstrip() == shortest_es(value), repr(value)
        assert float(f) == value, repr(value)


@pytest.mark.parametrize("value, text", [(0.0, "0.0E+000"), (-0.0, "-0.0E+000"), (math.inf, "Infinity"),
                                         (-math.inf, "-Infinity"), (math.nan, "NaN")])
def test_values_outside_the_fast_path(value, text):
    fast, slow = texts([value])
    assert fast == slow
    assert fast[0].rstrip() == text


def test_resolved_text_reads_back_to_the_same_configuration():
    """A configuration whose reals need 2 .. 17 digits survives its own resolved text."""
    config = tmafm.Config("fig2_n4", scene={"theta": 0.2617993877991494, "alpha5": 6.7665e-5,
                                            "alpha1": 0.1 + 0.2},
                          solver={"tau_end": math.pi * 10})
    text = config.text
    assert "    alpha1 = 3.0000000000000004E-001\n" in text
    assert f"    tau_end = {shortest_es(math.pi * 10)}\n" in text
    assert "    alpha5 = 6.7665E-005\n" in text
    again = tmafm.Config(config)
    assert again.text == text
    assert again.scene == config.scene
