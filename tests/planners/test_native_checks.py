"""A plan's limit check in native code (planners/_program.c: ``gf_grid_horner``, ``gf_limit_scan``) against the
numpy definitions (:func:`planners.plan._horner`, :func:`gna.limits.scan_sides`), bit for bit, and the static
part of a first iterate kept with its system (:func:`planners.chained._static_part`): the same series, never
another problem's, grid's or order's."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planners._native as NA
import planners.chained as C
from gna.limits import TrajectoryColumns, aircraft_limits, limit_violations, scan_sides

if NA.library(wait=True) is None:  # pragma: no cover - a machine without a C compiler
    pytest.skip(f"native evaluator unavailable: {NA.reason()}", allow_module_level=True)

SET = settings(max_examples=40, deadline=None)


@SET
@given(
    nodes=st.integers(2, 12),
    v=st.integers(1, 5),
    d1=st.integers(1, 14),
    pad=st.integers(0, 4),
    N=st.integers(0, 400),
    sort=st.booleans(),
    seed=st.integers(0, 10**6),
)
def test_the_grid_horner_is_the_plans_evaluation_bit_for_bit(nodes, v, d1, pad, N, sort, seed):
    """Each time in its interval (numpy's searchsorted and clip, times before, after and on the nodes) at its offset,
    by Horner's rule: planners.plan._horner's values exactly; with ``pad``, those of the zero-padded polynomials
    (zero coefficients among the others included)."""
    from planners.plan import _horner

    rng = np.random.default_rng(seed)
    tn = np.cumsum(rng.uniform(0.1, 2.0, nodes)) - 1.0
    c = rng.normal(size=(nodes - 1, v, d1)) * 10.0 ** rng.integers(-3, 4, size=(nodes - 1, v, d1))
    c[rng.uniform(size=c.shape) < 0.2] = 0.0
    c[rng.uniform(size=c.shape) < 0.1] = -0.0
    t = rng.uniform(tn[0] - 0.5, tn[-1] + 0.5, N)
    if N:
        t[: min(N, nodes)] = tn[: min(N, nodes)]  # on the nodes: the right-hand interval
    if sort:
        t = np.sort(t)
    i = np.clip(np.searchsorted(tn, t, side="right") - 1, 0, nodes - 2)
    out = np.empty((v, N))
    assert NA.grid_horner(c, tn, t, out, pad=bool(pad))
    cp = np.concatenate([c, np.zeros(c.shape[:2] + (pad,))], axis=2) if pad else c
    ref = _horner(cp[i], t - tn[i], 0)
    assert np.array_equal(out, ref)
    assert np.array_equal(np.signbit(out), np.signbit(ref))  # the zeros' signs too
    # rows of a larger block (how the plan writes its states and controls)
    block = np.full((v + 2, N), np.nan)
    assert NA.grid_horner(c, tn, t, block[1 : v + 1], pad=bool(pad))
    assert np.array_equal(block[1 : v + 1], ref) and np.all(np.isnan(block[[0, -1]]))


def _sides(rng, N, kinds):
    """Sides in pairs (lower, upper) of quantities with NaN, infinities, ties and excursions where asked."""
    sides = []
    for where, lo, hi in kinds:
        v = rng.uniform(-1.0, 1.0, N)
        if N < 4 and where in ("start", "end", "middle"):
            where = "none"  # the excursions need a few rows
        if where == "start":
            v[:3] = [2.0, 2.0, -2.0]
        elif where == "end":
            v[-2:] = [-3.0, 3.0]
        elif where == "middle":
            v[N // 3 : N // 2] = 1.5
            v[N // 2] = -1.5
        elif where == "nan":
            v[::5] = np.nan
        elif where == "inf":
            v[N // 4] = np.inf
            v[N // 2] = -np.inf
        elif where == "all-nan":
            v[:] = np.nan
        if hi == "array":
            hi = rng.uniform(0.9, 1.2, N)
            hi[N // 3] = np.inf
            hi[N // 5] = np.nan
        sides += [(None, "lower", v, lo), (None, "upper", v, hi)]
    return sides


CASES = [
    [("none", -1.0, 1.0)],
    [("start", -1.0, 1.0)],
    [("end", -1.0, 1.0), ("middle", -1.2, 1.2)],
    [("middle", -np.inf, np.inf), ("nan", -0.5, np.nan)],
    [("inf", -1.0, 1.0), ("all-nan", -1.0, 1.0)],
    [("middle", 0.0, "array"), ("end", -np.inf, "array"), ("nan", 0.9, "array")],
    [("none", np.inf, -np.inf), ("start", -2.0, 2.0)],  # every row beyond; on the bounds exactly: not beyond
]


@pytest.mark.parametrize("kinds", CASES)
@pytest.mark.parametrize("N", [1, 2, 7, 8, 9, 64, 6001])
def test_the_native_limit_scan_is_scan_sides(kinds, N):
    """Per side: the row of the largest excess (the first of equal ones), the first and the last row beyond the
    bound, or None: the numpy definition's, on excursions at the ends, in the middle, with NaN and infinite
    values, unbounded and NaN bounds, varying bounds."""
    rng = np.random.default_rng(N)
    sides = _sides(rng, N, kinds)
    t = np.linspace(0.0, 1.0, N)
    assert NA.limit_scan(t, sides) == scan_sides(t, sides)


@pytest.mark.parametrize("which", ["twin-otter-single-engine", "gtm-aileron-roll"])
def test_the_plans_violations_are_the_numpy_paths(which):
    """Plan.limit_violations (the native scan) = gna.limits.limit_violations on the numpy path, record for record,
    on the plan's own grid (the Twin Otter's engine above its rating) and on a grid pushed beyond every limit."""
    from planners.generalized import plan_scenario
    from planners.scenario import load_scenario

    plan = plan_scenario(load_scenario(which), J=1)
    ac = plan.aircraft
    t, cols, vals = plan._limit_arrays(-1, None)
    ref = limit_violations(ac, TrajectoryColumns(t, cols, vals), plan.env)
    assert plan.limit_violations() == ref
    for scale in (3.0, -3.0, 1.0001):
        pushed = vals.copy()
        pushed[:, ::7] *= scale
        pushed[:, -1] *= -scale
        pushed[:, 0] *= scale
        frame = TrajectoryColumns(t, cols, pushed)
        ref = limit_violations(ac, frame, plan.env)
        assert ref
        new = limit_violations(ac, frame, plan.env, NA.limit_scan)
        assert [v.to_dict() for v in new] == [v.to_dict() for v in ref]
        assert [v.source for v in new] == [v.source for v in ref]
    assert aircraft_limits(ac)  # the limits themselves untouched


def test_the_limit_grid_on_the_native_horner_is_the_padded_evaluation():
    """The plan's limit grid: states and controls each at their own degree natively = the zero-padded block of
    the numpy evaluation, bit for bit."""
    from planners.generalized import plan_scenario
    from planners.plan import _horner
    from planners.scenario import load_scenario

    plan = plan_scenario(load_scenario("twin-otter-single-engine"), J=2)
    t, cols, vals = plan._limit_arrays(-1, None)
    c = plan._coefficients(tuple(cols), -1)
    tn = plan.t_nodes
    i = np.clip(np.searchsorted(tn, t, side="right") - 1, 0, len(tn) - 2)
    ref = _horner(c[i], t - tn[i], 0)
    assert np.array_equal(vals, ref) and np.array_equal(np.signbit(vals), np.signbit(ref))


def test_the_static_part_is_kept_per_system_grid_and_order():
    """A second plan of a problem takes its first iterate's flat outputs, stage 1 and derived series (and the
    stage-2 starting values) from the first plan's, bit for bit; another grid, order or problem computes its own."""
    from planners.generalized import plan_motion
    from planners.scenario import load_scenario

    sc = load_scenario("twin-otter-single-engine")
    prob = sc.problem()
    computed = []
    solve = C._solve_stage

    def counted(*a, **k):
        computed.append(a[1])
        return solve(*a, **k)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(C, "_solve_stage", counted)
        a = plan_motion(prob, sc.t_nodes, 2, e=1)
        n_first = computed.count(1)
        b = plan_motion(prob, sc.t_nodes, 2, e=1)
        assert computed.count(1) == n_first  # stage 1 not again
        c = plan_motion(prob, sc.t_nodes, 2, e=1)
        plan_motion(prob, sc.t_nodes, 3, e=1)  # another order: its own
        assert computed.count(1) == n_first + 1
        plan_motion(prob, sc.t_nodes[:-1], 2, e=1)  # another grid
        assert computed.count(1) == n_first + 2
    for x, y in ((a, b), (a, c)):
        for it_x, it_y in zip(x.iterates, y.iterates):
            assert list(it_x) == list(it_y)
            for var in it_x:
                assert np.array_equal(it_x[var].coeffs, it_y[var].coeffs), var
        assert x.warnings == y.warnings
    # the kept series are read-only and shared; each plan has its own inputs (its native buffers)
    s0, s1 = a.iterates[0], c.iterates[0]
    assert s0._inputs is not s1._inputs
    assert s0["V"] is s1["V"] and not s0["V"]._c.flags.writeable
    starts = s1._inputs["starts"]  # the stage-2 starting values: made by the second plan, read by the third
    assert starts is s0._inputs["starts"] and set(starts) == {2}
    assert all(not x.flags.writeable for x in starts[2])


