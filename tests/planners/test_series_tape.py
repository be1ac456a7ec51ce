"""Traced stage residuals (planners.series_tape): the replay equals the eager evaluation bit for bit.

Exactly, not to a tolerance: every instruction calls the function the eager Series path calls, on
arrays of the same values and layout, so the results are the same floating-point numbers (module
docstring).  Checked on the stage-2 and stage-4 residuals of the three paper scenarios at several
orders, real and complex-step inputs, the tape traced on one kind and replayed on the other, with
the numpy and the compiled kernels; on random programs of the supported operations (hypothesis);
and the eager fallback when the residual does something the tracer does not record.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import planners.series as S
from planners.newton import newton_series
from planners.series import Series
from planners.series_tape import TapedResidual, TraceError, trace

flat = importlib.import_module("planners.chained")  # the module whose stages call newton_series

PAPER = ("gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip")
H = 1e-30  # the complex step of planners.newton


def _backends():
    out = [pytest.param(S._NumpyKernels, id="numpy")]
    try:
        import numba  # noqa: F401

        out.append(pytest.param(S._CompiledKernels, id="compiled"))
    except ImportError:
        out.append(pytest.param(None, id="compiled", marks=pytest.mark.skip(reason="numba not installed")))
    return out


@pytest.fixture(params=_backends())
def kernels(request, monkeypatch):
    monkeypatch.setattr(S, "_K", request.param)
    return request.param


@pytest.fixture(scope="module")
def stage_residuals():
    """The first iterate's stage-2 and stage-4 residuals of each paper scenario, with their solutions."""
    from planners.generalized import plan_scenario
    from planners.scenario import load_scenario

    original = flat.newton_series
    out = {}
    for name in PAPER:
        captured = []

        def capture(residual, u0, order, **kw):
            u, rep = original(residual, u0, order, **kw)
            captured.append((residual, u, order))  # noqa: B023
            return u, rep

        flat.newton_series = capture
        try:
            plan_scenario(load_scenario(name))
        finally:
            flat.newton_series = original
        out[name] = {"stage2": captured[0], "stage4": captured[1]}
    return out


def _coeffs(r):
    return np.asarray(r.coeffs if isinstance(r, Series) else r)


def _assert_same(got, want):
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert type(g) is type(w)
        cg, cw = _coeffs(g), _coeffs(w)
        assert cg.dtype == cw.dtype and cg.shape == cw.shape
        np.testing.assert_array_equal(cg, cw)


def _inputs(u, k, kind, shift=0.0):
    """Unknowns at order k: real, or the complex-step batch of planners.newton (n, nodes)."""
    stacked = np.stack([np.real(x.truncate(min(k, x.order)).coeffs) for x in u]) * (1.0 + shift)
    if kind == "real":
        return [Series(stacked[j]) for j in range(len(u))]
    n = len(u)
    pert = np.broadcast_to(stacked, (n,) + stacked.shape).astype(complex)
    for j in range(n):
        pert[j, j, ..., 0] += 1j * H
    return [Series(pert[:, j]) for j in range(n)]


