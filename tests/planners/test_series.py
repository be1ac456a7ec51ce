"""Tests of :mod:`planners.series` (batched truncated power series)."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from planners.series import Series

N_KNOWN = 15  # order used for the closed-form expansions
HSET = settings(max_examples=40, deadline=None)


# ---------------------------------------------------------------------------- helpers


def coeffs(x):
    """Coefficient array of a Series, or the array itself."""
    return x.coeffs if isinstance(x, Series) else np.asarray(x)


def assert_series_close(a, b, tol=1e-12):
    """Coefficient-wise comparison (same order and batch shape required)."""
    if isinstance(a, Series) and isinstance(b, Series):
        assert a.order == b.order and a.batch_shape == b.batch_shape
    np.testing.assert_allclose(coeffs(a), coeffs(b), rtol=tol, atol=tol)


def binom(a, k):
    """Generalised binomial coefficient C(a, k)."""
    return math.prod(a - i for i in range(k)) / math.factorial(k)


def odd(values, n=N_KNOWN):
    """Coefficients of an odd series from its odd-power coefficients."""
    c = np.zeros(n + 1)
    c[1::2] = values[: len(c[1::2])]
    return c


def make_series(draw, order, shape, c0):
    """Series with constant term in ``c0`` and tail coefficients ``|c_k| <= 2^-k``.

    The tail bound keeps ``|f - c0| <= 1`` on the unit disk, so every function
    applied in the tests stays far from its singularities.
    """
    lo, hi = c0
    const = draw(hnp.arrays(np.float64, shape, elements=st.floats(lo, hi)))
    tail = draw(hnp.arrays(np.float64, shape + (order,), elements=st.floats(-1.0, 1.0)))
    tail = tail * 0.5 ** np.arange(1, order + 1)
    return Series(np.concatenate([const[..., None], tail], axis=-1))


@st.composite
def series(draw, c0=(-1.0, 1.0), min_order=0, max_order=12):
    """A single random series (order and batch shape drawn too)."""
    order = draw(st.integers(min_order, max_order))
    shape = draw(st.sampled_from([(), (3,), (2, 2)]))
    return make_series(draw, order, shape, c0)


@st.composite
def series_pair(draw, c0_f=(-1.0, 1.0), c0_g=(-1.0, 1.0), min_order=0, max_order=12):
    """Two random series of the same order and batch shape."""
    order = draw(st.integers(min_order, max_order))
    shape = draw(st.sampled_from([(), (3,)]))
    return make_series(draw, order, shape, c0_f), make_series(draw, order, shape, c0_g)


def model(x):
    """A function written once with numpy ufuncs (float, ndarray or Series)."""
    return (
        np.sin(x) * np.exp(x / 2) / np.sqrt(1 + x**2)
        + np.arctan2(x, 2 + np.cos(x))
        + np.tan(0.3 * x) ** 3
        - np.log(2 + x)
        + (1.5 + x) ** 1.7
        + np.arcsin(0.4 * x)
        + np.arctan(x) * np.cosh(x)
        - 1 / (3 - x)
        + np.tanh(x) * np.arccos(0.3 * x)
    )


# ---------------------------------------------------------------------------- known expansions

T0 = Series.variable(0.0, N_KNOWN)
K = np.arange(N_KNOWN + 1)
FACT = np.array([math.factorial(k) for k in K], dtype=float)
TAN_ODD = [
    Fraction(1),
    Fraction(1, 3),
    Fraction(2, 15),
    Fraction(17, 315),
    Fraction(62, 2835),
    Fraction(1382, 155925),
    Fraction(21844, 6081075),
    Fraction(929569, 638512875),
]
KNOWN = {
    "exp": (lambda t: np.exp(t), 1 / FACT),
    "expm1": (lambda t: np.expm1(t), np.r_[0.0, 1 / FACT[1:]]),
    "log(1+t)": (lambda t: np.log(1 + t), np.r_[0.0, [(-1) ** (k + 1) / k for k in K[1:]]]),
    "log1p": (lambda t: np.log1p(t), np.r_[0.0, [(-1) ** (k + 1) / k for k in K[1:]]]),
    "sin": (lambda t: np.sin(t), odd([(-1) ** j / math.factorial(2 * j + 1) for j in range(8)])),
    "cos": (lambda t: np.cos(t), np.where(K % 2 == 0, (-1.0) ** (K // 2) / FACT, 0.0)),
    "sinh": (lambda t: np.sinh(t), odd([1 / math.factorial(2 * j + 1) for j in range(8)])),
    "cosh": (lambda t: np.cosh(t), np.where(K % 2 == 0, 1 / FACT, 0.0)),
    "tan": (lambda t: np.tan(t), odd([float(f) for f in TAN_ODD])),
    "tanh": (lambda t: np.tanh(t), odd([(-1) ** j * float(f) for j, f in enumerate(TAN_ODD)])),
    "arcsin": (lambda t: np.arcsin(t), odd([math.comb(2 * j, j) / (4**j * (2 * j + 1)) for j in range(8)])),
    "arccos": (
        lambda t: np.arccos(t),
        np.eye(1, N_KNOWN + 1)[0] * np.pi / 2 - odd([math.comb(2 * j, j) / (4**j * (2 * j + 1)) for j in range(8)]),
    ),
    "arctan": (lambda t: np.arctan(t), odd([(-1) ** j / (2 * j + 1) for j in range(8)])),
    "arctan2(t, 1)": (lambda t: np.arctan2(t, 1.0), odd([(-1) ** j / (2 * j + 1) for j in range(8)])),
    "sqrt(1+t)": (lambda t: np.sqrt(1 + t), np.array([binom(0.5, k) for k in K])),
    "(1+t)**a": (lambda t: (1 + t) ** 2.7, np.array([binom(2.7, k) for k in K])),
    "(1+t)**-1.5": (lambda t: np.power(1 + t, -1.5), np.array([binom(-1.5, k) for k in K])),
    "1/(1-t)": (lambda t: 1 / (1 - t), np.ones(N_KNOWN + 1)),
    "(1+t)**-3": (lambda t: (1 + t) ** -3, np.array([binom(-3, k) for k in K])),
    "hypot(1, t)": (lambda t: np.hypot(1.0, t), np.array([binom(0.5, k // 2) if k % 2 == 0 else 0.0 for k in K])),
}


@pytest.mark.parametrize("name", sorted(KNOWN))
def test_known_expansions_at_zero(name):
    fun, expected = KNOWN[name]
    np.testing.assert_allclose(fun(T0).coeffs, expected, rtol=1e-13, atol=1e-15)


def test_known_expansions_at_nonzero_points():
    t0 = np.array([0.3, 1.7, -2.5])
    t = Series.variable(t0, 12)
    k = np.arange(13)
    fk = np.array([math.factorial(i) for i in k], dtype=float)
    np.testing.assert_allclose(np.exp(t).coeffs, np.exp(t0)[:, None] / fk, rtol=1e-13)
    np.testing.assert_allclose(np.sin(t).coeffs, np.sin(t0[:, None] + k * np.pi / 2) / fk, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(np.cos(t).coeffs, np.cos(t0[:, None] + k * np.pi / 2) / fk, rtol=1e-13, atol=1e-15)
    x0 = np.abs(t0)
    x = Series.variable(x0, 12)
    expected_log = np.concatenate([np.log(x0)[:, None], (-1.0) ** (k[1:] + 1) / (k[1:] * x0[:, None] ** k[1:])], axis=1)
    np.testing.assert_allclose(np.log(x).coeffs, expected_log, rtol=1e-13)
    expected_sqrt = np.array([binom(0.5, i) for i in k]) * x0[:, None] ** (0.5 - k)
    np.testing.assert_allclose(np.sqrt(x).coeffs, expected_sqrt, rtol=1e-13)


def test_integer_powers_with_zero_constant_term():
    t = Series.variable(0.0, 6)
    np.testing.assert_array_equal((t**3).coeffs, [0, 0, 0, 1, 0, 0, 0])
    np.testing.assert_array_equal((t**0).coeffs, [1, 0, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal((t**2.0).coeffs, [0, 0, 1, 0, 0, 0, 0])
    np.testing.assert_array_equal(np.square(t).coeffs, [0, 0, 1, 0, 0, 0, 0])
    assert (t**1) is t
    u = 1 - t
    np.testing.assert_allclose((u**-2).coeffs, np.arange(1, 8), rtol=1e-14)
    np.testing.assert_allclose(np.reciprocal(u).coeffs, np.ones(7), rtol=1e-14)


def test_arctan2_follows_the_angle_in_every_quadrant():
    theta0 = np.array([0.2, 1.5, 2.9, -2.9, -1.2, -0.1, np.pi / 2, -np.pi / 2])
    t = Series.variable(0.0, 10)
    theta = np.zeros((theta0.size, 11))
    theta[:, 0], theta[:, 1], theta[:, 2] = theta0, 1.0, 0.3
    th = Series(theta)
    r = 2 + t
    got = np.arctan2(r * np.sin(th), r * np.cos(th))
    np.testing.assert_allclose(got.coeffs, theta, rtol=1e-13, atol=1e-13)
    # constant second argument
    np.testing.assert_allclose(np.arctan2(t, -2.0).constant_term, np.pi)
    # arctan2(t, -2) = pi - arctan(t / 2) near t = 0
    np.testing.assert_allclose(np.arctan2(t, -2.0).coeffs[1:], -np.arctan(t / 2).coeffs[1:], atol=1e-15)


# ---------------------------------------------------------------------------- identities (hypothesis)


@HSET
@given(series(c0=(-3.0, 3.0)))
def test_sin2_plus_cos2(f):
    assert_series_close(np.sin(f) ** 2 + np.cos(f) ** 2, f.ones_like(), 1e-13)


@HSET
@given(series(c0=(-2.0, 2.0)))
def test_cosh2_minus_sinh2_and_tanh(f):
    assert_series_close(np.cosh(f) ** 2 - np.sinh(f) ** 2, f.ones_like(), 1e-11)
    assert_series_close(np.tanh(f), np.sinh(f) / np.cosh(f), 1e-12)


@HSET
@given(series(c0=(1.5, 3.0)))
def test_exp_log_and_log_exp(f):
    assert_series_close(np.exp(np.log(f)), f)
    assert_series_close(np.log(np.exp(f)), f)
    assert_series_close(np.expm1(np.log1p(f)), f)


@HSET
@given(series_pair(c0_f=(-2.0, 2.0), c0_g=(1.5, 3.0)), st.booleans())
def test_product_quotient_round_trip(fg, negate):
    f, g = fg
    g = -g if negate else g
    assert_series_close((f * g) / g, f)
    assert_series_close(f / g * g, f)
    assert_series_close(f * g, g * f, 1e-14)


@HSET
@given(series(c0=(1.5, 3.0)))
def test_sqrt_squared(f):
    assert_series_close(np.sqrt(f) ** 2, f)
    assert_series_close(np.sqrt(f) * np.sqrt(f), f)
    assert_series_close(f**0.5, np.sqrt(f), 1e-14)


@HSET
@given(series(c0=(1.5, 3.0)), st.floats(-3.0, 3.0).filter(lambda a: abs(a) > 0.1))
def test_real_powers(f, a):
    assert_series_close((f**a) ** (1 / a), f, 1e-10)
    assert_series_close(f**a, np.exp(a * np.log(f)), 1e-11)
    assert_series_close(f ** (a + 1), f**a * f, 1e-11)


@HSET
@given(series(c0=(-0.5, 0.5)))
def test_tan_is_sin_over_cos(f):
    assert_series_close(np.tan(f), np.sin(f) / np.cos(f))
    assert_series_close(np.arctan(np.tan(f)), f)
    assert_series_close(np.arcsin(np.sin(f)), f)
    assert_series_close(np.arccos(np.cos(f + 1.0)), f + 1.0, 1e-11)


@HSET
@given(series(c0=(-3.0, 3.0)))
def test_arctan2_of_sin_cos(f):
    assert_series_close(np.arctan2(np.sin(f), np.cos(f)), f)
    assert_series_close(np.arctan2(3 * np.sin(f), 3 * np.cos(f)), f)


@HSET
@given(series_pair(c0_f=(-2.0, 2.0), c0_g=(-2.0, 2.0)))
def test_hypot(fg):
    f, g = fg
    h = np.hypot(f + 3.0, g)
    assert_series_close(h * h, (f + 3.0) ** 2 + g**2, 1e-11)


@HSET
@given(st.data(), st.integers(0, 10), st.sampled_from([(), (3,)]))
def test_composition_associativity_and_identity(data, order, shape):
    f = make_series(data.draw, order, shape, (-1.0, 1.0))
    g = make_series(data.draw, order, shape, (0.0, 0.0))
    h = make_series(data.draw, order, shape, (0.0, 0.0))
    ident = Series.variable(np.zeros(shape), order)
    assert_series_close(f.compose(ident), f, 1e-14)
    assert_series_close(ident.compose(g), g, 1e-14)
    assert_series_close(f.compose(g.compose(h)), f.compose(g).compose(h), 1e-12)


def test_compose_matches_function_of_function():
    t = Series.variable(0.0, 10)
    g = np.sin(t)
    assert_series_close(np.exp(t).compose(g), np.exp(g), 1e-14)
    with pytest.raises(ValueError, match="zero constant term"):
        np.exp(t).compose(g + 1)


@HSET
@given(series_pair(min_order=1))
def test_product_rule(fg):
    f, g = fg
    assert_series_close((f * g).derivative(), f.derivative() * g + f * g.derivative(), 1e-13)


@HSET
@given(series(min_order=1), st.floats(-5.0, 5.0))
def test_integral_derivative_round_trip(f, c0):
    assert_series_close(f.derivative().integral(f.constant_term), f, 1e-14)
    g = f.integral(c0)
    assert g.order == f.order + 1
    np.testing.assert_allclose(g.constant_term, c0)
    assert_series_close(g.derivative(), f, 1e-14)


@HSET
@given(series(c0=(-1.0, 1.0)), series(c0=(-1.0, 1.0)))
def test_mixed_orders_truncate_to_smaller(f, g):
    if f.batch_shape != g.batch_shape:
        g = g[(0,) * len(g.batch_shape)]
    m = min(f.order, g.order)
    s = f + g * 2.0
    assert s.order == m
    assert_series_close(s, f.truncate(m) + 2.0 * g.truncate(m), 1e-15)
    assert (f * g).order == m


# ---------------------------------------------------------------------------- Taylor accuracy


def test_series_matches_function_values():
    t0 = np.linspace(-0.8, 0.9, 7)
    s = model(Series.variable(t0, 14))
    for h in (1e-2, -1e-2):
        np.testing.assert_allclose(s.eval(h), model(t0 + h), rtol=0, atol=1e-13)
    np.testing.assert_allclose(s.constant_term, model(t0), rtol=1e-14)


@pytest.mark.parametrize("order", [1, 2, 3])
def test_truncation_error_is_order_n_plus_one(order):
    t0 = np.array([-0.4, 0.25, 0.7])
    s = model(Series.variable(t0, order))
    h = np.array([2e-3, 1e-3])[:, None]
    err = np.abs(s.eval(h) - model(t0 + h))
    slope = np.log2(err[0] / err[1])  # err ~ C h^(n+1)
    np.testing.assert_allclose(slope, order + 1, atol=0.15)


def test_derivatives_match_finite_differences():
    t0 = np.array([0.1, -0.3])
    d = model(Series.variable(t0, 4)).derivatives()
    h = 1e-4
    fd1 = (model(t0 + h) - model(t0 - h)) / (2 * h)
    fd2 = (model(t0 + h) - 2 * model(t0) + model(t0 - h)) / h**2
    np.testing.assert_allclose(d[:, 1], fd1, rtol=1e-7)
    np.testing.assert_allclose(d[:, 2], fd2, rtol=1e-5)


# ---------------------------------------------------------------------------- complex step


def test_complex_step_on_expansion_point():
    """d c_k / d t0 = (k + 1) c_{k+1}, recovered exactly by a complex step."""
    x = np.array([0.3, -0.7, 0.55])
    n, h = 10, 1e-30
    ref = model(Series.variable(x, n + 1)).coeffs
    ref = np.arange(1, n + 2) * ref[:, 1:]
    cs = model(Series.variable(x + 1j * h, n))
    assert cs.dtype == np.complex128
    scale = np.abs(ref).max(axis=-1, keepdims=True)
    err = np.abs(cs.imag.coeffs / h - ref) / scale
    assert err.max() < 1e-14, err.max()
    real = model(Series.variable(x, n)).coeffs
    np.testing.assert_allclose(cs.real.coeffs, real, rtol=1e-14, atol=1e-14 * np.abs(real).max())


CHAIN = {  # f and its derivative written with other operations
    "exp": (np.exp, np.exp),
    "log": (np.log, lambda u: 1 / u),
    "sqrt": (np.sqrt, lambda u: 0.5 / np.sqrt(u)),
    "pow": (lambda u: u**2.3, lambda u: 2.3 * u**1.3),
    "sin": (np.sin, np.cos),
    "cos": (np.cos, lambda u: -np.sin(u)),
    "tan": (np.tan, lambda u: 1 + np.tan(u) ** 2),
    "tanh": (np.tanh, lambda u: 1 - np.tanh(u) ** 2),
    "sinh": (np.sinh, np.cosh),
    "arcsin": (lambda u: np.arcsin(u / 3), lambda u: 1 / np.sqrt(9 - u * u)),
    "arccos": (lambda u: np.arccos(u / 3), lambda u: -1 / np.sqrt(9 - u * u)),
    "arctan": (np.arctan, lambda u: 1 / (1 + u * u)),
    "reciprocal": (np.reciprocal, lambda u: -1 / (u * u)),
    "atan2_y": (lambda u: np.arctan2(u, -1.5), lambda u: -1.5 / (u * u + 2.25)),
    "atan2_x": (lambda u: np.arctan2(-0.8, u), lambda u: 0.8 / (u * u + 0.64)),
}


@pytest.mark.parametrize("name", sorted(CHAIN))
def test_complex_step_is_exact_in_every_coefficient(name):
    """Im f(u + i h d) / h == f'(u) d in series arithmetic (chain rule)."""
    f, df = CHAIN[name]
    rng = np.random.default_rng(1)
    n = 9
    u = Series(
        np.concatenate([rng.uniform(1.2, 2.0, (4, 1)), rng.uniform(-1, 1, (4, n)) * 0.5 ** np.arange(1, n + 1)], axis=1)
    )
    u = Series.stack([u, -u], axis=0) if name in ("atan2_x", "atan2_y", "sin", "cos", "tan") else u
    d = Series(rng.uniform(-1, 1, u.batch_shape + (n + 1,)))
    h = 1e-30
    got = f(u + 1j * h * d).imag / h
    ref = df(u) * d
    scale = np.abs(ref.coeffs).max()
    np.testing.assert_allclose(got.coeffs, ref.coeffs, rtol=1e-14, atol=1e-14 * scale)


