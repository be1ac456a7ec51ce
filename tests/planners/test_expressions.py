"""Safe expressions of t: parsing, refusal of code, evaluation on floats, arrays and series."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna.errors import InputError
from planners.expressions import compile_expression
from planners.series import Series


def test_values_and_constants():
    e = compile_expression("29.10852587*t + 50*sin(t/60)")
    assert e(60.0) == pytest.approx(29.10852587 * 60 + 50 * math.sin(1.0))
    assert compile_expression("140*kt")(0.0) == pytest.approx(140 * 1852 / 3600)
    assert compile_expression("0.5 + arctan((t - 30.0)/5.0)/pi")(30.0) == 0.5
    assert compile_expression("h + t", {"h": 2.0})(1.0) == 3.0
    np.testing.assert_allclose(compile_expression(3)(np.zeros(4)), 3.0)


def test_on_series_matches_taylor():
    e = compile_expression("sin(t/3) * exp(t/10) + t**2")
    s = e(Series.variable(np.array([0.5, 1.0]), 6))
    h = 1e-3
    fd1 = (e(np.array([0.5, 1.0]) + h) - e(np.array([0.5, 1.0]) - h)) / (2 * h)
    np.testing.assert_allclose(np.real(s.coeffs[:, 1]), fd1, rtol=1e-6)
    np.testing.assert_allclose(np.real(s.constant_term), e(np.array([0.5, 1.0])), rtol=1e-15)


@pytest.mark.parametrize(
    "bad, message",
    [
        ("__import__('os').system('true')", "not allowed"),
        ("t.real", "Attribute not allowed"),
        ("open('x')", "unknown function"),
        ("x + 1", "unknown name 'x'"),
        ("[t]", "List not allowed"),
        ("sin(t, 2)", "takes 1 argument"),
        ("t +", "cannot parse"),
        ("lambda: 1", "Lambda not allowed"),
    ],
)
def test_refused(bad, message):
    with pytest.raises(InputError, match=message):
        compile_expression(bad, where="flat_outputs x")


def test_size_is_bounded_with_a_clear_message():
    """Issue kind: a 20 000-term expression raised RecursionError."""
    from planners.expressions import MAX_NODES, compile_expression

    with pytest.raises(InputError, match="at most 4000"):
        compile_expression("+".join(["t"] * 20000), where="[flat_outputs] y")
    with pytest.raises(InputError, match="too large"):
        compile_expression("+".join(["t"] * (MAX_NODES // 2 + 10)), where="[flat_outputs] y")
    with pytest.raises(InputError, match="too large"):
        compile_expression("-" * 300 + "t", where="[flat_outputs] y")  # nesting
    assert compile_expression("+".join(["t"] * 100))(1.0) == 100.0


def test_complex_values_are_refused():
    """Issue kind: (-1)**0.5 silently dropped its imaginary part."""
    from planners.expressions import compile_expression

    with pytest.raises(InputError, match="not real"):
        compile_expression("(-1)**0.5", where="[flat_outputs] y")
    f = compile_expression("(t - 5)**0.5", where="[flat_outputs] y")
    assert f(9.0) == 2.0
    with pytest.raises(InputError, match=r"not real at t = 1 s"):
        f(1.0)
    assert compile_expression("(-2)**2 * t")(1.0) == 4.0


@pytest.mark.parametrize("text", ["1/0 + t", "t*(1/0)", "1/0*t", "10**400*t", "t**(0**-1)"])
def test_a_part_without_t_that_cannot_be_evaluated_is_refused_when_read(text):
    # a new user's try (2026-12-02): the part without t failed only while planning, a traceback with exit 1
    with pytest.raises(InputError, match="cannot be evaluated"):
        compile_expression(text, where="x")
