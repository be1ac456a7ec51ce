"""The work around the stage-residual evaluations, done once or on the series kernels: the same numbers.

Stage 3 on the kernels (independent products in one call) against the operators of the Series class,
the flight-path terms computed once and truncated against computing them at each order, the domain
test of all iterates at once against iterate by iterate, the envelope's columns against the whole table,
and the series linear combinations with broadcast batches against their explicit sums.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gna.simulate import ENVELOPE_VARIABLES
from planners.flat import _path_terms, _stage3, _stage3_series, stage3
from planners.generalized import domain_failures
from planners.series import Series


@pytest.mark.parametrize("j", [0, -1])
def test_stage3_on_kernels_is_bitwise_the_series_operators(weave_plan, j):
    _, plan = weave_plan
    s = plan.iterates[j].series
    k = s["alpha"].order
    gamma, chi = s["gamma"].truncate(k), s["chi"].truncate(k)
    path = _path_terms(gamma, chi)
    fast = _stage3(s["alpha"], s["beta"], s["mu"], path)
    ref = _stage3_series(s["alpha"], s["beta"], s["mu"], *(path[n] for n in ("gd", "chid_cg", "chid_sg")))
    for a, b in zip(fast, ref):
        assert a.order == b.order == k - 1
        assert np.array_equal(a.coeffs, b.coeffs)
    # the public function, and the path terms of a higher order truncated: the same coefficients
    top = plan.iterates[0].series
    K = top["alpha"].order
    high = _path_terms(top["gamma"].truncate(K), top["chi"].truncate(K))
    for a, b in zip(_stage3(s["alpha"], s["beta"], s["mu"], high), stage3(s["alpha"], s["beta"], s["mu"], gamma, chi)):
        assert np.array_equal(a.coeffs, b.coeffs)


def test_stage3_complex_series_take_the_series_operators(weave_plan):
    _, plan = weave_plan
    s = plan.iterates[-1].series
    k = s["alpha"].order
    a, b, m = (s[n].astype(complex) for n in ("alpha", "beta", "mu"))
    out = stage3(a, b, m, s["gamma"].truncate(k), s["chi"].truncate(k))
    ref = stage3(s["alpha"], s["beta"], s["mu"], s["gamma"].truncate(k), s["chi"].truncate(k))
    for x, y in zip(out, ref):
        assert x.dtype.kind == "c"
        assert np.allclose(np.real(x.coeffs), y.coeffs, rtol=1e-13, atol=1e-15)


def test_domain_failures_name_each_failed_iterate(weave_plan):
    from dataclasses import replace

    _, plan = weave_plan
    assert domain_failures(plan) == []
    bad = replace(plan, iterates=list(plan.iterates))
    sol = plan.iterates[1]
    series = dict(sol.series)
    c = np.array(series["V"].coeffs)
    c[3, 0] = -1.0  # a negative airspeed at the fourth node
    series["V"] = Series(c)
    bad.iterates[1] = replace(sol, series=series)
    out = domain_failures(bad)
    assert len(out) == 1 and out[0].startswith("iterate j = 1: ")
    assert f"t = {plan.t_nodes[3]:g}" in out[0]


def test_envelope_columns_are_those_of_the_whole_table(weave_plan):
    _, plan = weave_plan
    step = float(np.min(np.diff(plan.t_nodes))) / 8
    part = plan.to_dataframe(step=step, variables=ENVELOPE_VARIABLES)
    whole = plan.to_dataframe(step=step)
    assert list(part.columns) == list(ENVELOPE_VARIABLES)
    assert np.array_equal(part.to_numpy(), whole[list(ENVELOPE_VARIABLES)].to_numpy())
    assert np.array_equal(part.index.to_numpy(), whole.index.to_numpy())


def test_linear_combinations_broadcast_batches_and_constants():
    rng = np.random.default_rng(3)
    a = Series(rng.normal(size=(3, 5, 4)) + 1j * rng.normal(size=(3, 5, 4)))  # batch (3, 5), order 3
    b = Series(rng.normal(size=(5, 6)))  # batch (5,), order 5
    w = rng.normal(size=(2, 4))
    out = Series.linear_combinations(w, [a, b, 2.0, np.arange(5.0)])
    for i in range(2):
        ref = w[i, 0] * a + w[i, 1] * b.truncate(3) + (w[i, 2] * 2.0 + w[i, 3] * np.arange(5.0))
        assert out[i].batch_shape == (3, 5) and out[i].order == 3
        assert np.allclose(out[i].coeffs, ref.coeffs, rtol=1e-14, atol=1e-14)
    with pytest.raises(TypeError):
        Series.linear_combinations(w, [1.0, 2.0, 3.0, 4.0])


@pytest.mark.parametrize("which", ["weave", "twin-otter-single-engine"])
def test_limits_are_built_once_per_aircraft_and_checked_as_on_arrays(weave_plan, which):
    """aircraft_limits is kept per aircraft object; limit_violations with constant bounds compared as numbers
    and the engines' rating computed once gives the records of the bounds as arrays (Limit.bounds), on a
    frame leaving several limits (the Twin Otter: two engines with a power rating)."""
    from dataclasses import replace

    from gna.limits import TrajectoryColumns, aircraft_limits, limit_violations

    if which == "weave":
        _, plan = weave_plan
    else:
        from planners.generalized import plan_scenario
        from planners.scenario import load_scenario

        plan = plan_scenario(load_scenario(which), J=1)
    ac = plan.aircraft
    assert aircraft_limits(ac) is aircraft_limits(ac)
    other = replace(ac)
    assert aircraft_limits(other) is not aircraft_limits(ac) and aircraft_limits(other) == aircraft_limits(ac)
    t, cols, vals = plan._limit_arrays(-1, None)
    vals = vals.copy()
    vals[:, ::7] *= 3.0  # well outside: alpha, beta and the surfaces on both sides
    vals[:, 5::11] *= -3.0
    frame = TrajectoryColumns(t, cols, vals)
    got = limit_violations(ac, frame, plan.env)
    assert got
    dt = np.diff(t, append=t[-1])
    ref = []
    for lim in aircraft_limits(ac):
        if not set(lim.columns) <= set(cols):
            continue
        v = lim.value_of(frame, plan.env)
        lo, hi = lim.bounds(frame)
        for side, excess, bound in (("lower", lo - v, lo), ("upper", v - hi, hi)):
            over = excess > 0
            if over.any():
                i = int(np.argmax(np.where(over, excess, -np.inf)))
                ref.append((lim.name, side, float(bound[i]), float(v[i]), float(t[i]), float(np.sum(dt[over]))))
    assert [(g.name, g.side, g.limit, g.worst, g.time) for g in got] == [r[:5] for r in ref]
    span = float(t[-1] - t[0])
    assert [g.fraction for g in got] == [r[5] / span for r in ref]


@settings(max_examples=40, deadline=None)
@given(
    K=st.integers(0, 23),
    n=st.integers(1, 40),
    v=st.integers(1, 8),
    interpolation=st.sampled_from(["hermite", "paper"]),
    seed=st.integers(0, 10**6),
)
def test_interval_polynomials_stacked_along_the_intervals_are_each_variables_own(K, n, v, interpolation, seed):
    """Plan._coefficients evaluates the formula once per order with the variables one after the other along the
    interval axis: each variable's polynomials are bit for bit those of a call of its own."""
    from planners.plan import interval_coefficients

    rng = np.random.default_rng(seed)
    c = rng.normal(size=(n + 1, v, K + 1)) * 10.0 ** rng.integers(-3, 4, size=(n + 1, v, K + 1))
    h = rng.uniform(0.05, 8.0, n)
    a = np.concatenate([c[:-1, i : i + 1] for i in range(v)])
    b = np.concatenate([c[1:, i : i + 1] for i in range(v)])
    stacked = interval_coefficients(a, b, np.tile(h, v), interpolation)
    for i in range(v):
        own = interval_coefficients(c[:-1, i : i + 1], c[1:, i : i + 1], h, interpolation)
        assert np.array_equal(own, stacked[i * n : (i + 1) * n])