# ---------------------------------------------------------------------------- batches and broadcasting


def test_batch_equals_scalar_computations():
    rng = np.random.default_rng(2)
    t0 = rng.uniform(-0.9, 0.9, 100)
    batch = model(Series.variable(t0, 8) + 0.1 * Series.variable(0.0, 8) ** 2)
    for i in range(100):
        single = model(Series.variable(t0[i], 8) + 0.1 * Series.variable(0.0, 8) ** 2)
        assert single.batch_shape == ()
        np.testing.assert_allclose(batch[i].coeffs, single.coeffs, rtol=1e-14, atol=1e-15)


def test_broadcasting_with_ndarrays_on_both_sides():
    rng = np.random.default_rng(3)
    s = Series(rng.uniform(1, 2, (5, 4)))
    arr = rng.uniform(1, 2, 5)
    c = s.coeffs
    for res, exp in [
        (arr * s, arr[:, None] * c),
        (s * arr, arr[:, None] * c),
        (s / arr, c / arr[:, None]),
        (arr - s, np.concatenate([(arr - c[:, 0])[:, None], -c[:, 1:]], 1)),
        (s - arr, np.concatenate([(c[:, 0] - arr)[:, None], c[:, 1:]], 1)),
        (arr + s, np.concatenate([(arr + c[:, 0])[:, None], c[:, 1:]], 1)),
        (s + arr, np.concatenate([(arr + c[:, 0])[:, None], c[:, 1:]], 1)),
    ]:
        assert isinstance(res, Series) and res.batch_shape == (5,)
        np.testing.assert_allclose(res.coeffs, exp, rtol=1e-15)
    np.testing.assert_allclose((arr / s).coeffs, (arr * s.reciprocal()).coeffs, rtol=1e-14)
    grid = arr[:, None, None] * np.ones((5, 2, 1))  # batch (5,) against (5, 2, 1) -> (5, 2, 5)
    assert (grid * s).batch_shape == (5, 2, 5)
    assert (s - grid).batch_shape == (5, 2, 5)
    np.testing.assert_allclose((s * grid)[1, 0, 3].coeffs, arr[1] * c[3])
    col = Series.variable(np.arange(3.0)[:, None], 2)  # (3, 1) with (5,) series
    assert (col * s).batch_shape == (3, 5)
    np.testing.assert_allclose((col * s)[2, 4].coeffs, (Series.variable(2.0, 2) * s[4]).coeffs)


