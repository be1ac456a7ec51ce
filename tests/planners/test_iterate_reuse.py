"""Reuse across generalized-flatness iterates: iterate j >= 1 starts from iterate j - 1 (Newton at the
working order from its series; its flat outputs and stage 1, truncated)."""

from __future__ import annotations

import pickle

import numpy as np

from planners.flat import parametrize
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
        assert len(it.reports["stage4"].doubling_orders) == 2


def test_previous_iterate_lends_its_flat_outputs_bitwise():
    """A NodeSolution as the guess gives the same iterate as its series alone (the flat outputs and
    stage 1 truncated from the higher order are the ones computed at the lower order), and its
    borrowed inputs are not pickled."""
    sc = load_scenario("twin-otter-single-engine")
    problem, t = sc.problem(), sc.t_nodes
    first = parametrize(problem, t, 12)
    h = first.h_values()
    a = parametrize(problem, t, 10, h=h, guess=first)
    b = parametrize(problem, t, 10, h=h, guess=dict(first.series))
    for name, s in a.series.items():
        np.testing.assert_array_equal(np.asarray(s.coeffs), np.asarray(b[name].coeffs), err_msg=name)
    assert a._inputs is first._inputs and b._inputs["order"] == 10
    assert pickle.loads(pickle.dumps(a))._inputs is None


def test_inputs_of_another_problem_are_not_borrowed():
    sc = load_scenario("twin-otter-single-engine")
    other = load_scenario("twin-otter-single-engine").problem()
    first = parametrize(sc.problem(), sc.t_nodes, 10)
    sol = parametrize(other, sc.t_nodes, 8, h=first.h_values(), guess=first)
    assert sol._inputs is not first._inputs and sol._inputs["problem"] is other
