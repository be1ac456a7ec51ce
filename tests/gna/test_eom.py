"""Independent check of the wind-frame equations against a body-axis quaternion 6-DoF.

Issue requirement: from >= 20 random states with random smooth control
histories, both formulations integrated over 10 s with tight tolerances agree
to <= 1e-7 relative on every wind-frame variable.  The relative error of a
variable is its max abs difference over the run divided by its peak magnitude
(floor 1e-3 in the variable's SI unit, for variables that stay near zero).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gna import body6dof
from gna.aircraft import Propulsion, load_aircraft
from gna.atmosphere import ISA, ConstantDensity, Environment
from gna.eom import STATE_NAMES, Controls, State, derivatives, state_vector_derivative
from gna.trim import trim_level


def _twin(aircraft):
    """A two-engine variant with tilted thrust and an offset CG (exercises every moment term)."""
    return dataclasses.replace(aircraft, propulsion=Propulsion(count=2, y_p=1.8, epsilon=math.radians(3.0)))


def _cases(n=24, seed=20261122):
    rng = np.random.default_rng(seed)
    base = {name: load_aircraft(name) for name in ("f16c", "a7")}
    cases = []
    for k in range(n):
        craft = base["f16c" if k % 2 == 0 else "a7"]
        if k % 3 == 0:
            craft = _twin(craft)
        env = Environment(ISA()) if k % 4 else Environment(ConstantDensity(1.0))
        V = rng.uniform(110.0, 200.0)
        alt = rng.uniform(500.0, 6000.0)
        tr = trim_level(craft, V, alt, env=env)
        s = np.array(tr.state, dtype=float)
        s[4] += rng.uniform(-0.1, 0.1)  # gamma
        s[5] = rng.uniform(-math.pi, math.pi)  # chi
        s[6] += rng.uniform(-0.03, 0.03)  # alpha
        s[7] = rng.uniform(-0.08, 0.08)  # beta
        s[8] = rng.uniform(-0.5, 0.5)  # mu
        s[9:12] = rng.uniform(-0.1, 0.1, 3)  # p, q, r
        u0 = np.array(tr.controls, dtype=float)
        amp = np.array([0.1 * u0[0], 0.3 if craft.propulsion.count == 2 else 0.0, 0.02, 0.02, 0.02]) * rng.uniform(
            0.2, 1, 5
        )
        w = rng.uniform(0.2, 2.0, 5)
        ph = rng.uniform(0, 2 * math.pi, 5)
        cases.append((craft, env, s, u0, amp, w, ph))
    return cases


CASES = _cases()


def _controls(u0, amp, w, ph):
    return lambda t: u0 + amp * np.sin(w * t + ph)


@pytest.mark.parametrize("case", range(len(CASES)))
def test_wind_frame_equals_body_frame(case):
    craft, env, s0, u0, amp, w, ph = CASES[case]
    ufun = _controls(u0, amp, w, ph)
    t_eval = np.linspace(0.0, 10.0, 201)
    tol = dict(rtol=1e-12, atol=1e-12, method="DOP853", t_eval=t_eval)
    wind = solve_ivp(
        lambda t, y: np.array(derivatives(craft, env, State(*y), Controls(*ufun(t))), dtype=float),
        (0.0, 10.0),
        s0,
        **tol,
    )
    body = solve_ivp(
        lambda t, y: body6dof.derivative(craft, env, y, ufun(t)), (0.0, 10.0), body6dof.from_wind_state(s0), **tol
    )
    assert wind.success and body.success
    bw = body6dof.to_wind_state(body.y)
    for i, name in enumerate(STATE_NAMES):
        a, b = wind.y[i], bw[i]
        if name in ("chi", "mu"):
            b = a + (np.angle(np.exp(1j * (b - a))))  # same branch
        scale = max(np.max(np.abs(a)), 1e-3)
        rel = np.max(np.abs(a - b)) / scale
        assert rel <= 1e-7, f"{name}: relative difference {rel:.2e} (case {case}, {craft.id})"


def test_initial_derivatives_match_body_frame():
    """At t = 0 the wind-frame derivatives equal those obtained from the body formulation by the chain rule."""
    craft, env, s0, u0, *_ = CASES[3]
    d_wind = np.array(derivatives(craft, env, State(*s0), Controls(*u0)), dtype=float)
    X = body6dof.from_wind_state(s0)
    h = 1e-6
    Xd = body6dof.derivative(craft, env, X, u0)
    fd = (body6dof.to_wind_state(X + h * Xd) - body6dof.to_wind_state(X - h * Xd)) / (2 * h)
    np.testing.assert_allclose(d_wind, fd, rtol=1e-6, atol=1e-8)


def test_vectorised_evaluation_equals_pointwise():
    """One definition evaluates on arrays of many states at once."""
    states = np.array([c[2] for c in CASES[:6:3]]).T  # both f16c twins
    craft, env = CASES[0][0], CASES[0][1]
    u = Controls(*CASES[0][3])
    d = state_vector_derivative(craft, env, states, u)
    for j in range(states.shape[1]):
        dj = np.array(derivatives(craft, env, State(*states[:, j]), u), dtype=float)
        np.testing.assert_allclose(d[:, j], dj, rtol=1e-14, atol=1e-14)


def test_the_propulsive_moments_are_zero_for_every_bundled_aircraft_and_add_no_operation():
    # Bit-identical: the moments of every bundled aircraft equal the equations without the propulsive terms.
    from gna.aircraft import list_aircraft, load_aircraft
    from gna.atmosphere import Environment
    from gna.eom import Controls, State, body_moments, loads

    s = State(0.0, 0.0, -1000.0, 60.0, 0.05, 0.2, 0.08, 0.03, 0.2, 0.1, -0.05, 0.02)
    u = Controls(3000.0, 0.1, 0.02, -0.05, 0.01)
    for ident in list_aircraft():
        ac = load_aircraft(ident)
        assert ac.propulsion.thrust_line_offset == 0.0 and ac.propulsion.torque_arm == 0.0
        ld = loads(ac, Environment(), s, u)
        geo = ac.geometry
        qS = ld.qbar * geo.S
        full = ld.moment_coeffs
        L, M, N = qS * geo.b * full.Cl, qS * geo.cbar * full.Cm, qS * geo.b * full.Cn
        d = geo.x_cg - geo.x_ref
        if d != 0.0:
            M = M - d * (-qS * (np.sin(s.alpha) * full.CD + np.cos(s.alpha) * full.CL))
            N = N + d * qS * full.CY
        if ac.propulsion.y_p != 0.0:
            eps = ac.propulsion.epsilon
            L = L + ac.propulsion.y_p * np.sin(eps) * u.F * u.eta
            N = N + ac.propulsion.y_p * np.cos(eps) * u.F * u.eta
        assert body_moments(ac, s, u, full, ld.qbar) == (L, M, N)


def test_the_propulsive_moments_by_hand_and_against_the_body_axis_model():
    from dataclasses import replace as _replace

    from gna.aircraft import load_aircraft
    from gna.atmosphere import Environment
    from gna.eom import Controls, State, body_moments, derivatives, loads

    base = load_aircraft("twin-otter")
    ac = _replace(base, propulsion=_replace(base.propulsion, thrust_line_offset=0.3, torque_arm=-0.2, epsilon=0.05))
    s = State(0.0, 0.0, -1000.0, 60.0, 0.05, 0.2, 0.08, 0.03, 0.2, 0.1, -0.05, 0.02)
    u = Controls(3000.0, 0.1, 0.02, -0.05, 0.01)
    ld = loads(ac, Environment(), s, u)
    without = _replace(ac, propulsion=_replace(ac.propulsion, thrust_line_offset=0.0, torque_arm=0.0))
    L0, M0, N0 = body_moments(without, s, u, ld.moment_coeffs, ld.qbar)
    L, M, N = body_moments(ac, s, u, ld.moment_coeffs, ld.qbar)
    assert M - M0 == pytest.approx(0.3 * 3000.0, rel=1e-12)  # thrust line 0.3 m below the CG: nose up
    assert L - L0 == pytest.approx(-0.2 * 3000.0, rel=1e-12)
    assert N == N0
    # the independent body-axis model (engines at r = (o sin eps, y, o cos eps), r x F, torque) agrees
    env = Environment()
    x0 = np.array(s, dtype=float)
    d_wind = np.array(derivatives(ac, env, s, u), dtype=float)
    X = body6dof.from_wind_state(x0)
    h = 1e-6
    Xd = body6dof.derivative(ac, env, X, np.array(u, dtype=float))
    fd = (body6dof.to_wind_state(X + h * Xd) - body6dof.to_wind_state(X - h * Xd)) / (2 * h)
    np.testing.assert_allclose(d_wind, fd, rtol=1e-6, atol=1e-8)
