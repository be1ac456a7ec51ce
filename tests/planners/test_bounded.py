"""Bounded planning (issue 26): free parameters, spline flat outputs from trim to trim, the optimizer within
the aircraft's limits, infeasible bounds in one line.

The optimizer's tests fly a small problem (the Twin Otter level at a free speed, 3 nodes, J = 1: about ten
plans); the bundled scenarios' numbers (the must-show figures) are in docs/bounded.md with their commands.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gna.errors import InputError
from gna.limits import limit_violations
from planners.bounded import FAILED, BoundedResult, control_rate_cost, control_scales, plan_bounded
from planners.generalized import plan_scenario
from planners.scenario import load_scenario, scenario_from_dict
from planners.series import Series
from planners.splines import bezier_expression, bezier_points, steady_derivatives

# The Twin Otter level at 500 m: alpha reaches the model's 12 deg at about 36 m/s; at the nominal 34 m/s it
# is above it.
SLOW = {
    "name": "slow-level",
    "aircraft": "twin-otter",
    "parameters": {"V": {"value": 34.0, "min": 34.0, "max": 60.0}},
    "time": {"t0": 0.0, "t1": 10.0, "step": 5.0},
    "flat_outputs": {"x": "V*t", "y": "0", "z": "-500", "zeta": "beta", "zeta_value": "0", "eta": "0"},
    "generalized": {"J": 1},
}


def slow(**parameter) -> dict:
    data = json.loads(json.dumps(SLOW))
    data["parameters"]["V"].update(parameter)
    return data


@pytest.fixture(scope="module")
def bounded_slow():
    return plan_bounded(scenario_from_dict(slow()))


@pytest.fixture(scope="module")
def infeasible_slow():
    return plan_bounded(scenario_from_dict(slow(max=35.0)))


# --- splines -----------------------------------------------------------------------------------------------


def test_bezier_meets_its_end_conditions_on_series():
    start, end = [0.0, 150.0, 0.0, 0.0, 0.0, 0.0], [5729.6, 0.0, 0.0, 0.0, 0.0, 0.0]
    pts = bezier_points(start, end, [4000.0, 5000.0], 0.0, 60.0)
    assert pts.size == 14  # 6 + 2 + 6: degree 13
    f = bezier_expression(pts, 0.0, 60.0)
    s = f(Series.variable(np.array([0.0, 60.0]), 6))
    c = np.real(s.coeffs) * np.array([math.factorial(k) for k in range(7)])  # derivatives at the ends
    np.testing.assert_allclose(c[0, :6], start, atol=1e-9)
    np.testing.assert_allclose(c[1, :6], end, atol=1e-8)

    def casteljau(p, u):
        p = list(p)
        while len(p) > 1:
            p = [(1 - u) * a + u * b for a, b in zip(p[:-1], p[1:])]
        return p[0]

    np.testing.assert_allclose(f(np.array([13.0, 41.0])), [casteljau(pts, 13 / 60), casteljau(pts, 41 / 60)])


def test_steady_derivatives_of_a_level_turn():
    d = steady_derivatives(100.0, 0.0, 0.0, 0.1, (0.0, 0.0, -1000.0), 3)
    assert d["x"] == pytest.approx([0.0, 100.0, 0.0, -1.0])  # x' = V cos(chi), x''' = -V chi'^2
    assert d["y"] == pytest.approx([0.0, 0.0, 10.0, 0.0])
    assert d["z"] == [-1000.0, -0.0, 0.0, 0.0]


# --- scenario files ----------------------------------------------------------------------------------------


def test_bundled_point_to_point_starts_and_ends_at_its_trims():
    sc = load_scenario("f16c-climb-turn")
    assert [p.name for p in sc.free_parameters] == ["cx6", "cx7", "cy6", "cy7", "cz6", "cz7"]
    start, end = sc.boundary["start"], sc.boundary["end"]
    assert start.trim.values["V"] == end.trim.values["V"] == 150.0
    assert end.altitude == 4000.0 and end.chi == pytest.approx(math.pi / 2)
    for b in (start, end):  # the splines meet the trims' positions and velocities
        t = np.array([b.time])
        assert sc.x(t)[0] == pytest.approx(b.x, abs=1e-6) and sc.z(t)[0] == pytest.approx(-b.altitude, abs=1e-6)
        assert b.controls()[0] == pytest.approx(b.trim.values["F"])


def test_a_member_of_the_family_has_no_free_parameter_and_its_values():
    sc = scenario_from_dict(slow())
    m = sc.at({"V": 40.0})
    assert not m.free_parameters and m.parameter_values() == {"V": 40.0}
    assert m.x(2.0) == pytest.approx(80.0) and sc.x(2.0) == pytest.approx(68.0)
    with pytest.raises(InputError, match="outside"):
        sc.at({"V": 70.0})
    with pytest.raises(InputError, match="unknown key 'W'"):
        sc.at({"W": 40.0})


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d["parameters"]["V"].update(nominal=3), r"\[parameters.V\]: unknown key 'nominal'"),
        (lambda d: d["parameters"]["V"].update(min=70.0), r"V: min = 70 is above max = 60"),
        (lambda d: d["parameters"]["V"].update(value=80.0), r"V: value = 80 is outside \[min, max\]"),
        (lambda d: d["parameters"].update(pi={"value": 1, "min": 0, "max": 2}), "shadow the built-in constant"),
        (lambda d: d["flat_outputs"].update(x={"basis": "bezier", "knots": []}), r"unknown key 'knots'"),
        (lambda d: d["flat_outputs"].update(x={"basis": "bspline"}), r"basis must be one of 'bezier'"),
        (lambda d: d.update(bounded={"cost": "fuel"}), r"cost must be one of"),
        (lambda d: d.update(bounded={"costs": "thrust"}), r"unknown key 'costs'"),
        (
            lambda d: d.update(boundary={"start": {"V": 40.0, "altitude": 500.0, "heading": 0.0}}),
            "unknown key 'heading'",
        ),
        (lambda d: d.update(boundary={"start": {"V": 40.0}}), r"\[boundary.start\]: missing 'altitude'"),
        (lambda d: d["time"].update(nodes=3), "step = 5.0 and nodes = 3 give the same quantity twice"),
    ],
)
def test_bad_bounded_input_is_one_line(change, message):
    data = slow()
    change(data)
    with pytest.raises(InputError, match=message) as exc:
        scenario_from_dict(data, where="s.toml")
    assert "\n" not in str(exc.value)


def test_a_boundary_trim_that_contradicts_the_fourth_flat_output_is_refused():
    data = slow()
    data["boundary"] = {"start": {"V": 40.0, "altitude": 500.0, "beta": 0.1}}
    with pytest.raises(InputError, match=r"fourth flat output beta = 0 at t = 0 s differs from the trim's beta"):
        scenario_from_dict(data, where="s.toml")


# --- the optimizer -----------------------------------------------------------------------------------------


def test_the_optimum_is_within_every_limit_on_the_verdicts_grid(bounded_slow):
    r = bounded_slow
    assert isinstance(r, BoundedResult) and r.feasible and r.infeasible_line() is None
    assert 35.0 < r.optimum["V"] < 38.0  # alpha = 12 deg at about 36.3 m/s
    assert [a["name"] for a in r.active] == ["alpha"] and r.active[0]["side"] == "upper"
    assert r.active[0]["value"] < r.active[0]["bound"]  # inside, by the margin
    frame = r.plan.limit_frame()
    assert frame.index[1] - frame.index[0] <= 0.01 + 1e-12
    assert limit_violations(r.plan.aircraft, frame, r.plan.env) == []
    assert r.plans_evaluated >= 3 and r.plans_failed == 0 and r.cost == pytest.approx(((r.optimum["V"] - 34) / 26) ** 2)
    assert not r.scenario.free_parameters and r.plan.problem.x(1.0) == pytest.approx(r.optimum["V"])


def test_infeasible_bounds_name_the_binding_limit_and_its_best_value(infeasible_slow):
    r = infeasible_slow
    assert not r.feasible and r.optimum["V"] == pytest.approx(35.0)  # the least violation: the fastest
    line = r.infeasible_line()
    assert "\n" not in line and "binding limit alpha" in line and "worst 13.1" in line and "V = 35" in line
    assert r.binding["name"] == "alpha" and r.binding["worst"] > r.binding["limit"]


def test_a_failing_plan_is_a_violation_not_an_error():
    # above 20 km the ISA ends: the plan raises a DomainError, which the optimizer sees as every limit violated
    data = slow(value=40.0, min=40.0, max=40.0)
    data["parameters"]["h"] = {"value": 500.0, "min": 500.0, "max": 30000.0}
    data["flat_outputs"]["z"] = "-h"
    sc = scenario_from_dict(data)
    from planners.bounded import _Problem

    pb = _Problem(sc)
    ev = pb.evaluate(np.array([1.0]))
    assert ev.failure is not None and "20" in ev.failure
    assert np.all(pb.constraints(np.array([1.0])) == FAILED) and pb.failed == 1
    assert math.isfinite(pb.objective(np.array([1.0])))


def test_plan_scenario_plans_a_bounded_scenario_bounded(bounded_slow):
    sc = scenario_from_dict(slow())
    plan = plan_scenario(sc)
    assert plan.bounded is not None and plan.bounded.optimum["V"] == pytest.approx(bounded_slow.optimum["V"])
    with pytest.raises(InputError, match="planned bounded with its own method"):
        plan_scenario(sc, e=2)


def test_control_rate_cost_of_a_ramp():
    t = np.linspace(0.0, 10.0, 11)
    rates = np.zeros((5, 11))
    rates[2] = 0.1  # dl at 0.1 rad/s
    s = np.ones(5)
    s[2] = 0.5
    assert control_rate_cost(t, rates, s) == pytest.approx(0.04)
    sc = load_scenario("twin-otter-single-engine")
    scales = control_scales(sc.aircraft, sc.env)
    assert scales[2] == pytest.approx(math.radians(20.0)) and scales[1] == 1.0


def test_duration_cost_with_a_free_end_time():
    data = slow(value=40.0, min=40.0, max=40.0)
    data["parameters"]["T"] = {"value": 10.0, "min": 4.0, "max": 10.0}
    data["time"] = {"t0": 0.0, "t1": "T", "nodes": 3}
    data["bounded"] = {"cost": "duration"}
    r = plan_bounded(scenario_from_dict(data))
    assert r.feasible and r.optimum["T"] == pytest.approx(4.0, abs=1e-3) and r.cost == pytest.approx(r.optimum["T"])
    assert r.plan.t1 == pytest.approx(r.optimum["T"]) and len(r.plan.t_nodes) == 3


def test_a_violation_beyond_one_scale_is_compressed_not_clipped():
    """Beyond a bound by more than its scale, a constraint still grows as the violation shrinks (the least worst
    violation of infeasible bounds needs the slope), and a failed plan stays the worst value."""
    from planners.bounded import _compressed

    d = np.array([-1e9, -1000.0, -30.0, -4.5, -1.0, -0.5, 0.0, 3.0, 50.0])
    c = _compressed(d)
    assert np.all(np.diff(c[1:]) > 0)  # monotone above the floor
    assert c[0] == c[1] == FAILED and c[4] == -1.0 and c[5] == -0.5 and c[-1] == 10.0
    assert -4.5 < c[3] < -1.0 and c[2] < c[3]
