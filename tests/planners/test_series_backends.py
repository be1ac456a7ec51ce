"""The compiled (numba) series kernels against the numpy reference: every operation, real and complex,
across orders and batch shapes, agrees to 1e-12 relative to the coefficient scale (property tests)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planners.series as S
from planners.series import Series

pytest.importorskip("numba")
from planners import _series_compiled  # noqa: E402,F401  (compiles on first use)

NUMPY, COMPILED = S._NumpyKernels, S._CompiledKernels
SET = settings(max_examples=30, deadline=None)
TOL = 1e-12

ORDERS = st.integers(0, 26)
SHAPES = st.sampled_from([(), (1,), (5,), (2, 3), (0,)])
#: (first, second) batch shapes of binary operations: equal, suffix broadcast (a complex-step batch
#: against the nodes), scalar batch, and a general broadcast.
PAIR_SHAPES = st.sampled_from(
    [((4,), (4,)), ((3, 4), (4,)), ((4,), (3, 4)), ((), (5,)), ((4, 1), (3,)), ((2, 3), (2, 3))]
)
KINDS = st.sampled_from(["real", "complex"])


def coefficients(seed, order, shape, kind, c0=(-1.0, 1.0), tail=1.0):
    """Random coefficient-last array: constant term in ``c0``, ``|c_k| <= tail 2^-k``."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1, 1, shape + (order + 1,)) * tail * 0.5 ** np.arange(order + 1)
    c[..., 0] = rng.uniform(*c0, shape)
    if kind == "complex":
        im = rng.uniform(-1, 1, shape + (order + 1,)) * tail * 0.5 ** np.arange(order + 1)
        im[..., 0] *= 0.1 * (c0[1] - c0[0])
        c = c + 1j * im
    return c