def test_a_changed_problem_never_reads_another_problems_static_part():
    """The bounded planner's members are new problems (new systems): their first iterates are their own."""
    from dataclasses import replace

    from planners.flat import aircraft_system
    from planners.generalized import plan_motion
    from planners.scenario import load_scenario

    sc = load_scenario("gtm-aileron-roll")
    prob = sc.problem()
    plan_motion(prob, sc.t_nodes, 1, e=1)
    plan_motion(prob, sc.t_nodes, 1, e=1)
    heavier = replace(
        prob, aircraft=replace(prob.aircraft, mass=replace(prob.aircraft.mass, mass=prob.aircraft.mass.mass * 1.1))
    )
    assert aircraft_system(heavier) is not aircraft_system(prob)
    assert not aircraft_system(heavier).__dict__.get("_static_parts")
    p1 = plan_motion(heavier, sc.t_nodes, 1, e=1)
    fresh = replace(heavier)  # the same numbers in a new problem: the same plan, computed again
    p2 = plan_motion(fresh, sc.t_nodes, 1, e=1)
    for var in p1.iterates[-1]:
        assert np.array_equal(p1.iterates[-1][var].coeffs, p2.iterates[-1][var].coeffs)
    ref = plan_motion(prob, sc.t_nodes, 1, e=1)
    assert not np.array_equal(ref.iterates[-1]["F"].coeffs, p1.iterates[-1]["F"].coeffs)


def test_another_backend_in_the_same_process_computes_its_own_static_part():
    """The numpy reference switched on within a process (the collocation benchmark's: the series kernels and the
    compiled programs off) after native plans of the same problem: the plan of a fresh problem on that path, bit
    for bit (nothing kept by the native plans is read)."""
    import planners.series as S
    from planners.generalized import plan_motion
    from planners.scenario import load_scenario

    sc = load_scenario("twin-otter-single-engine")
    prob = sc.problem()
    plan_motion(prob, sc.t_nodes, 1, e=1)
    plan_motion(prob, sc.t_nodes, 1, e=1)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(S, "_K", S._NumpyKernels)
        mp.setattr(C, "compiled_programs", lambda: False)
        got = plan_motion(prob, sc.t_nodes, 1, e=1)
        ref = plan_motion(
            sc.problem().__class__(**{k: getattr(prob, k) for k in prob.__dataclass_fields__}), sc.t_nodes, 1, e=1
        )
    for it_g, it_r in zip(got.iterates, ref.iterates):
        for var in it_r:
            assert np.array_equal(it_g[var].coeffs, it_r[var].coeffs), var