def test_numpy_dispatch():
    t = Series.variable(np.array([0.2, 0.4]), 6)
    for res in (
        np.sin(t),
        np.arctan2(t, 2.0),
        np.arctan2(2.0, t),
        np.sqrt(t + 1),
        t**2,
        2.0**t,
        np.float64(3.0) * t,
        t * np.float64(3.0),
        np.power(t + 1, 2.5),
        np.exp(t),
        np.add(t, t),
        np.divide(1.0, t + 1),
        np.negative(t),
        np.positive(t),
    ):
        assert isinstance(res, Series)
        assert res.batch_shape == (2,)
    assert_series_close(2.0**t, np.exp(t * np.log(2.0)), 1e-15)
    assert_series_close(np.float64(2.0) ** t, np.exp(t * np.log(2.0)), 1e-15)
    assert_series_close((t + 1) ** (t + 1), np.exp((t + 1) * np.log(t + 1)), 1e-15)
    assert_series_close(np.float64(3.0) * t, 3.0 * t, 0)
    assert_series_close(np.arctan2(t, 2.0), np.arctan(t / 2.0), 1e-15)
    assert_series_close(t**2, t * t, 0)
    assert_series_close(np.power(t + 1, np.array([2.5, 2.5])), (t + 1) ** 2.5, 1e-14)
    assert_series_close(
        np.power(t + 1, np.array([1.5, -0.5])), Series.stack([(t[0] + 1) ** 1.5, (t[1] + 1) ** -0.5]), 1e-14
    )


