"""The Python API refuses bad arguments as the CLI does: one InputError naming the cause, no traceback from deep inside."""

from __future__ import annotations

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.errors import InputError
from gna.simulate import simulate
from gna.trim import trim_level
from harness.validation import ValidationCase, run_case
from planners.generalized import plan_scenario
from planners.scenario import load_scenario


@pytest.fixture(scope="module")
def f16():
    ac = load_aircraft("f16c")
    tr = trim_level(ac, 150.0, 1000.0)
    return ac, np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)


@pytest.mark.parametrize(
    "J, match",
    [
        (-1, "J must be between 0 and 30, got -1"),
        ("3", "J must be a whole number, got '3'"),
        (2.5, "J must be a whole number, got 2.5"),
        (True, "J must be a whole number"),
    ],
)
def test_plan_scenario_checks_J_as_the_loader_does(J, match):
    sc = load_scenario("gtm-aileron-roll")
    with pytest.raises(InputError, match=match):
        plan_scenario(sc, J=J)
    with pytest.raises(InputError, match=match):
        load_scenario("gtm-aileron-roll", J=J)


@pytest.mark.parametrize("bad", [None, "gtm-aileron-roll", 3])
def test_plan_scenario_needs_a_scenario(bad):
    with pytest.raises(InputError, match=r"a Scenario is needed.*load_scenario\(name\) makes one"):
        plan_scenario(bad)


def test_simulate_refuses_non_finite_controls_at_t0(f16):
    ac, x0, u0 = f16
    with pytest.raises(InputError, match=r"controls at t0 = 0 s are not finite \(F = nan"):
        simulate(ac, lambda t: u0 * np.nan, (0.0, 1.0), x0)


def test_simulate_ends_a_run_whose_controls_turn_non_finite_with_a_status(f16):
    ac, x0, u0 = f16
    r = simulate(ac, lambda t: u0 if t < 0.5 else u0 * np.nan, (0.0, 1.0), x0)
    assert r.status == "domain" and r.message.startswith("non-finite control at t = 0.5 s (F = nan,")  # JSBSim's words


@pytest.mark.parametrize("shape", [(3, 4), (1, 12), (12, 2), (13,)])
def test_simulate_refuses_a_state_that_is_not_12_values(f16, shape):
    ac, x0, u0 = f16
    bad = np.resize(x0, shape)
    with pytest.raises(InputError, match=rf"12 wind-frame values .* got shape \({shape[0]},"):
        simulate(ac, u0, (0.0, 0.1), bad)
    assert simulate(ac, u0, (0.0, 0.1), x0.reshape(12, 1)).status == "completed"


def test_simulate_and_run_case_refuse_a_name_for_an_object(f16):
    ac, x0, u0 = f16
    with pytest.raises(InputError, match=r"aircraft must be a gna.aircraft.Aircraft.*load_aircraft\(name\) makes one"):
        simulate("f16c", u0, (0.0, 1.0), x0)
    with pytest.raises(InputError, match=r"plan must be a planners.plan.Plan"):
        run_case(ValidationCase("gtm-aileron-roll", J=1), plan="garbage")
    with pytest.raises(InputError, match=r"scenario must be a planners.scenario.Scenario"):
        run_case(ValidationCase("gtm-aileron-roll", J=1), scenario="garbage")
