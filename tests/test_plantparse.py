"""The plant parser: the thesis's plants, round trips, one-line errors, and fuzzing."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fitdf.errors import OptionError
from fitdf.loop.plant import (
    MAX_DEGREE,
    MAX_OPERATIONS,
    LoopPlant,
    Plant,
    as_loop_plant,
    format_transfer_function,
    parse_plant,
)


@pytest.mark.parametrize(
    "text, gain, num, den",
    [
        # thesis V.6: K/((1+s)(1+0.25s)(1+1.1s)); denominator made monic
        # (1+s)(1+0.25s)(1+1.1s) = 0.275 s^3 + 1.625 s^2 + 2.35 s + 1
        (
            "K/((1+s)(1+0.25s)(1+1.1s))",
            2.0,
            [2 / 0.275],
            list(np.array([0.275, 1.625, 2.35, 1.0]) / 0.275),
        ),
        ("10/(s*(s+1)*(s+2))", 1.0, [10.0], [1.0, 3.0, 2.0, 0.0]),
        ("(1+0.5s)/s^3", 1.0, [0.5, 1.0], [1.0, 0.0, 0.0, 0.0]),  # Fig 5.13, locus (1)
        ("(1+0.5s)/s**3", 1.0, [0.5, 1.0], [1.0, 0.0, 0.0, 0.0]),
        ("s^2 + 2s + 1", 1.0, [1.0, 2.0, 1.0], [1.0]),
        ("2(s+1)(s-1)", 1.0, [2.0, 0.0, -2.0], [1.0]),
        ("-s^2", 1.0, [-1.0, 0.0, 0.0], [1.0]),
        ("2*-s", 1.0, [-2.0, 0.0], [1.0]),
        (".5/(s + 1e1)", 1.0, [0.5], [1.0, 10.0]),
        ("(s+1)^-2", 1.0, [1.0], [1.0, 2.0, 1.0]),
        ("s/(s(s+1))", 1.0, [1.0], [1.0, 1.0]),  # common powers of s cancel
        ("Ks/(s+K)", 3.0, [3.0, 0.0], [1.0, 3.0]),
        ("1 + 1/(s+1)", 1.0, [1.0, 2.0], [1.0, 1.0]),
        ("(s^2)^3", 1.0, [1.0, 0, 0, 0, 0, 0, 0], [1.0]),
        # implicit products and number forms the token pass must get right
        ("K(1+s)", 2.0, [2.0, 2.0], [1.0]),
        ("1/2s", 1.0, [0.5, 0.0], [1.0]),  # (1/2)*s, as written left to right
        ("s^-2s", 1.0, [1.0], [1.0, 0.0]),  # (s^-2)*s
        ("0.25s^2 + 1.e1s", 1.0, [0.25, 10.0, 0.0], [1.0]),
        ("007s^02", 1.0, [7.0, 0, 0], [1.0]),  # leading zeros, as before
        ("sKs", 3.0, [3.0, 0, 0], [1.0]),
        ("\t2 s ", 1.0, [2.0, 0.0], [1.0]),
        ("+".join(["1"] * 999), 1.0, [999.0], [1.0]),  # long chains do not recurse deeply
        ("s^(-2)", 1.0, [1.0], [1.0, 0, 0]),
    ],
)
def test_parse_examples(text, gain, num, den):
    p = parse_plant(text)
    n, d = p.polynomials(gain)
    np.testing.assert_allclose(n, num, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(d, den, rtol=1e-12, atol=1e-12)


def test_gain_symbol_flags_and_transfer_function():
    p = parse_plant("K/((1+s)(1+0.25s)(1+1.1s))")
    assert p.has_gain and p.linear_in_gain
    assert not parse_plant("10/(s(s+1))").has_gain
    q = parse_plant("K^2/(s+K)")
    assert q.has_gain and not q.linear_in_gain
    tf = p.transfer_function(500.0)
    w = np.array([0.3, 2.9, 17.0])
    expected = 500.0 / ((1 + 1j * w) * (1 + 0.25j * w) * (1 + 1.1j * w))
    np.testing.assert_allclose(p.frequency_response(w, 500.0), expected, rtol=1e-12)
    np.testing.assert_allclose(tf(1j * w), expected, rtol=1e-10)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("", "empty transfer function"),
        ("1/(s+1", "column 7"),
        ("1/(s+1))", "unbalanced ')' at column 8"),
        ("s^2.5", "whole number at column 3"),
        ("exp(s)", "unknown name 'exp' at column 1"),
        ("1/0", "division by zero at column 2"),
        ("1/(s-s)", "division by zero"),
        ("2 3", "missing operator before a number at column 3"),
        ("(s+1)2", "column 6"),
        ("s^2^3", "power of a power needs parentheses"),
        ("s^99", "exponent larger than"),
        ("1e999", "out of range at column 1"),
        ("s" * (MAX_DEGREE + 1), "degree above"),
        ("(" * 100 + "s" + ")" * 100, "nesting deeper"),
        ("s + $", "unexpected character '$' at column 5"),
        ("s +", "column 4 (found end of text)"),
        ("()", "empty parentheses at column 2"),
        ("x" * 3000, "longer than"),
        # Python syntax beyond the grammar never reaches ast.parse
        ("1j", "column 1"),
        ("0x1f", "column 1"),
        ("s//2", "expected a number, s, K or '(' at column 3"),
        ("s.", "unexpected character '.' at column 2"),
        ("lambda", "unknown name 'lambda' at column 1"),
        ("s # note", "unexpected character '#' at column 3"),
        ("'s'", "unexpected character"),
        ("s\n+1", "unexpected character"),
        ("s^(1+s)", "whole number at column 4"),
        ("2^s", "whole number at column 3"),
        ("-(" * 31 + "s" + ")" * 31, "nesting deeper"),  # signs count as nesting, too
        ("+".join(["K^40"] * (MAX_OPERATIONS // 40)), "more than"),
    ],
)
def test_errors_say_what_and_where(text, fragment):
    with pytest.raises(OptionError, match="^plant: ") as info:
        parse_plant(text)
    msg = str(info.value)
    assert fragment in msg
    assert "\n" not in msg


def test_one_class_for_the_loop():
    """Text, tuples and control systems all give a Plant (LoopPlant is the same class); K G0 when linear."""
    assert LoopPlant is Plant
    p = parse_plant("K/((1+s)(1+0.25s)(1+1.1s))")
    assert as_loop_plant("K/((1+s)(1+0.25s)(1+1.1s))") is p and as_loop_plant(p) is p
    n1, d1 = p.polynomials(1.0)
    n, d = p.polynomials(7.0)
    np.testing.assert_array_equal(n, 7.0 * n1)
    np.testing.assert_array_equal(d, d1)
    q = parse_plant("K^2/(s+K)")  # non-linear: evaluated at each gain
    np.testing.assert_allclose(q.polynomials(3.0)[0], [9.0])
    np.testing.assert_allclose(q.response([1.0], [3.0]), [[9.0 / (3.0 + 1j)]])
    assert str(p) == p.text == p.label == "K/((1+s)(1+0.25s)(1+1.1s))"
    assert "at s/2" in as_loop_plant(p, time_scale=2.0).label


def test_non_text_is_an_option_error():
    with pytest.raises(OptionError, match="expected text"):
        parse_plant(3.0)


_coef = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False).filter(lambda c: abs(c) > 1e-3)


@settings(max_examples=150, deadline=None)
@given(st.lists(_coef, min_size=1, max_size=5), st.lists(_coef, min_size=2, max_size=6))
def test_round_trip_through_text(num, den):
    """format -> parse gives the same transfer function (normalised: monic denominator)."""
    p = parse_plant(format_transfer_function(num, den))
    n, d = p.polynomials()
    w = 1j * np.array([0.13, 1.7, 9.1])
    with np.errstate(all="ignore"):
        expected = np.polyval(num, w) / np.polyval(den, w)
    got = np.polyval(n, w) / np.polyval(d, w)
    ok = np.isfinite(expected)
    np.testing.assert_allclose(got[ok], expected[ok], rtol=1e-9)
    assert d[0] == 1.0


_ALPHABET = "0123456789.+-*/^()sK eE \t"


@settings(max_examples=400, deadline=None)
@given(st.one_of(st.text(max_size=60), st.text(alphabet=_ALPHABET, max_size=60)))
def test_fuzz_only_option_errors(text):
    """Whatever the text, parsing either succeeds or raises OptionError -- nothing else."""
    try:
        p = parse_plant(text)
    except OptionError as exc:
        assert "\n" not in str(exc)
        return
    assert isinstance(p, Plant)
    n, d = p.polynomials(1.5)
    assert np.all(np.isfinite(n)) and np.all(np.isfinite(d))


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.sampled_from(["s", "K", "2", "0.5", "(", ")", "+", "-", "*", "/", "^", "**", "3", " "]),
        max_size=40,
    )
)
def test_fuzz_token_soup(tokens):
    try:
        parse_plant("".join(tokens))
    except OptionError:
        pass


def test_as_loop_plant_inputs_agree():
    import control

    w = np.array([0.5, 1.414, 4.0])
    text = as_loop_plant("1/(s(s+1)(s+2))")
    tup = as_loop_plant(([1.0], [1.0, 3.0, 2.0, 0.0]))
    ctl = as_loop_plant(control.tf([1.0], [1.0, 3.0, 2.0, 0.0]))
    ref = text.response(w, [2.0])
    for other in (tup, ctl):
        np.testing.assert_allclose(other.response(w, [2.0]), ref, rtol=1e-12)
    # time scaling: G(s/alpha) at alpha w equals G(s) at w
    fast = as_loop_plant("1/(s(s+1)(s+2))", time_scale=3.0)
    np.testing.assert_allclose(fast.response(3.0 * w, [2.0]), ref, rtol=1e-12)
    with pytest.raises(OptionError):
        as_loop_plant(object())
    with pytest.raises(OptionError):
        as_loop_plant("1/s", time_scale=-1.0)
