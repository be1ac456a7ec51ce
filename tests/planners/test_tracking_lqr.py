"""The time-varying LQR tracking design (planners.lqr) beside the paper's (planners.tracking)."""

from __future__ import annotations

import math
import pickle
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.linalg import solve_continuous_are

from gna.errors import InputError
from gna.perturbation import Perturbation, offset_state, perturbed_aircraft
from harness.engines import get_engine
from planners.generalized import plan_scenario
from planners.lqr import (
    TRACKING_TIME,
    LQRController,
    TrackingTolerances,
    feedforward_room,
    input_ranges,
    lqr_controller,
    lqr_design,
    solve_riccati,
    thrust_lag,
)
from planners.scenario import load_scenario, with_tracking_design
from planners.tracking import tracking_controller

from .conftest import make_scenario


def test_riccati_tends_to_the_algebraic_solution_as_the_horizon_grows():
    # Constant coefficients (a lightly damped oscillator with an integrator), zero terminal weight:
    # P(t0) -> the stabilising solution of the algebraic Riccati equation as t1 - t0 grows.
    A = np.array([[0.0, 1.0, 0.0], [-4.0, -0.2, 0.0], [1.0, 0.0, 0.0]])
    B = np.array([[0.0], [1.0], [0.0]])
    Q, R = np.diag([1.0, 0.1, 2.0]), np.array([[0.5]])
    P_inf = solve_continuous_are(A, B, Q, R)
    errors = []
    for T in (0.5, 2.0, 8.0, 30.0):
        P, dP = solve_riccati(lambda t: A, lambda t: B, Q, R, np.zeros((3, 3)), (0.0, T), np.array([0.0, T]))
        assert np.allclose(P[1], 0.0, atol=1e-12)  # the terminal condition
        errors.append(np.linalg.norm(P[0] - P_inf) / np.linalg.norm(P_inf))
    assert errors == sorted(errors, reverse=True)
    assert errors[0] > 0.1 and errors[-1] < 1e-6
    # ... and started from it, it stays there (P' = 0).
    P, dP = solve_riccati(lambda t: A, lambda t: B, Q, R, P_inf, (0.0, 5.0), np.linspace(0.0, 5.0, 6))
    assert np.max(np.abs(P - P_inf)) < 1e-6 * np.abs(P_inf).max()
    assert np.max(np.abs(dP)) < 1e-5 * np.abs(P_inf).max()


@pytest.fixture(scope="module")
def roll():
    sc = load_scenario("gtm-aileron-roll")
    plan = plan_scenario(sc)
    return sc, plan, lqr_controller(plan, saturate=sc.tracking.saturate)


def _fly(plan, controller, pert):
    tt = np.arange(plan.t0, plan.t1 + 1e-9, 0.05)
    res = get_engine("inhouse").simulate(
        perturbed_aircraft(plan.aircraft, pert),
        controller.controls,
        (plan.t0, plan.t1),
        offset_state(plan.initial_state(), pert),
        controller=controller,
        env=plan.env,
        t_eval=tt,
    )
    t = res.df.index.to_numpy()
    err = np.linalg.norm(res.df[["x", "y", "z"]].to_numpy().T - plan.state(t)[:3], axis=0)
    return res, t, err


def test_lqr_holds_an_initial_offset_the_paper_design_loses(roll):
    # 5 m, 1 m/s, 1 deg off the roll's start: the paper-style poles (the scenario's lambdas) leave the flight
    # domain at once (measured: departs at t0); the LQR returns (measured 0.34 m over the last 20 %; 0.49 m with integrals from 0 and rating-sized ranges).
    sc, plan, lqr = roll
    pert = Perturbation(position_m=5.0, speed_mps=1.0, angle_rad=math.radians(1.0))
    paper = tracking_controller(plan, sc.tracking.lambdas, saturate=sc.tracking.saturate)
    res_p, t_p, err_p = _fly(plan, paper, pert)
    assert res_p.status != "completed" or np.max(err_p[t_p >= plan.t0 + 0.8 * (plan.t1 - plan.t0)]) > 1.0
    res, t, err = _fly(plan, lqr, pert)
    assert res.status == "completed" and t[-1] == pytest.approx(plan.t1)
    assert np.max(err[t >= plan.t0 + 0.8 * (plan.t1 - plan.t0)]) < 1.0
    assert err[0] == pytest.approx(5.0)