@pytest.mark.parametrize("name", PAPER)
@pytest.mark.parametrize("stage", ["stage2", "stage4"])
@pytest.mark.parametrize("first", ["complex", "real"])
def test_replay_equals_eager_on_paper_residuals(stage_residuals, kernels, name, stage, first):
    residual, u, order = stage_residuals[name][stage]
    other = "real" if first == "complex" else "complex"
    for k in sorted({1, max(1, order // 2), order}):
        tr = TapedResidual(residual)
        a = _inputs(u, k, first)
        _assert_same(tr(a, k), residual(a, k))  # the trace's own values
        for kind, shift in ((other, 0.0), (first, 1e-3), (other, -2e-3)):
            b = _inputs(u, k, kind, shift)
            _assert_same(tr(b, k), residual(b, k))  # replays, either kind
        assert tr.counts == {"eager": 0, "trace": 1, "replay": 3}, tr.reason
        assert tr.reason is None


def test_tape_is_smaller_than_the_model(stage_residuals):
    """Dead code (forces a stage does not use) is dropped; only unknown-dependent work is replayed."""
    residual, u, order = stage_residuals["gtm-aileron-roll"]["stage4"]
    tape, _ = trace(residual, _inputs(u, order, "real"), order)
    assert 0 < tape.n_instructions < 60


def test_orders_have_their_own_tapes(stage_residuals):
    residual, u, order = stage_residuals["gtm-aileron-roll"]["stage2"]
    tr = TapedResidual(residual, "first")
    for k in (2, 4, 2, 4):
        a = _inputs(u, k, "real")
        _assert_same(tr(a, k), residual(a, k))
    assert tr.counts == {"eager": 0, "trace": 2, "replay": 2}
    assert sorted(tr.tapes) == [2, 4]


@pytest.mark.parametrize(
    "when, counts",
    [
        ("first", {"eager": 0, "trace": 3, "replay": 3}),
        ("first-order", {"eager": 2, "trace": 3, "replay": 1}),
        ("second", {"eager": 3, "trace": 2, "replay": 1}),
        ("never", {"eager": 6, "trace": 0, "replay": 0}),
    ],
)
def test_when_to_trace(stage_residuals, when, counts):
    """The doubling pattern (each order once), then a warm pattern (one order, evaluated again)."""
    residual, u, order = stage_residuals["gtm-forward-slip"]["stage2"]
    tr = TapedResidual(residual, when)
    for k in (1, 2, 4, 4, 4, 2):
        a = _inputs(u, k, "real", 1e-3 * k)
        _assert_same(tr(a, k), residual(a, k))
    assert tr.counts == counts


def test_pointwise_arrays_are_eager(stage_residuals):
    residual, u, order = stage_residuals["twin-otter-single-engine"]["stage2"]
    tr = TapedResidual(residual)
    x = [np.real(s.constant_term).copy() for s in u]
    for got, want in zip(tr(x, 0), residual(x, 0)):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    assert tr.counts["eager"] == 1 and not tr.tapes


# ---------------------------------------------------------------------------- fallback


@pytest.mark.parametrize("use", ["truncate", "index", "coeffs", "compare", "batch_shape", "float"])
def test_untraceable_residual_falls_back_to_eager(use):
    rng = np.random.default_rng(3)
    data = Series(rng.uniform(1, 2, (5, 4)))

    def residual(u, k):
        a, b = u
        r = a * data + np.sin(b)
        if use == "truncate":
            r = r + a.truncate(k)
        elif use == "index":
            r = r + a[:]
        elif use == "coeffs":
            r = r + Series(np.asarray(a.coeffs))
        elif use == "compare":
            r = r + (a if a > 0 else b)
        elif use == "batch_shape":
            r = r + np.zeros(a.batch_shape)
        elif use == "float":
            r = r * float(a.order + 1) + float(b.constant_term[0])
        return [r, a - b]

    tr = TapedResidual(residual)
    for shift in (0.0, 0.1, 0.2):
        u = [Series(rng.uniform(1, 2, (5, 4)) + shift), Series(rng.uniform(1, 2, (5, 4)))]
        if use == "compare":
            with pytest.raises(TypeError):
                residual(u, 3)
            with pytest.raises(TypeError):
                tr(u, 3)
            continue
        _assert_same(tr(u, 3), residual(u, 3))
    if use == "float":
        # .order is fixed by the working order and allowed; the constant term is not
        assert "constant term" in tr.reason
    else:
        assert tr.reason
    assert tr.counts["trace"] == 0 and tr.counts["replay"] == 0


def test_trace_error_names_the_operation():
    def residual(u, k):
        return [u[0].derivative()]

    with pytest.raises(TraceError, match="derivative"):
        trace(residual, [Series(np.ones((3, 4)))], 3)


def test_newton_series_with_an_untraceable_residual():
    """newton_series still solves (eagerly) a residual the tracer refuses."""
    target = Series(np.array([[2.0, 0.3, -0.1, 0.05]] * 3))

    def residual(u, k):
        x = u[0]
        if isinstance(x, Series):
            x = x + 0.0 * x.truncate(k)  # not traced: eager fallback
        return [x * x - (target.truncate(k) if k > 0 else target.constant_term)]

    u, rep = newton_series(residual, [Series(np.full((3, 1), 1.5))], 3, names=("x",))
    np.testing.assert_allclose((u[0] * u[0]).coeffs, target.coeffs, atol=1e-12)


# ---------------------------------------------------------------------------- random programs

UNARY = [
    "neg",
    "sin",
    "cos",
    "exp",
    "sqrt",
    "log",
    "square",
    "reciprocal",
    "tan",
    "arctan",
    "tanh",
    "sinh",
    "cosh",
    "expm1",
    "log1p",
    "pow1.5",
    "pow3",
    "pow-2",
    "powarr",
]
BINARY = ["add", "sub", "mul", "div", "arctan2", "hypot", "pow"]
OPERAND = ["value", "data", "float", "array", "npfloat"]


def _apply_unary(name, x, nodes):
    if name == "neg":
        return -x
    if name in ("sqrt", "log"):
        return getattr(np, name)(x * x + 1.0)
    if name == "log1p":
        return np.log1p(x * x)
    if name == "pow1.5":
        return (x * x + 1.0) ** 1.5
    if name == "pow3":
        return x**3
    if name == "pow-2":
        return (x * x + 1.0) ** -2
    if name == "powarr":
        return (x * x + 1.0) ** np.linspace(0.5, 2.0, nodes)
    return getattr(np, name)(x)


def _operand(kind, x, data, nodes):
    return {"value": x, "data": data, "float": 0.7, "array": np.linspace(0.5, 1.5, nodes), "npfloat": np.float64(1.3)}[
        kind
    ]


def _apply_binary(name, a, b):
    if name == "div":
        return a / (b * b + 1.0) if isinstance(b, (Series,)) or hasattr(b, "rec") else a / (b + 2.0)
    if name == "pow":
        return (a * a + 1.0) ** (b * 0.1) if hasattr(b, "order") else (a * a + 1.0) ** 1.25
    if name == "arctan2":
        return np.arctan2(a, b)
    if name == "hypot":
        return np.hypot(a, b)
    return {"add": np.add, "sub": np.subtract, "mul": np.multiply}[name](a, b)


@st.composite
def programs(draw):
    n_ops = draw(st.integers(1, 12))
    ops = []
    for i in range(n_ops):
        if draw(st.booleans()):
            ops.append(("u", draw(st.sampled_from(UNARY)), draw(st.integers(0, i + 1))))
        else:
            left = draw(st.sampled_from(OPERAND))
            right = draw(st.sampled_from(OPERAND))
            swap = draw(st.booleans())
            ops.append(
                (
                    "b",
                    draw(st.sampled_from(BINARY)),
                    draw(st.integers(0, i + 1)),
                    draw(st.integers(0, i + 1)),
                    left,
                    right,
                    swap,
                )
            )
    return ops


def _program_residual(ops, data, nodes):
    def residual(u, k):
        vals = list(u)
        for op in ops:
            if op[0] == "u":
                vals.append(_apply_unary(op[1], vals[op[2] % len(vals)], nodes))
            else:
                _, name, i, j, left, right, swap = op
                a = _operand(left, vals[i % len(vals)], data, nodes)
                b = _operand(right, vals[j % len(vals)], data, nodes)
                if left != "value" and right != "value":
                    b = vals[j % len(vals)]
                a, b = (b, a) if swap else (a, b)
                vals.append(_apply_binary(name, a, b))
        lin = (
            Series.linear_combinations(np.array([[1.0, -0.5, 2.0], [0.25, 0.0, 1.0]]), [1.0, vals[-1], data])
            if len(vals) > 2
            else []
        )
        return [vals[-1], vals[len(vals) // 2]] + list(lin)

    return residual


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(programs(), st.integers(0, 8), st.sampled_from(["real", "complex"]), st.integers(0, 2**31))
def test_random_programs_replay_exactly(kernels, ops, k, first, seed):
    nodes = 5
    rng = np.random.default_rng(seed)
    data = Series(rng.uniform(0.5, 1.5, (nodes, k + 1)) * 0.5 ** np.arange(k + 1))
    residual = _program_residual(ops, data, nodes)

    def unknowns(kind, scale):
        base = rng.uniform(0.2, 0.8, (2, nodes, k + 1)) * scale * 0.5 ** np.arange(k + 1)
        if kind == "real":
            return [Series(base[0]), Series(base[1])]
        pert = np.broadcast_to(base, (2,) + base.shape).astype(complex)
        pert[0, 0, :, 0] += 1j * H
        pert[1, 1, :, 0] += 1j * H
        return [Series(pert[:, 0]), Series(pert[:, 1])]

    tr = TapedResidual(residual)
    with np.errstate(all="ignore"):
        for kind, scale in ((first, 1.0), ("real", 0.9), ("complex", 1.1), (first, 0.95)):
            u = unknowns(kind, scale)
            _assert_same(tr(u, k), residual(u, k))
    assert tr.reason is None, tr.reason
    assert tr.counts == {"eager": 0, "trace": 1, "replay": 3}
