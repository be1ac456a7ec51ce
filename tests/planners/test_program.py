"""The compiled planning layer (planners.program) against the numpy reference: every traced operation's
series and tangent (property tests over random series), the stage residuals and Jacobians of the paper
scenarios, and whole plans, to 1e-12 of the coefficient scale."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planners.chained as C
from planners.newton import ResidualEvaluator
from planners.program import StageEvaluator, TraceError, trace
from planners.series import Series

pytest.importorskip("numba")

SET = settings(max_examples=25, deadline=None)
TOL = 1e-12


def rand_series(rng, order, nodes, c0=(-1.0, 1.0)):
    c = rng.uniform(-1, 1, (order + 1, nodes)) * 0.5 ** np.arange(order + 1)[:, None]
    c[0] = rng.uniform(*c0, nodes)
    return Series._wrap(c)


def close(ref, new, tol=TOL):
    ref, new = np.asarray(ref), np.asarray(new)
    assert ref.shape == new.shape, (ref.shape, new.shape)
    scale = max(1.0, float(np.max(np.abs(ref))))
    assert np.max(np.abs(new - ref)) <= tol * scale, np.max(np.abs(new - ref)) / scale


def _lincomb(w, items):
    """As the aerodynamic model: the series class's linear_combinations, plain sums on arrays (order 0)."""
    lin = next((type(x) for x in items if hasattr(type(x), "linear_combinations")), None)
    if lin is not None:
        return lin.linear_combinations(w, items)
    return [sum(wi * x for wi, x in zip(row, items)) for row in w]


# Each function of two unknowns (a, b) and one datum d, written with plain arithmetic as the model is.
FUNCTIONS = {
    "add-sub": lambda a, b, d: [a + b - d + 2.5, 3.0 - a, b - 1.5],
    "mul-div": lambda a, b, d: [a * b, a / (b + 3.0), d / (a + 3.0), 2.0 / (b + 3.0)],
    "scale": lambda a, b, d: [a * 0.7 / 3.0, -b, +a],
    "sqrt-exp-log": lambda a, b, d: [np.sqrt(a + 3.0), np.exp(b), np.log(a + 3.0), (a + 3.0) ** 0.5],
    "trig": lambda a, b, d: [np.sin(a), np.cos(b) * np.sin(b), np.tan(a * 0.5), np.arctan(b * d)],
    "hyperbolic": lambda a, b, d: [np.sinh(a), np.cosh(b)],
    "powers": lambda a, b, d: [(a + 3.0) ** 1.7, a**2, (b + 3.0) ** -2, a**3 * d],
    "lincomb": lambda a, b, d: _lincomb(np.array([[1.0, 0.5, -2.0], [0.0, 3.0, 1.0]]), [a, a * b * d, 1.0]),
}


@SET
@given(
    name=st.sampled_from(sorted(FUNCTIONS)),
    order=st.integers(0, 18),
    nodes=st.integers(1, 6),
    seed=st.integers(0, 10**6),
)
def test_operations_and_tangents_agree_with_numpy(name, order, nodes, seed):
    """Residual series and Jacobian series of each operation: compiled program = numpy Series (complex step)."""
    fun = FUNCTIONS[name]
    rng = np.random.default_rng(seed)
    a, b, d = (rand_series(rng, order, nodes) for _ in range(3))

    def residual(v):
        return fun(v["a"], v["b"], v["d"])

    prog, reason = trace(residual, ("a", "b"), {"d": d}, {"d"})
    assert prog is not None, reason
    ev = StageEvaluator(prog, {"d": d}, nodes)
    ref = ResidualEvaluator(lambda us, k: fun(us[0], us[1], d.truncate(k) if k else d.constant_term))
    stacked = np.stack([a.coeffs, b.coeffs])  # (2, nodes, K)
    G, J = ev.residual_and_jacobian(stacked, order)
    Gr, Jr = ref.residual_and_jacobian(stacked, order)
    close(Gr, G)
    close(Jr, J)
    close(Gr, ev.residual_only(stacked, order))
    x0 = stacked[..., 0]
    close(ref.const_fun(x0), ev.const_fun(x0))
    close(ref.const_jacobian(x0), ev.const_jacobian(x0))


