"""The paper's tracking feedback (linearized system, integral terms, pole placement) on chained systems:
the aircraft's planners.tracking.linearize / design / tracking_controller on a system's explicit model."""

from __future__ import annotations

import numpy as np
import pytest

from gna.errors import InputError
from planners.chained import generalized_parametrization
from planners.systems import CarTrailers, simulate_car_two_trailers
from planners.systems.scenario import load_chained_scenario, plan_chained_scenario
from planners.tracking import design, linearize, simulate_closed_loop, tracking_controller

CAR_LAMBDAS = ((1.0, 2.0), (1.0, 1.5, 2.0, 2.5, 3.0))


@pytest.fixture(scope="module")
def car_plan():
    sc = load_chained_scenario("car-two-trailers")
    return sc, plan_chained_scenario(sc)


def test_linearization_of_the_chained_model_is_its_jacobian(car_plan):
    """linearize: the complex-step series Jacobian equals central differences of the exact model at
    the nodes; the design model (off-axle terms frozen) differs from it only by those terms."""
    sc, plan = car_plan
    ssm = plan.system.model
    full = linearize(plan, model="full")
    design = linearize(plan, model="design")
    assert full.A.shape == (49, 5, 5, 2) and full.B.shape == (49, 5, 2, 2)
    i = 17
    x = np.array([np.real(plan.iterates[-1][n].constant_term[i]) for n in ssm.states])
    u = np.array([np.real(plan.iterates[-1][n].constant_term[i]) for n in ssm.controls])
    h = 1e-6
    for b in range(5):
        d = np.zeros(5)
        d[b] = h
        fd = (np.array(ssm.rhs(list(x + d), list(u), None)) - np.array(ssm.rhs(list(x - d), list(u), None))) / (2 * h)
        assert np.allclose(full.A[i, :, b, 0], fd, atol=1e-8)
    for b in range(2):
        d = np.zeros(2)
        d[b] = h
        fd = (np.array(ssm.rhs(list(x), list(u + d), None)) - np.array(ssm.rhs(list(x), list(u - d), None))) / (2 * h)
        assert np.allclose(full.B[i, :, b, 0], fd, atol=1e-8)
    # design model: the steering reaches the trailers only through theta0 (w0 frozen in the off-axle terms)
    assert np.allclose(design.B[:, :4, 1], 0.0) and not np.allclose(full.B[:, :4, 1], 0.0)


def test_design_places_the_poles_of_each_integral(car_plan):
    """Frozen at every node, the augmented design closed loop has exactly the poles -lambda of I1 (along
    track, degree 2 through v0) and I2 (cross track, degree 5 through phi): no zero dynamics left."""
    _, plan = car_plan
    des = design(plan, CAR_LAMBDAS)
    assert des.degrees == (2, 5) and des.inputs == ("v0", "phi") and des.integrals == ("I1", "I2")
    want = np.sort(-np.concatenate(CAR_LAMBDAS))
    ev = np.sort(np.linalg.eigvals(des.closed_loop()).real, axis=1)
    assert np.allclose(ev, want, atol=1e-6)
    with pytest.raises(InputError, match="lengths 2, 5"):
        design(plan, [[1.0], [1.0]])


def test_car_closed_loop_converges_to_the_plan_from_a_perturbed_start():
    """The exact off-axle model in closed loop, the rig started 0.3 m behind and 0.3 m beside its plan,
    trailer 2 turned by 1 deg and the car by 2 deg, on the scenario's weave over 24 s: back on the plan
    (0.42 m -> 0.16 mm measured) with the steering within 0.11 rad (the plan's: 0.06), while the same
    start flown open loop stays off."""
    sc = load_chained_scenario("car-two-trailers")
    T = 24.0
    plan = generalized_parametrization(sc.system, np.linspace(0.0, T, 97), sc.flat_outputs, J=4, e=3)
    ctl = tracking_controller(plan, ((1.0, 1.5), (0.6, 0.8, 1.0, 1.2, 1.4)))
    te = np.linspace(0.0, T, 241)
    ref = np.column_stack([sc.flat_outputs["x2"](te), sc.flat_outputs["y2"](te)])
    dx = np.array([0.3, 0.3, 0.02, 0.0, 0.03])
    x0 = np.array([plan.evaluate(n, 0.0) for n in ctl.model_states]) + dx
    X, U = simulate_closed_loop(plan, ctl, x0, te)
    err = np.hypot(*(X[:, :2] - ref).T)
    assert err[0] == pytest.approx(0.3 * np.sqrt(2)) and err[-1] < 1e-3 and np.all(err[te >= 16.0] < 1e-2)
    assert np.max(np.abs(U[:, 1])) < 0.2 and np.all(np.abs(U[:, 0] - 5.0) < 1.0)
    g = CarTrailers(**{k: sc.parameters[k] for k in ("l0", "d1", "L1", "d2", "L2")})
    Xo = simulate_car_two_trailers(g, lambda t: plan.evaluate("v0", t), lambda t: plan.evaluate("phi", t), x0, te)
    assert np.hypot(*(Xo[-1, :2] - ref[-1])) > 0.2
    # unperturbed: the loop keeps the exact model on the plan (the plan's own open-loop error is 4e-5 m)
    X, _ = simulate_closed_loop(plan, ctl, x0 - dx, te)
    assert np.max(np.hypot(*(X[:, :2] - ref).T)) < 1e-4


def test_lag_closed_loop_converges():
    """The first-order lag: I = int dx of relative degree 3 in the design model (eps y' frozen); the exact
    lag x' = y + eps y' in closed loop from x off by 0.1 returns to the plan."""
    sc = load_chained_scenario("first-order-lag")
    plan = generalized_parametrization(sc.system, np.linspace(0.0, 10.0, 41), sc.flat_outputs, J=8)
    ctl = tracking_controller(plan, [(1.0, 2.0, 3.0)])
    te = np.linspace(0.0, 10.0, 101)
    x0 = np.array([plan.evaluate(n, 0.0) for n in ("x", "y")]) + np.array([0.1, 0.0])
    X, _ = simulate_closed_loop(plan, ctl, x0, te)
    err = np.abs(X[:, 0] - np.sin(te))
    assert err[0] == pytest.approx(0.1) and err[-1] < 2e-3


def test_a_system_without_an_explicit_model_is_refused():
    from planners.chained import ChainedSystem, Stage

    sysm = ChainedSystem("bare", {"x": 1}, (Stage(("y",), lambda v: [v["x'"] - v["y"]]),))
    plan = generalized_parametrization(sysm, [0.0, 1.0], {"x": np.sin}, J=0)
    with pytest.raises(InputError, match="no explicit model"):
        design(plan, 1.0)
