"""Trim / calibration: residuals, fixed-variable choices, helpers and failure messages."""

from __future__ import annotations

import math

import pytest

from gna.aircraft import load_aircraft
from gna.atmosphere import Environment
from gna.eom import derivatives
from gna.errors import ConvergenceError, DomainError, InputError
from gna.trim import coordinated_turn, level_alpha, sideslip_glide, stall_speed, trim, trim_level


@pytest.fixture(scope="module")
def f16():
    return load_aircraft("f16c")


def _check_steady(aircraft, t, chi_dot=0.0):
    env = Environment.constant(t.altitude)
    d = derivatives(aircraft, env, t.state, t.controls, model=t.model)
    for name in ("V", "gamma", "alpha", "beta", "mu", "p", "q", "r"):
        assert abs(getattr(d, name)) <= 1e-9, name
    assert abs(d.chi - chi_dot) <= 1e-9


def test_level_trim_issue_condition(f16):
    t = trim_level(f16, 152.4, 3048.0)
    assert t.max_residual <= 1e-9
    _check_steady(f16, t)
    assert 0.0 < t.values["alpha"] < math.radians(10)
    assert t.values["F"] > 0 and t.values["dm"] < 0


@pytest.mark.parametrize("model", ["full", "simple"])
def test_coordinated_turn(f16, model):
    t = coordinated_turn(f16, 150.0, 0.1, 2000.0, model=model)
    _check_steady(f16, t, 0.1)
    assert t.values["beta"] == 0.0 and t.values["mu"] > 0.5
    # body rates are the wind frame's rotation chi' about the vertical
    w = math.sqrt(t.values["p"] ** 2 + t.values["q"] ** 2 + t.values["r"] ** 2)
    assert w == pytest.approx(0.1, rel=1e-9)


def test_any_four_fixed(f16):
    ref = trim_level(f16, 140.0, 1000.0)
    # Fix alpha instead of V: recovers the same speed.
    t = trim(f16, {"alpha": ref.values["alpha"], "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0}, altitude=1000.0)
    assert t.values["V"] == pytest.approx(140.0, rel=1e-9)
    # Fix thrust and speed: gives gamma.
    t = trim(f16, {"V": 140.0, "F": ref.values["F"] * 1.2, "chi_dot": 0.0, "beta": 0.0}, altitude=1000.0)
    assert t.values["gamma"] > 0.0
    assert level_alpha(f16, 140.0, 1000.0) == pytest.approx(ref.values["alpha"], rel=1e-12)


def test_sideslip_glide(f16):
    t = sideslip_glide(f16, 0.1, 0.1, 1000.0)
    assert t.values["F"] == 0 and t.values["gamma"] < 0 and t.values["mu"] != 0
    _check_steady(f16, t)


def test_simple_model_trim_differs_from_full(f16):
    full = trim_level(f16, 150.0, 1000.0)
    simple = trim_level(f16, 150.0, 1000.0, model="simple")
    assert simple.max_residual <= 1e-9
    # Simple model neglects the elevator's lift: alpha differs slightly.
    assert 0 < abs(simple.values["alpha"] - full.values["alpha"]) < math.radians(1)


def test_stall_speed(f16):
    s = stall_speed(f16, 0.0)
    assert 30 < s.V_stall < 80
    assert f16.envelope.alpha_min < s.alpha_stall <= f16.envelope.alpha_max
    # Any slower level flight at lower alpha needs more speed.
    assert (
        trim(f16, {"alpha": s.alpha_stall * 0.8, "gamma": 0, "chi_dot": 0, "beta": 0}, check_envelope=False).values["V"]
        > s.V_stall
    )


def test_input_errors(f16):
    with pytest.raises(InputError, match="exactly 4"):
        trim(f16, {"V": 100.0})
    with pytest.raises(InputError, match="unknown trim variable"):
        trim(f16, {"V": 100.0, "gama": 0, "chi_dot": 0, "beta": 0})
    with pytest.raises(InputError, match="speed must be positive"):
        trim_level(f16, -5.0)
    with pytest.raises(InputError, match="finite"):
        trim_level(f16, float("nan"))


def test_out_of_envelope_refused(f16):
    with pytest.raises(DomainError, match="outside the aerodynamic model's envelope"):
        trim_level(f16, 20.0)


def test_convergence_failure_message(f16):
    with pytest.raises(ConvergenceError, match=r"did not converge: residual .* after 3 Newton iterations"):
        trim(f16, {"V": 150.0, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0}, maxiter=3, tol=1e-30)


@pytest.mark.parametrize(
    "entry",
    [
        lambda ac: trim_level(ac, 5000.0, altitude=3048.0),
        lambda ac: level_alpha(ac, 5000.0),
        lambda ac: coordinated_turn(ac, 3500.0, 0.01),
        lambda ac: trim(ac, {"V": 0.5, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0}),
    ],
)
def test_trim_refuses_a_speed_outside_the_physical_domain(entry):
    with pytest.raises(DomainError, match=r"V = .* m/s is outside the physical domain \[1, 3000\] m/s"):
        entry(load_aircraft("f16c"))