def test_lqr_from_the_plan_stays_on_it(roll):
    _, plan, lqr = roll
    res, t, err = _fly(plan, lqr, Perturbation())
    assert res.status == "completed" and np.max(err) < 1e-3  # measured 5.2e-5 m


def test_the_controller_is_a_picklable_controller_with_its_design(roll):
    _, plan, lqr = roll
    assert isinstance(lqr, LQRController) and lqr.design == "lqr" and lqr.n_states == 4
    assert lqr.state_names == ("I1", "I2", "I3", "I4") and lqr.lag is None
    back = pickle.loads(pickle.dumps(lqr))
    x = np.asarray(plan.initial_state(), dtype=float) + 0.01
    xc = np.array([0.1, -0.2, 0.05, 0.01])
    t = plan.t0 + 1.3
    out, der = lqr.output_and_derivative(t, x, xc)
    out2, der2 = back.output_and_derivative(t, x, xc)
    assert np.array_equal(out, out2) and np.array_equal(der, der2)
    assert np.allclose(lqr.controls(t), np.asarray(plan.control_function()(t)).reshape(-1), atol=1e-9)
    # the same at precomputed sample times, and batched
    sampled = lqr.at_times([t])
    assert np.allclose(sampled.output(t, x, xc), out, rtol=1e-12, atol=1e-12)
    du, rates = lqr.output_and_derivative_many(t, np.stack([x, x], 1), np.stack([xc, xc], 1))
    assert np.allclose(du[:, 1], out) and np.allclose(rates[:, 0], der)
    du, rates = lqr.output_and_derivative_many(np.array([t, t]), np.stack([x, x], 1), np.stack([xc, xc], 1))
    assert np.allclose(du[:, 0], out) and np.allclose(rates[:, 1], der)


def test_anti_windup_back_calculation_under_saturation(roll):
    _, plan, lqr = roll
    t = plan.t0 + 2.0
    x = np.asarray(plan.state(t), dtype=float).reshape(-1).copy()
    x[:3] += 30.0  # far off the plan: the surfaces saturate
    xc = np.zeros(4)
    free = replace(lqr, anti_windup=False)
    u, du = lqr.commanded(t, x, xc)
    total = u + du
    excess = total - np.clip(total, lqr.lower, lqr.upper)
    assert np.any(excess != 0.0)
    out, rates = lqr.output_and_derivative(t, x, xc)
    out_free, rates_free = free.output_and_derivative(t, x, xc)
    # the applied command is the saturated one either way
    assert np.allclose(u + out, np.clip(total, lqr.lower, lqr.upper)) and np.allclose(out, out_free)
    # the integrals are pulled back: K_I (I'_free - I') = excess / T_t on the feedback inputs
    _, gain = lqr._reference_and_gain(t)
    rows = list(lqr.input_rows)
    K_I = gain[rows, 12:16]
    assert np.allclose(K_I @ (rates_free - rates), excess[rows] / TRACKING_TIME, rtol=1e-8, atol=1e-12)
    # within the limits, the integrands are the paper's (no correction)
    x0 = np.asarray(plan.state(t), dtype=float).reshape(-1)
    assert np.allclose(lqr.derivative(t, x0, xc), free.derivative(t, x0, xc))