def with_backend(kernels, fn, *args):
    """``fn(*args)`` computed with the given kernel set (fresh Series, so no memoised results are shared)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(S, "_K", kernels)
        fresh = [Series(a.coeffs) if isinstance(a, Series) else a for a in args]
        return fn(*fresh)


def as_array(x):
    if isinstance(x, tuple):
        return np.stack([as_array(v) for v in x])
    return np.asarray(x.coeffs if isinstance(x, Series) else x)


def assert_agree(ref, new, tol=TOL):
    """``max |new - ref| <= tol * max |ref|`` (the coefficient scale), dtype and shape equal."""
    a, b = as_array(ref), as_array(new)
    assert a.shape == b.shape and a.dtype == b.dtype, (a.shape, b.shape, a.dtype, b.dtype)
    if a.size == 0:
        return
    scale = max(float(np.max(np.abs(a))), 1e-300)
    err = float(np.max(np.abs(a - b)))
    assert err <= tol * scale, f"max difference {err:.3g}, scale {scale:.3g}"


def check(fn, *args, tol=TOL):
    with np.errstate(all="ignore"):
        ref = with_backend(NUMPY, fn, *args)
        new = with_backend(COMPILED, fn, *args)
    assert_agree(ref, new, tol)


# ---------------------------------------------------------------------------- unary operations

#: name -> (function, range of the constant term)
UNARY = {
    "negative": (np.negative, (-1, 1)),
    "square": (np.square, (-1, 1)),
    "reciprocal": (np.reciprocal, (0.5, 2)),
    "sqrt": (np.sqrt, (0.5, 2)),
    "exp": (np.exp, (-1, 1)),
    "expm1": (np.expm1, (-1, 1)),
    "log": (np.log, (0.5, 2)),
    "log1p": (np.log1p, (-0.4, 1)),
    "sin": (np.sin, (-2, 2)),
    "cos": (np.cos, (-2, 2)),
    "sincos": (lambda u: u.sincos(), (-2, 2)),
    "tan": (np.tan, (-1, 1)),
    "arcsin": (np.arcsin, (-0.6, 0.6)),
    "arccos": (np.arccos, (-0.6, 0.6)),
    "arctan": (np.arctan, (-2, 2)),
    "sinh": (np.sinh, (-1, 1)),
    "cosh": (np.cosh, (-1, 1)),
    "sinhcosh": (lambda u: u.sinhcosh(), (-1, 1)),
    "tanh": (np.tanh, (-1, 1)),
    "pow 2.5": (lambda u: u**2.5, (0.5, 2)),
    "pow -1.5": (lambda u: u**-1.5, (0.5, 2)),
    "pow 1/3": (lambda u: np.power(u, 1 / 3), (0.5, 2)),
    "pow complex": (lambda u: u ** (0.5 + 0.25j), (0.5, 2)),
    "pow int 5": (lambda u: u**5, (-1, 1)),
    "pow int -3": (lambda u: u**-3, (0.5, 2)),
    "float_power": (lambda u: np.float_power(u, 1.7), (0.5, 2)),
    "scalar ** u": (lambda u: 2.0**u, (-1, 1)),
    "hypot(u, 1)": (lambda u: np.hypot(u, 1.0), (-1, 1)),
    "arctan2(u, 2)": (lambda u: np.arctan2(u, 2.0), (-1, 1)),
    "1 / u": (lambda u: 1.0 / u, (0.5, 2)),
    "compose": (lambda u: u.compose(u - u.constant_term), (-1, 1)),
    "derivative+integral": (lambda u: u.derivative().integral(1.0) if u.order else u, (-1, 1)),
}


@pytest.mark.parametrize("name", sorted(UNARY))
@SET
@given(seed=st.integers(0, 2**32 - 1), order=ORDERS, shape=SHAPES, kind=KINDS)
def test_unary_operations_agree(name, seed, order, shape, kind):
    fn, c0 = UNARY[name]
    u = Series(coefficients(seed, order, shape, kind, c0, tail=0.25))
    check(fn, u)


# ---------------------------------------------------------------------------- binary operations

BINARY = {
    "add": (np.add, (-1, 1)),
    "subtract": (np.subtract, (-1, 1)),
    "multiply": (np.multiply, (-1, 1)),
    "divide": (np.divide, (0.5, 2)),
    "power": (np.power, (0.5, 2)),
    "arctan2": (np.arctan2, (0.5, 2)),
    "hypot": (np.hypot, (0.5, 2)),
}


@pytest.mark.parametrize("name", sorted(BINARY))
@SET
@given(
    seed=st.integers(0, 2**32 - 1),
    order=ORDERS,
    shapes=PAIR_SHAPES,
    kinds=st.tuples(KINDS, KINDS),
    order2=st.integers(0, 26),
)
def test_binary_operations_agree(name, seed, order, shapes, kinds, order2):
    fn, c0 = BINARY[name]
    a = Series(coefficients(seed, order, shapes[0], kinds[0], c0, tail=0.25))
    b = Series(coefficients(seed + 1, order2, shapes[1], kinds[1], c0, tail=0.25))
    check(fn, a, b)


@SET
@given(seed=st.integers(0, 2**32 - 1), order=ORDERS, shape=st.sampled_from([(3,), (2, 3)]), kind=KINDS)
def test_array_exponent_and_array_operands_agree(seed, order, shape, kind):
    u = Series(coefficients(seed, order, shape, kind, (0.5, 2), tail=0.25))
    p = np.random.default_rng(seed).uniform(-2, 2, shape[-1:])
    check(lambda s: s**p, u)
    check(lambda s: p / s, u)
    check(lambda s: (p * s) * s - p, u)


# ---------------------------------------------------------------------------- the kernels themselves


def _arr(seed, order, n, kind, c0=(-1, 1)):
    return np.ascontiguousarray(np.moveaxis(coefficients(seed, order, (n,), kind, c0, 0.25), -1, 0))


@SET
@given(
    seed=st.integers(0, 2**32 - 1),
    order=ORDERS,
    n=st.integers(0, 7),
    r=st.integers(1, 5),
    kinds=st.tuples(KINDS, KINDS),
    which=st.sampled_from(["a", "b", "none"]),
)
def test_broadcasting_kernels_agree(seed, order, n, r, kinds, which):
    """mul3/div3 on (m, R|1, S) operands, either side broadcast along the middle axis."""
    m = order + 1
    a = _arr(seed, order, r * n, kinds[0]).reshape(m, r, n)
    b = _arr(seed + 1, order, r * n, kinds[1], (0.5, 2)).reshape(m, r, n)
    if which == "a":
        a = np.ascontiguousarray(a[:, :1])
    elif which == "b":
        b = np.ascontiguousarray(b[:, :1])
    for op in ("mul3", "div3"):
        assert_agree(getattr(NUMPY, op)(a, b), getattr(COMPILED, op)(a, b))


@SET
@given(seed=st.integers(0, 2**32 - 1), order=ORDERS, n=st.integers(0, 6), kind=KINDS)
def test_recurrence_kernels_agree(seed, order, n, kind):
    u = _arr(seed, order, n, kind, (0.5, 2))
    p = np.random.default_rng(seed).uniform(-2, 2, n)
    for hyperbolic in (False, True):
        assert_agree(NUMPY.sincos(u, hyperbolic), COMPILED.sincos(u, hyperbolic))
        assert_agree(NUMPY.tan(u * 0.3, hyperbolic), COMPILED.tan(u * 0.3, hyperbolic))
    assert_agree(NUMPY.exp(u), COMPILED.exp(u))
    assert_agree(NUMPY.exp(u, u[0]), COMPILED.exp(u, u[0]))
    for q in (0.5, -1.25, 3.0, 0.5 - 0.75j):
        assert_agree(NUMPY.pow(u, q), COMPILED.pow(u, q))
    assert_agree(NUMPY.pow_array(u, p), COMPILED.pow_array(u, p))
    assert_agree(NUMPY.mul(u, u), COMPILED.mul(u, u))
    assert_agree(NUMPY.div(u, u[::-1].copy() + 2), COMPILED.div(u, u[::-1].copy() + 2))


@SET
@given(seed=st.integers(0, 2**32 - 1), K=st.integers(1, 26), n=st.integers(1, 5), B=st.integers(0, 9))
def test_series_solve_kernel_agrees(seed, K, n, B):
    """The order-by-order solve of Newton on series (planners.newton) on a well-conditioned J_0."""
    rng = np.random.default_rng(seed)
    J = rng.uniform(-1, 1, (B, n, n, K)) * 0.5 ** np.arange(K)
    J[..., 0] += 3 * np.eye(n)
    G = rng.uniform(-1, 1, (B, n, K))
    J0inv = np.linalg.inv(J[..., 0]) if B else np.zeros((0, n, n))
    assert_agree(NUMPY.series_solve(J, J0inv, G), COMPILED.series_solve(J, J0inv, G))


def test_float32_stays_on_the_numpy_kernels(monkeypatch):
    """Precisions other than float64/complex128 are left to the numpy kernels, which keep them."""
    monkeypatch.setattr(S, "_K", COMPILED)
    s = Series(np.array([1.0, 0.5, 0.25], dtype=np.float32))
    for f in (np.exp, np.sin, np.tan, lambda u: u * u, lambda u: u / (u + 1), lambda u: u**2.5):
        assert f(s).dtype == np.float32


def test_backend_selection_is_read_once_from_the_environment():
    import subprocess
    import sys

    code = "import planners.series as S; print(S.BACKEND, S._K.name)"
    for want, kernels in (("numpy", "numpy"), ("compiled", "compiled"), ("native", "numpy"), ("", "numpy")):
        out = subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            check=True,
            env={**__import__("os").environ, S.BACKEND_ENV: want},
        )
        assert out.stdout.split() == [want or S.DEFAULT_BACKEND, kernels]
    bad = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env={**__import__("os").environ, S.BACKEND_ENV: "fortran"},
    )
    assert bad.returncode != 0 and "GFLAT_SERIES_BACKEND" in bad.stderr


@pytest.mark.parametrize("name", ["gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip"])
def test_paper_plans_are_the_same_with_both_backends(name):
    """Every iterate's node series of the paper's three plans, coefficient k weighted by step^k (its
    contribution over one node interval), agree to 1e-12 relative to the variable's scale (absolutely for
    a variable that is zero to rounding, such as a prescribed beta = 0)."""
    from planners.generalized import plan_scenario
    from planners.scenario import load_scenario

    sc = load_scenario(name)
    plans = {}
    for label, kernels in (("numpy", NUMPY), ("compiled", COMPILED)):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(S, "_K", kernels)
            plans[label] = plan_scenario(sc)
    a, b = plans["numpy"], plans["compiled"]
    step = float(np.min(np.diff(sc.t_nodes)))
    assert len(a.iterates) == len(b.iterates)
    for ia, ib in zip(a.iterates, b.iterates):
        assert ia.series.keys() == ib.series.keys()
        for var in ia.series:
            x, y = np.asarray(ia[var].coeffs), np.asarray(ib[var].coeffs)
            w = step ** np.arange(x.shape[-1])
            scale = float(np.max(np.abs(x) * w))
            err = float(np.max(np.abs(x - y) * w))
            assert err <= 1e-12 * (scale if scale >= 1e-12 else 1.0), (var, err, scale)
    assert a.feasible == b.feasible and len(a.warnings) == len(b.warnings)


@SET
@given(seed=st.integers(0, 2**32 - 1), order=ORDERS, kind=KINDS, bshape=st.sampled_from([(4,), (3, 4)]))
def test_linear_combinations_are_the_sums(seed, order, kind, bshape):
    """Series.linear_combinations (the aerodynamic model's contraction) equals the explicit sums."""
    rng = np.random.default_rng(seed)
    items = [
        Series(coefficients(seed, order, bshape, kind)),
        Series(coefficients(seed + 1, order + 2, (4,), "real")),
        0.5,
        rng.uniform(-1, 1, (4,)),
    ]
    w = rng.uniform(-1, 1, (3, len(items)))
    w[0, 1] = 0.0
    got = Series.linear_combinations(w, items)
    for i in range(3):
        ref = sum(float(w[i, j]) * items[j] for j in range(len(items)))
        ref = ref.truncate(order) if ref.order > order else ref
        assert_agree(ref, got[i], 1e-14)
    with pytest.raises(TypeError):
        Series.linear_combinations(w, [1.0, 2.0, 3.0, 4.0])
