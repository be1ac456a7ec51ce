"""Theorem 1 (the linearized system is a free module) along plans: planners.flatness_test."""

from __future__ import annotations

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.atmosphere import Environment
from gna.errors import InputError
from gna.trim import trim
from planners.flatness_test import RANK_TOL, flatness_test, lift_maximum, silverman_meadows, stall_line
from planners.generalized import plan_scenario
from planners.scenario import load_scenario, scenario_from_dict

ALT = 1000.0


@pytest.fixture(scope="module")
def gtm():
    return load_aircraft("gtm")


def level_line(aircraft, alpha, density="constant"):
    """A level straight line at the speed of level flight at ``alpha``, as a scenario dict plan
    (calibrated at that alpha: the paper's calibration functions give H and the stage-2 start)."""
    env = Environment.constant(ALT)
    rho = float(env.density(-ALT))
    envs = {"density": "constant", "rho": rho} if density == "constant" else {"density": "isa"}
    V = trim(
        aircraft,
        {"alpha": alpha, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0},
        altitude=ALT,
        env=env if density == "constant" else None,
        check_envelope=False,
    ).values["V"]
    data = {
        "name": f"line-{alpha:.4f}",
        "aircraft": aircraft.id,
        "time": {"t0": 0.0, "t1": 2.0, "step": 1.0},
        "constants": {"V0": V},
        "environment": envs,
        "flat_outputs": {"x": "V0*t", "y": "0", "z": f"-{ALT}", "zeta": "beta", "zeta_value": "0"},
        "calibration": {"alpha": alpha, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0, "altitude": ALT},
        "generalized": {"J": 0},
    }
    return plan_scenario(scenario_from_dict(data), method="newton")


def test_constant_coefficients_is_kalman():
    rng = np.random.default_rng(0)
    A, B = rng.standard_normal((4, 4)), rng.standard_normal((4, 2))
    M = silverman_meadows(A[None, :, :, None], B[None, :, :, None], 4)[0]
    K = np.hstack([np.linalg.matrix_power(A, k) @ B for k in range(4)])
    assert np.allclose(M, K)


def test_time_varying_needs_the_derivative_term():
    """x1' = u, x2' = t x1: at t = 0, A(0) = 0 and Kalman's frozen test gives rank 1, but the system is
    controllable: M1 = A B - B' = (0, t), M2 = A M1 - M1' = (0, -1)."""
    A = np.zeros((1, 2, 2, 3))
    A[0, 1, 0, 1] = 1.0  # A21 = t
    B = np.zeros((1, 2, 1, 3))
    B[0, 0, 0, 0] = 1.0
    M = silverman_meadows(A, B, 3)[0]
    assert np.allclose(M, [[1, 0, 0], [0, 0, -1]])
    frozen = silverman_meadows(A[..., :1], B[..., :1], 3)[0]
    assert np.linalg.matrix_rank(frozen) == 1 and np.linalg.matrix_rank(M) == 2


def test_stall_line_fails_cruise_passes(gtm):
    """The paper: a straight line at the stall speed (alpha at the lift maximum) is not flat by Theorem 1.
    The trimmed lift maximum (minimum level-flight speed) is above the C_L polynomial's maximum
    (elevator lift and thrust); there the linearized full model loses rank 12 -> 11 at every node."""
    a_cl = lift_maximum(gtm)
    assert 0.25 < a_cl < 0.26  # GTM: 0.2540 rad
    alpha, V = stall_line(gtm, ALT, env=Environment.constant(ALT))
    assert a_cl < alpha < gtm.envelope.alpha_max and 28.0 < V < 30.0
    stall = flatness_test(level_line(gtm, alpha))
    assert not stall.passed
    assert list(stall.failed_nodes) == [0, 1, 2] and set(stall.rank) == {11}
    assert np.all(stall.sigma_min < RANK_TOL) and "fails at 3 of 3 nodes" in stall.message
    cruise = flatness_test(level_line(gtm, 0.1))  # 40.6 m/s
    assert cruise.passed and np.all(cruise.sigma_min > 100 * RANK_TOL)
    # a V-shaped minimum: 1e-4 rad either side already passes
    for da in (-1e-4, 1e-4):
        near = flatness_test(level_line(gtm, alpha + da))
        assert near.passed and np.all(near.sigma_min > 10 * RANK_TOL)


def test_stall_line_in_isa_is_weakly_controllable(gtm):
    """With the density falling with altitude the altitude column keeps rank 12 at the stall,
    by a relative singular value of ~2e-5 (climbing into thinner air changes the lift)."""
    alpha, _ = stall_line(gtm, ALT)
    ft = flatness_test(level_line(gtm, alpha, density="isa"))
    assert ft.passed and np.all(ft.sigma_min < 1e-4)


def test_paper_scenario_passes_along_the_plan():
    sc = load_scenario("gtm-aileron-roll")
    plan = plan_scenario(sc, J=5)
    ft = flatness_test(plan, 0)
    assert ft.order == 11 and ft.passed
    tab = ft.table()
    assert list(tab.columns) == ["rank", "sigma_min", "passed"] and len(tab) == len(plan.t_nodes)


def test_bad_input(gtm):
    plan = plan_scenario(load_scenario("gtm-aileron-roll"), J=0)
    with pytest.raises(InputError, match="unknown control"):
        flatness_test(plan, controls=("F", "throttle"))
    with pytest.raises(InputError, match="tol"):
        flatness_test(plan, tol=0.0)