def test_thrust_lag_is_a_designed_actuator_state(weave_plan):
    _, plan = weave_plan
    assert thrust_lag(plan.aircraft) is None  # the bundled aircraft give none: immediate thrust
    des = lqr_design(plan, lag=0.8)
    assert des.lag == 0.8 and des.weights.states[-1] == "e_F" and des.K.shape[2] == 12 + 4 + 1
    t = des.t[len(des.t) // 2]
    k = len(des.t) // 2
    eig = np.linalg.eigvals(des.A_of(t) + des.B_of(t) @ des.K[k])
    assert np.max(eig.real) < 0  # the frozen closed loop with the engine's lag is stable there
    ctl = lqr_controller(plan, lag=0.8)
    assert ctl.n_states == 5 and ctl.state_names[-1] == "e_F" and ctl.lead_poly is not None
    # e_F follows the engine model on the applied command: e_F' = (v_F - e_F) / tau
    x = np.asarray(plan.state(t), dtype=float).reshape(-1)
    xc = np.array([0.0, 0.0, 0.0, 0.0, 50.0])
    out, der = ctl.output_and_derivative(t, x, xc)
    lead = ctl._lead(t)
    assert der[-1] == pytest.approx((out[0] - lead - 50.0) / 0.8)
    # aircraft data with a measured time constant (Propulsion.thrust_lag [s]) give it; 0 gives none
    assert thrust_lag(SimpleNamespace(propulsion=SimpleNamespace(thrust_lag=0.5))) == 0.5
    assert thrust_lag(SimpleNamespace(propulsion=SimpleNamespace(thrust_lag=0.0))) is None


def test_lqr_flies_the_weave(weave_plan):
    _, plan = weave_plan
    res, t, err = _fly(plan, lqr_controller(plan), Perturbation(position_m=5.0, speed_mps=1.0))
    assert res.status == "completed" and np.max(err[t >= 24.0]) < 0.1


def test_scenario_design_key_and_tolerances():
    sc = make_scenario(tracking={"design": "lqr", "tolerances": {"position": 2.0, "angle": 0.01}})
    assert sc.tracking.design == "lqr"
    assert sc.tracking.tolerances == TrackingTolerances(position=2.0, angle=0.01)
    assert make_scenario().tracking.design == "paper"  # the default
    with pytest.raises(InputError, match="design must be one of 'paper', 'lqr', got 'lq'"):
        make_scenario(tracking={"design": "lq"})
    with pytest.raises(InputError, match="position must be > 0"):
        make_scenario(tracking={"tolerances": {"position": 0.0}})
    with pytest.raises(InputError, match="unknown key 'speed'"):
        make_scenario(tracking={"tolerances": {"speed": 1.0}})
    assert with_tracking_design(sc, None) is sc
    assert with_tracking_design(sc, "paper").tracking.design == "paper"
    with pytest.raises(InputError, match="--tracking"):
        with_tracking_design(sc, "pid")


def test_bryson_input_ranges_are_the_room_along_the_plan(roll, monkeypatch):
    # The roll flies 5.87-28.2 N of the GTM's 136 N and dl down to -0.302 rad against +-0.349 rad: a
    # saturating loop's feedback has 5.87 N and 0.047 rad in both directions, not the limits' sizes.
    _, plan, lqr = roll
    inputs = ("F", "dl", "dm", "dn")
    size = input_ranges(plan, inputs)
    assert size == pytest.approx(
        [plan.aircraft.propulsion.max_thrust, math.radians(20), math.radians(30), math.radians(30)]
    )
    room = feedforward_room(plan, inputs)
    t = np.linspace(plan.t0, plan.t1, 4001)
    U = np.array([plan.control_function()(s) for s in t]).T
    assert room[0] == pytest.approx(U[0].min(), rel=1e-4) and room[0] == pytest.approx(5.868, abs=1e-3)
    assert room[1] == pytest.approx(math.radians(20) + U[2].min(), rel=1e-4)
    assert np.all(room > 0) and np.all(room < size)
    assert input_ranges(plan, inputs, j=-1) == pytest.approx(room)
    # the design: R = 1 / room^2 when the loop saturates, 1 / size^2 when it does not
    assert lqr_design(plan).weights.ranges == pytest.approx(room)
    assert lqr_design(plan, saturate=False).weights.ranges == pytest.approx(size)
    # a plan touching or leaving a limit leaves no room there: the limit's size
    monkeypatch.setattr("planners.lqr.feedforward_room", lambda plan, inputs, j: np.array([-1.0, 0.0, 0.1, 0.2]))
    assert input_ranges(plan, inputs, j=-1) == pytest.approx([size[0], size[1], 0.1, 0.2])


def test_integrals_start_where_the_cost_to_go_is_least(roll):
    _, plan, lqr = roll
    des = lqr_design(plan)
    t0 = plan.t0
    x_ref = np.asarray(plan.initial_state(), dtype=float)
    assert np.allclose(lqr.initial_state(t0, x_ref), 0.0, atol=1e-9)  # on the plan: zero
    x0 = x_ref + np.array([1.0, -2.0, 0.5, 0.3, 0.002, -0.004, 0.003, 0.001, -0.005, 0.0, 0.0, 0.0])
    I0 = lqr.initial_state(t0, x0)
    P = des.P[0]
    dx = x0 - x_ref
    P_ii, P_ix = P[12:, 12:], P[12:, :12]
    assert np.allclose(P_ii @ I0 + P_ix @ dx, 0.0, atol=1e-9 * np.abs(P_ix @ dx).max())  # the gradient is zero

    def cost(I):
        z = np.concatenate([dx, I])
        return z @ P @ z

    assert cost(I0) < cost(np.zeros(4))
    rng = np.random.default_rng(3)
    assert all(cost(I0) < cost(I0 + 0.1 * rng.standard_normal(4)) for _ in range(5))
    # the least-cost start is optional: zero without it
    assert np.all(lqr_controller(plan, least_cost_start=False).initial_state(t0, x0) == 0.0)
    # and it survives a pickle
    assert np.array_equal(pickle.loads(pickle.dumps(lqr)).initial_state(t0, x0), I0)


def test_dispersed_roll_sample_is_held(roll):
    # Sample 5 of the bundled campaign paper-dispersions (case gtm-roll): 2.2 m behind, 2.1 m aside, 1.9 m
    # below the roll's start, a dispersed GTM.  Sized by the thrust rating and started with zero integrals,
    # the LQR sent 136 N (the plan flies 10 N), overshot by 2.9 m/s with no thrust left to brake (0 for 7.75 s)
    # and ended 8.0 m off; now 0.55 m after the settle time (the tracking verdict: 1 m after 5 s).
    from harness.campaign.sampling import dispersed_aircraft, draw_sample
    from harness.campaign.spec import load_campaign

    _, plan, lqr = roll
    task = next(t for t in load_campaign("paper-dispersions").tasks(32) if t.case_id == "gtm-roll.data.0005")
    draw = draw_sample(plan.aircraft, task.dispersion, task.seed)
    assert draw.offsets[:3] == pytest.approx([-2.177, 2.076, 1.885], abs=1e-3)
    res = get_engine("inhouse").simulate(
        dispersed_aircraft(plan.aircraft, draw),
        lqr.controls,
        (plan.t0, plan.t1),
        np.asarray(plan.initial_state(), dtype=float) + draw.offsets,
        controller=lqr,
        env=plan.env,
        t_eval=np.arange(plan.t0, plan.t1 + 1e-9, 0.05),
    )
    t = res.df.index.to_numpy()
    err = np.linalg.norm(res.df[["x", "y", "z"]].to_numpy().T - plan.state(t)[:3], axis=0)
    assert res.status == "completed"
    assert np.max(err[t >= plan.t0 + 5.0 - 1e-9]) < 1.0  # measured 0.554 m
