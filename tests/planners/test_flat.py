"""Flat parametrization: every flat output choice satisfies the simple model's equations (issue 4, test 8a)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gna.aircraft import Propulsion
from gna.eom import STATE_NAMES, Controls, HValues, State, derivatives
from planners.expressions import compile_expression
from planners.flat import FlatOutput, FlatProblem, parametrize
from planners.generalized import plan_motion

from .conftest import make_scenario

CASES = {
    "beta": {"zeta": "beta", "zeta_value": "0.02*sin(t/5)"},
    "mu": {"zeta": "mu", "zeta_value": "0.1*sin(t/10)"},
    # a steady turn: thrust above the coordinated-turn need, balanced by sideslip drag on one side
    "F": {"zeta": "F", "zeta_value": "14500 + 300*sin(t/8)", "x": "3000*sin(0.05*t)", "y": "3000*(1 - cos(0.05*t))"},
    "mix": {"zeta": "mix", "zeta_value": "0.01", "f1": "1", "f2": "0.5 + 0.1*sin(t/7)"},
}

#: Tolerance of test 8(a): the simple model's 12 equations at the nodes.
TOL = 1e-8


def _scaled_residual(plan, j):
    """Residual of each equation divided by the magnitude of that state's derivative along the plan (floor 1)."""
    r = plan.equation_residuals("simple", j=j)
    d = plan.node_derivatives(j)
    return {n: float(np.max(np.abs(r[n])) / max(1.0, float(np.max(np.abs(getattr(d, n)))))) for n in STATE_NAMES}


@pytest.mark.parametrize("kind", list(CASES))
def test_simple_model_equations_hold_at_nodes(kind):
    sc = make_scenario(flat_outputs=CASES[kind], generalized={"J": 1})
    plan = plan_motion(sc.problem(), sc.t_nodes, J=1)
    for j in (0, 1):
        res = _scaled_residual(plan, j)
        assert max(res.values()) <= TOL, (kind, j, res)
    # the fourth flat output is what was asked
    st, ct = plan.node_values(0)
    t = plan.t_nodes
    if kind == "beta":
        np.testing.assert_allclose(st.beta, 0.02 * np.sin(t / 5), atol=1e-12)
    elif kind == "mu":
        np.testing.assert_allclose(st.mu, 0.1 * np.sin(t / 10), atol=1e-12)
    elif kind == "F":
        np.testing.assert_allclose(ct.F, 14500 + 300 * np.sin(t / 8), rtol=1e-12)
    else:
        np.testing.assert_allclose(st.beta + (0.5 + 0.1 * np.sin(t / 7)) * st.mu, 0.01, atol=1e-12)
    assert plan.worst_newton_residual() < 1e-9


def test_series_orders_follow_the_stages():
    sc = make_scenario()
    sol = parametrize(sc.problem(), sc.t_nodes, 9)
    expected = {"x": 9, "V": 8, "alpha": 7, "F": 7, "p": 6, "dl": 5, "dm": 5, "dn": 5}
    assert {k: sol[k].order for k in expected} == expected


def test_series_satisfy_equations_beyond_the_nodes():
    """The truncated series satisfy the equations as series: check at t_i + 0.1 s through Horner evaluation."""
    sc = make_scenario()
    prob = sc.problem()
    sol = parametrize(prob, sc.t_nodes, 9)
    dt = 0.1
    vals = {k: np.real(v.eval(dt)) for k, v in sol.series.items()}
    ders = {k: np.real(v.derivative().eval(dt)) for k, v in sol.series.items()}
    s = State(*(vals[n] for n in STATE_NAMES))
    u = Controls(vals["F"], vals["eta"], vals["dl"], vals["dm"], vals["dn"])
    f = derivatives(prob.aircraft, prob.env, s, u, "simple", HValues())
    for n, fn in zip(STATE_NAMES, f):
        scale = max(1.0, float(np.max(np.abs(ders[n]))))
        # truncation error O(dt^(order of the controls + 1)) ~ 1e-5 at dt = 0.1
        assert np.max(np.abs(ders[n] - fn)) / scale < 1e-4, n


def test_rudder_failure_eta_as_control():
    """With the rudder fixed, differential thrust eta is the fourth control (paper: deltan=0, eta=u_4)."""
    sc = make_scenario()
    twin = dataclasses.replace(sc.aircraft, propulsion=Propulsion(count=2, y_p=1.5))
    prob = FlatProblem(
        twin,
        sc.env,
        sc.x,
        sc.y,
        sc.z,
        FlatOutput("beta", compile_expression(0.0)),
        eta=None,
        dn=compile_expression(0.0),
    )
    plan = plan_motion(prob, sc.t_nodes, J=1)
    st, ct = plan.node_values(1)
    np.testing.assert_array_equal(ct.dn, 0.0)
    assert np.max(np.abs(ct.eta)) > 1e-4  # the weave needs yaw moment from the engines
    r = plan.equation_residuals("simple", j=0)
    assert float(r.abs().max().max()) < 1e-7


def test_problem_validation():
    sc = make_scenario()
    from gna.errors import InputError

    with pytest.raises(InputError, match="either eta"):
        FlatProblem(sc.aircraft, sc.env, sc.x, sc.y, sc.z, sc.zeta, eta=None, dn=None)
    with pytest.raises(InputError, match="order >= 4"):
        parametrize(sc.problem(), sc.t_nodes, 3)
    with pytest.raises(InputError, match="flat output must be"):
        FlatOutput("alpha", compile_expression(0.0))


def test_bank_angle_continuous_in_inverted_flight():
    """Near mu = pi the node values stay on one branch, so the plan between nodes is the inverted attitude."""
    sc = make_scenario(
        flat_outputs={"x": "150*t", "y": "3*sin(2*t)", "z": "-3000 + 0.75*g0*t**2"}, time={"t1": 4.0, "step": 0.25}
    )
    plan = plan_motion(sc.problem(), sc.t_nodes, J=0)
    st, _ = plan.node_values(0)
    assert np.all(np.abs(np.diff(st.mu)) < 2.0), st.mu  # no 2 pi jumps between neighbouring nodes
    assert np.max(np.abs(st.mu)) > 2.0  # inverted: the lift points up only with |mu| > pi/2
    tn = plan.t_nodes
    mid = 0.5 * (tn[:-1] + tn[1:])
    between = plan.evaluate("mu", mid, j=0)
    left = np.array([np.real(plan.iterates[0]["mu"][i].eval(mid[i] - tn[i])) for i in range(len(mid))])
    # the blend agrees with each node's own Taylor series (it did not before: they differed by ~pi)
    np.testing.assert_array_less(np.abs(between - left), 0.3)


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"zeta_value": "log(t - 20)"}, r"zeta\(t\) or its derivative is not finite at t = 0 s"),
        ({"z": "-3000 + log(t - 5)"}, r"z\(t\) or its derivative is not finite at t = 0 s"),
        ({"x": "0", "y": "0", "z": "-3000 - 100*t"}, "vertical or zero velocity"),
    ],
)
def test_non_finite_or_singular_inputs_refused(changes, message):
    from gna.errors import DomainError

    sc = make_scenario(flat_outputs=changes)
    with pytest.raises(DomainError, match=message):
        plan_motion(sc.problem(), sc.t_nodes, J=0)
