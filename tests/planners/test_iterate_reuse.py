"""Reuse across generalized-flatness iterates: iterate j >= 1 starts from iterate j - 1 (Newton at the
working order from its series; its flat outputs and stage 1, truncated)."""

from __future__ import annotations

import pickle

import numpy as np

from planners.flat import NodeSolution, aircraft_system, parametrize
from planners.generalized import plan_scenario
from planners.scenario import load_scenario


def test_later_iterates_start_newton_at_the_full_order():
    """Stage 2 and 4 Newton of iterates j >= 1 run at the working order only (no pointwise iterations,
    no low doubling orders), stage 4 of iterate 0 too (affine in the controls: one Newton step and its
    check); the residual series is at rounding."""
    plan = plan_scenario(load_scenario("gtm-aileron-roll"), J=2)
    for j, it in enumerate(plan.iterates):
        for stage, rep in it.reports.items():
            warm = j >= 1 or stage == "stage4"
            assert (len(set(rep.doubling_orders)) == 1) == warm, (j, stage, rep.doubling_orders)
            assert (rep.constant_iterations == 0) == warm
            assert rep.worst_residual < 1e-10
    assert len(plan.iterates[0].reports["stage4"].doubling_orders) == 2


def _kinds(monkeypatch):
    """Record the series evaluations of newton_series by kind: "J" (with the complex-step Jacobian), "R";
    on the numpy reference path (the compiled stage programs evaluate through planners.program)."""
    import importlib

    newton = importlib.import_module("planners.newton")
    monkeypatch.setattr(importlib.import_module("planners.chained"), "compiled_programs", lambda: False)
    log = []
    rj, ro = newton._residual_and_jacobian, newton._residual_only

    def with_jacobian(residual, stacked, k):
        log.append(("J", stacked.shape[0], k))
        return rj(residual, stacked, k)

    def residual_only(residual, stacked, k):
        log.append(("R", stacked.shape[0], k))
        return ro(residual, stacked, k)

    monkeypatch.setattr(newton, "_residual_and_jacobian", with_jacobian)
    monkeypatch.setattr(newton, "_residual_only", residual_only)
    return log


def test_later_iterates_reuse_the_previous_jacobian(monkeypatch):
    """Iterates j >= 3 of the bundled roll take no complex-step Jacobian on series: chord steps on the
    previous iterate's Jacobian series (its constant term renewed pointwise) reach the tolerance; the
    plan is the one of fresh Jacobians within the Newton tolerance."""
    import importlib

    chained = importlib.import_module("planners.chained")
    log = _kinds(monkeypatch)
    original = chained.flat_parametrization

    def marked(*args, **kw):
        log.append(("iterate",))
        return original(*args, **kw)

    monkeypatch.setattr(chained, "flat_parametrization", marked)
    plan = plan_scenario(load_scenario("gtm-aileron-roll"))
    starts = [i for i, e in enumerate(log) if e == ("iterate",)]
    assert len(starts) == plan.J + 1 == 8
    late = log[starts[3] :]
    assert [e for e in late if e[0] == "R"] and not [e for e in late if e[0] == "J"], late
    for it in plan.iterates[1:]:
        for rep in it.reports.values():
            assert rep.jacobian is not None and rep.worst_residual < 1e-10
    assert pickle.loads(pickle.dumps(plan.iterates[-1].reports["stage2"])).jacobian is None


def test_previous_iterate_lends_its_flat_outputs_bitwise():
    """A NodeSolution as the guess gives the same iterate as its series and Newton reports alone (the
    flat outputs and stage 1 truncated from the higher order are the ones computed at the lower order), and its
    borrowed inputs are not pickled."""
    sc = load_scenario("twin-otter-single-engine")
    problem, t = sc.problem(), sc.t_nodes
    first = parametrize(problem, t, 12)
    h = first.h_values()
    a = parametrize(problem, t, 10, h=h, guess=first)
    b = parametrize(problem, t, 10, h=h, guess=NodeSolution(dict(first.series), first.order, first.reports))
    for name, s in a.series.items():
        np.testing.assert_array_equal(np.asarray(s.coeffs), np.asarray(b[name].coeffs), err_msg=name)
    assert a._inputs is first._inputs and b._inputs["order"] == 10
    assert pickle.loads(pickle.dumps(a))._inputs is None


def test_inputs_of_another_problem_are_not_borrowed():
    sc = load_scenario("twin-otter-single-engine")
    other = load_scenario("twin-otter-single-engine").problem()
    first = parametrize(sc.problem(), sc.t_nodes, 10)
    sol = parametrize(other, sc.t_nodes, 8, h=first.h_values(), guess=first)
    assert sol._inputs is not first._inputs and sol._inputs["system"] is aircraft_system(other)