def test_unsupported_and_comparisons_raise():
    s = Series.variable(1.0, 3)
    with pytest.raises(TypeError, match="floor"):
        np.floor(s)
    with pytest.raises(TypeError, match="absolute"):
        np.abs(s)
    for op in (
        lambda: s < 1,
        lambda: s > 0,
        lambda: 1.0 <= s,
        lambda: np.ones(2) < s,
        lambda: s == s,
        lambda: bool(s),
        lambda: np.greater(s, 0),
    ):
        with pytest.raises(TypeError, match="truth value"):
            op()
    with pytest.raises(TypeError):
        s + "a"
    with pytest.raises(TypeError):
        float(s)


# ---------------------------------------------------------------------------- API details


def test_construction_and_properties():
    s = Series([[1, 2, 3], [4, 5, 6]])
    assert s.order == 2 and s.batch_shape == (2,) and s.dtype == np.float64
    np.testing.assert_array_equal(s.constant_term, [1, 4])
    np.testing.assert_array_equal(s.derivatives(), [[1, 2, 6], [4, 5, 12]])
    assert_series_close(Series.from_derivatives(s.derivatives()), s, 1e-15)
    with pytest.raises(ValueError):
        s.coeffs[0, 0] = 7.0
    c = Series.constant(np.array([1.0, 2.0]), 3)
    np.testing.assert_array_equal(c.coeffs, [[1, 0, 0, 0], [2, 0, 0, 0]])
    v = Series.variable(2.5, 3)
    np.testing.assert_array_equal(v.coeffs, [2.5, 1, 0, 0])
    np.testing.assert_array_equal(s.zeros_like().coeffs, np.zeros((2, 3)))
    np.testing.assert_array_equal(s.ones_like().coeffs, [[1, 0, 0], [1, 0, 0]])
    z = Series.variable(1.0 + 2.0j, 2)
    assert z.dtype == np.complex128
    np.testing.assert_array_equal(z.real.coeffs, [1, 1, 0])
    np.testing.assert_array_equal(z.imag.coeffs, [2, 0, 0])
    assert "order=2" in repr(s) and "batch_shape=(2,)" in repr(s)
    assert "order=13" in repr(Series(np.zeros((50, 14))))
    with pytest.raises(ValueError):
        Series(np.zeros((3, 0)))
    with pytest.raises(ValueError):
        Series.constant(1.0, -1)
    with pytest.raises(ValueError):
        Series.constant(1.0, 0).derivative()