def test_reading_a_value_that_depends_on_the_unknowns_is_refused():
    """A branch on the unknowns cannot be recorded: no program, the reason said (the stage runs on numpy)."""
    d = Series._wrap(np.ones((3, 2)))

    def residual(v):
        return [v["a"] * 2.0 if np.all(v["a"].constant_term > 0) else v["a"]]

    prog, reason = trace(residual, ("a",), {"d": d}, {"d"})
    assert prog is None and "depends on the unknowns" in reason
    with pytest.raises(TraceError):
        bool(trace.__globals__["Sym"](trace.__globals__["_Recorder"]([]), 0))


def test_a_static_value_may_be_read():
    """The constant term of static data decides a branch (the ISA layer): recorded as a decision."""
    z = Series._wrap(np.array([[-1000.0, -12000.0], [1.0, 1.0]]))

    def residual(v):
        h0 = (-v["z"]).constant_term
        return [v["a"] * (-v["z"]) if np.all(h0 < 11000) else v["a"] - v["z"]]

    prog, reason = trace(residual, ("a",), {"z": z}, {"z"})
    assert prog is not None, reason
    prog, reason = trace(residual, ("a",), {"z": z}, set())  # z changes between calls: refused
    assert prog is None


def _programs(problem, t_nodes):
    """The stages' programs of one flat parametrization of ``problem`` (order 8)."""
    from planners.flat import aircraft_system

    captured = {}
    orig = C._stage_evaluator

    def spy(programs, h, *args):
        out = orig(programs, h, *args)
        captured[h] = programs[h][0]
        return out

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(C, "_stage_evaluator", spy)
        mp.setattr(C, "compiled_programs", lambda: True)
        C.flat_parametrization(aircraft_system(problem), t_nodes, 8)
    return captured


def test_one_program_serves_aircraft_of_the_same_structure():
    """The instruction table does not hold the aircraft's numbers: a heavier GTM on the roll gives the same
    tables with other parameters; the roll and the forward slip (same GTM, another flight and fourth flat
    output) share the table of stage 4."""
    from dataclasses import replace

    from planners.scenario import load_scenario

    roll = load_scenario("gtm-aileron-roll")
    prob = roll.problem()
    ac = prob.aircraft
    heavy = replace(prob, aircraft=replace(ac, mass=replace(ac.mass, mass=1.2 * ac.mass.mass)))
    slip = load_scenario("gtm-forward-slip")
    a, b, c = _programs(prob, roll.t_nodes), _programs(heavy, roll.t_nodes), _programs(slip.problem(), slip.t_nodes)
    for h in (2, 4):
        assert a[h] is not None and b[h] is not None
        assert a[h].structure_key == b[h].structure_key and np.array_equal(a[h].code, b[h].code)
    assert not np.array_equal(a[2].params, b[2].params)  # the mass is a parameter of the force equations
    assert c[4].structure_key == a[4].structure_key
    assert c[2].structure_key != a[2].structure_key  # the fourth flat output is part of the structure


def _plan(name, compiled, J=None):
    from planners.generalized import plan_motion
    from planners.scenario import load_scenario

    sc = load_scenario(name)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(C, "compiled_programs", lambda: compiled)
        return plan_motion(sc.problem(), sc.t_nodes, sc.J if J is None else J, e=getattr(sc, "e", 1), name=name)


@pytest.mark.parametrize("name", ["gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip"])
def test_whole_plans_agree_with_the_numpy_path(name):
    """Every series of every iterate of the bundled paper plans: compiled programs = numpy path to 1e-12
    of each variable's coefficient scale (or 1e-12 absolute for a variable that is zero, as beta = 0)."""
    ref, new = _plan(name, False), _plan(name, True)
    assert len(ref.iterates) == len(new.iterates)
    for it_r, it_n in zip(ref.iterates, new.iterates):
        assert set(it_r) == set(it_n)
        for var in it_r:
            close(np.real(it_r[var].coeffs), np.real(it_n[var].coeffs))
    assert ref.feasible == new.feasible
