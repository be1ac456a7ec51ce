"""The aircraft as an instance of the generic almost chained system (planners.systems.aircraft):
the generic machinery of planners.chained reproduces the aircraft planners."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from planners.chained import flat_parametrization, generalized_parametrization, newton_parametrization
from planners.generalized import plan_motion, plan_scenario
from planners.scenario import load_scenario, scenario_from_dict
from planners.systems.aircraft import aircraft_system

PAPER = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")


def worst_relative_difference(aircraft_iterates, chained_iterates, nodes: int) -> float:
    """Max over iterates, variables and Taylor coefficients of |difference| / max |value| (per coefficient)."""
    worst = 0.0
    assert len(aircraft_iterates) == len(chained_iterates)
    for a, b in zip(aircraft_iterates, chained_iterates):
        for name, s in a.series.items():
            ca = np.real(np.broadcast_to(s.coeffs, (nodes, s.order + 1)))
            cb = np.real(np.broadcast_to(b[name].coeffs, (nodes, b[name].order + 1)))
            k = min(ca.shape[1], cb.shape[1])
            assert k == s.order + 1 or name in ("eta", "dn"), name  # same orders (inputs: higher)
            scale = np.maximum(np.max(np.abs(ca[:, :k]), axis=0), 1e-12)
            worst = max(worst, float(np.max(np.abs(ca[:, :k] - cb[:, :k]) / scale)))
    return worst


@pytest.mark.parametrize("name", PAPER)
def test_generic_chained_planner_reproduces_the_aircraft_planner(name):
    """States and controls of every iterate, every Taylor coefficient at every node, agree to 1e-7
    relative (the same equations on the same data; the aircraft planner's iterates j >= 1 end their
    chord steps within the Newton tolerance: measured 7.6e-8 on the forward slip, coefficients of size
    3e-12 differing by 2e-19; the flat plan J = 0 to 1e-9)."""
    sc = load_scenario(name)
    J = 2
    ref = plan_scenario(sc, J=J)
    system = aircraft_system(sc.problem())
    assert system.r == 4 and system.L == 2
    assert system.stage_of("zeta") == 3 and system.stage_of("dl") == 5
    plan = generalized_parametrization(system, sc.t_nodes, None, J, e=ref.e)  # the scenario's output order
    assert worst_relative_difference(ref.iterates, plan.iterates, len(sc.t_nodes)) < 1e-7
    # the flat outputs given explicitly, as a caller of the generic API does
    p = sc.problem()
    zeta = {"x": p.x, "y": p.y, "z": p.z, "zeta": p.zeta.value}
    ref0 = plan_scenario(sc, J=0)
    plan0 = generalized_parametrization(system, sc.t_nodes, zeta, 0, e=ref0.e)
    assert worst_relative_difference(ref0.iterates, plan0.iterates, len(sc.t_nodes)) < 1e-9


def _variant(name: str, **flat_outputs):
    sc = load_scenario(name)
    raw = copy.deepcopy(sc.raw)
    raw["flat_outputs"].update(flat_outputs)
    raw["flat_outputs"] = {k: v for k, v in raw["flat_outputs"].items() if v is not None}
    raw["time"]["step"] = 2.0
    raw.pop("tracking", None)
    return scenario_from_dict(raw, name)


@pytest.mark.parametrize(
    "flat_outputs",
    [
        {"eta": None, "dn": "0.02"},  # rudder fixed: eta a control
        {"zeta": "mix", "f1": "1 + t/100", "f2": "0.5", "zeta_value": "0.001*sin(t/10)"},  # mixed fourth output
    ],
)
def test_fixed_rudder_and_mixed_output(flat_outputs):
    sc = _variant("twin-otter-single-engine", **flat_outputs)
    ref = plan_scenario(sc, J=1)
    plan = generalized_parametrization(aircraft_system(sc.problem()), sc.t_nodes, None, 1, e=ref.e)
    assert worst_relative_difference(ref.iterates, plan.iterates, len(sc.t_nodes)) < 1e-9
    if "dn" in flat_outputs:
        assert "eta" in plan.system.stages[-1].unknowns
        assert np.allclose(np.real(plan.iterates[-1]["dn"].constant_term), 0.02)


def test_every_stage_equation_holds_on_the_closed_form_solution():
    """Stages 1 and 3 are solved in closed form (planners.flat.stage1, stage3); their equations,
    written with gna.eom (kinematics; wind_angle_rates with the forces of the force equations),
    vanish on that solution to rounding: the two forms are the same equations."""
    sc = load_scenario("gtm-aileron-roll")
    system = aircraft_system(sc.problem())
    tn = sc.t_nodes
    sol, reports = flat_parametrization(system, tn, 7)
    assert sorted(reports) == [2, 4]  # Newton on stages 2 and 4 only
    for h, stage in enumerate(system.stages, start=1):
        k = 7 - h
        v = {n: s.truncate(min(s.order, k)) for n, s in sol.items()}
        v.update({n + "'": s.derivative().truncate(min(s.order - 1, k)) for n, s in sol.items() if s.order >= 1})
        v.update({n: system.neglected_start(n) for n in stage.neglected})
        for r in stage.residual(v):
            c = np.abs(np.real(np.broadcast_to(r.coeffs, (len(tn), r.order + 1))))
            assert np.max(c) < 1e-9, (h, np.max(c))


def test_generic_newton_matches_the_aircraft_newton():
    """Newton on the fixed point through the generic chained Jacobian (complex-step partials of the
    four stage equations) converges as the aircraft's own (planners.generalized_newton)."""
    sc = load_scenario("gtm-aileron-roll")
    p = sc.problem()
    tn = sc.t_nodes[::2]
    ref = plan_motion(p, tn, 1, method="newton")
    plan = newton_parametrization(aircraft_system(p), tn, None, J=1, tol=1e-12)
    assert plan.residuals[-1] < 1e-12
    assert np.allclose(plan.residuals, ref.generalized["residual"], rtol=1e-6, atol=1e-13)
    for name in ("alpha", "beta", "mu", "F", "p", "q", "r", "dl", "dm", "dn"):
        a = np.real(ref.iterates[-1].series[name].constant_term)
        b = np.real(plan.iterates[-1][name].constant_term)
        assert np.max(np.abs(a - b)) <= 1e-9 * max(1.0, np.max(np.abs(a))), name