def test_batch_indexing_stacking_reshaping():
    rng = np.random.default_rng(4)
    c = rng.standard_normal((4, 3, 6))
    s = Series(c)
    np.testing.assert_array_equal(s[1].coeffs, c[1])
    np.testing.assert_array_equal(s[:, 2].coeffs, c[:, 2])
    np.testing.assert_array_equal(s[..., 0].coeffs, c[:, 0])
    mask = np.array([True, False, True, True])
    np.testing.assert_array_equal(s[mask].coeffs, c[mask])
    np.testing.assert_array_equal(s[[0, 2], [1, 1]].coeffs, c[[0, 2], [1, 1]])
    np.testing.assert_array_equal(s.reshape(12).coeffs, c.reshape(12, 6))
    np.testing.assert_array_equal(s.reshape((2, -1)).coeffs, c.reshape(2, 6, 6))
    st_ = Series.stack([s[0], s[1], s[2]], axis=1)
    np.testing.assert_array_equal(st_.coeffs, np.stack([c[0], c[1], c[2]], axis=1))
    np.testing.assert_array_equal(Series.stack([s[0, 0], s[1]]).coeffs[0], np.broadcast_to(c[0, 0], (3, 6)))
    assert Series.stack([s, s.truncate(2)]).order == 2
    np.testing.assert_array_equal(Series.concatenate([s, s[:1]]).coeffs, np.concatenate([c, c[:1]]))
    np.testing.assert_array_equal(s.broadcast_to((2, 4, 3)).coeffs, np.broadcast_to(c, (2, 4, 3, 6)))
    np.testing.assert_array_equal(s.truncate(2).coeffs, c[..., :3])
    np.testing.assert_array_equal(s.pad(8).coeffs[..., :6], c)
    np.testing.assert_array_equal(s.pad(8).coeffs[..., 6:], 0)
    with pytest.raises(ValueError):
        s.truncate(6)
    with pytest.raises(ValueError):
        s.pad(3)
    assert [x.batch_shape for x in s] == [(3,)] * 4


def test_eval_and_shift():
    c = np.array([[1.0, 2.0, -1.0, 0.5], [0.0, 1.0, 1.0, 1.0]])
    s = Series(c)
    dt = np.array([0.3, -0.2])
    p = np.polynomial.polynomial
    np.testing.assert_allclose(s.eval(dt), [p.polyval(dt[i], c[i]) for i in range(2)])
    grid = np.linspace(-1, 1, 5)[:, None]
    assert s.eval(grid).shape == (5, 2)
    np.testing.assert_allclose(s.eval(grid)[:, 1], p.polyval(grid[:, 0], c[1]))
    for k in range(5):
        expected = [p.polyval(dt[i], p.polyder(c[i], k)) if k <= 3 else 0.0 for i in range(2)]
        np.testing.assert_allclose(s.eval_derivative(dt, k), expected, atol=1e-15)
    sh = s.shift(dt)
    tau = 0.37
    np.testing.assert_allclose(sh.eval(tau), s.eval(dt + tau), rtol=1e-14)
    np.testing.assert_allclose(sh.shift(-dt).coeffs, c, atol=1e-14)


def test_sincos_memoised_and_consistent():
    t = Series.variable(np.array([0.1, 0.5]), 7)
    assert np.sin(t) is np.sin(t)
    s, c = t.sincos()
    assert s is np.sin(t) and c is np.cos(t)
    assert_series_close(np.sin(2 * t), 2 * np.sin(t) * np.cos(t), 1e-14)


def test_complex_exponent():
    u = Series.variable(np.array([1.3, 2.0]), 8)
    a = 1.5 + 0.5j
    assert_series_close(u**a, np.exp(a * np.log(u)), 1e-14)
    assert_series_close((u**a) * u, u ** (a + 1), 1e-14)


def test_float32_and_complex_dtypes():
    s = Series(np.array([1.0, 0.5, 0.25], dtype=np.float32))
    assert (s * 2.0).dtype == np.float32
    assert (np.sqrt(s) + 1).dtype == np.float32
    for f in (np.log, np.exp, np.sin, np.tan, np.arctan, lambda u: np.arctan2(u, u + 1), lambda u: u**2.5):
        assert f(s).dtype == np.float32
    assert s.derivative().dtype == np.float32 and s.integral().dtype == np.float32
    z = s + 1j
    assert z.dtype == np.complex64
