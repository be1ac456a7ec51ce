"""The aircraft as an almost chained system (planners.flat.aircraft_system): its stages, the fixed
rudder and the mixed fourth flat output, planned by the one generic machinery (planners.chained)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from planners.chained import flat_parametrization, generalized_parametrization
from planners.flat import aircraft_system
from planners.generalized import plan_scenario
from planners.scenario import load_scenario, scenario_from_dict


def _variant(name: str, **flat_outputs):
    sc = load_scenario(name)
    raw = copy.deepcopy(sc.raw)
    raw["flat_outputs"].update(flat_outputs)
    raw["flat_outputs"] = {k: v for k, v in raw["flat_outputs"].items() if v is not None}
    raw["time"]["step"] = 2.0
    raw.pop("tracking", None)
    return scenario_from_dict(raw, name)


def test_the_aircraft_plan_is_the_chained_plan():
    """plan_scenario runs generalized_parametrization on the aircraft system: the same series, bit for bit,
    restricted to the 12 states and 5 controls (the prescribed eta at the surfaces' order)."""
    sc = load_scenario("gtm-aileron-roll")
    system = aircraft_system(sc.problem())
    assert system.r == 4 and system.L == 2
    assert system.stage_of("zeta") == 3 and system.stage_of("dl") == 5
    ref = plan_scenario(sc, J=2)
    plan = generalized_parametrization(system, sc.t_nodes, None, 2, e=ref.e)
    for a, b in zip(ref.iterates, plan.iterates):
        assert set(a.series) == {"x", "y", "z", "V", "gamma", "chi", "alpha", "beta", "mu", "F"} | {
            "p",
            "q",
            "r",
            "dl",
            "dm",
            "dn",
            "eta",
        }
        for name, s in a.series.items():
            k = s.order + 1
            assert np.array_equal(s.coeffs, b[name].coeffs[..., :k]), name
        assert a["eta"].order == a["dl"].order


def test_fixed_rudder_makes_eta_a_control():
    sc = _variant("twin-otter-single-engine", eta=None, dn="0.02")
    plan = plan_scenario(sc, J=1)
    assert "eta" in aircraft_system(sc.problem()).stages[-1].unknowns
    assert np.allclose(np.real(plan.iterates[-1]["dn"].constant_term), 0.02)
    assert plan.feasible and plan.iterate_residuals()[-1] < plan.iterate_residuals()[0]


def test_mixed_fourth_output_holds_at_the_nodes():
    sc = _variant("twin-otter-single-engine", zeta="mix", f1="1 + t/100", f2="0.5", zeta_value="0.001*sin(t/10)")
    plan = plan_scenario(sc, J=1)
    t = sc.t_nodes
    beta, mu = (np.real(plan.iterates[-1][n].constant_term) for n in ("beta", "mu"))
    assert np.max(np.abs((1 + t / 100) * beta + 0.5 * mu - 0.001 * np.sin(t / 10))) < 1e-11


def test_every_stage_equation_holds_on_the_closed_form_solution():
    """Stages 1 and 3 are solved in closed form (planners.flat.stage1, stage3); their equations,
    written with gna.eom (kinematics; wind_angle_rates with the forces of the force equations),
    vanish on that solution to rounding: the two forms are the same equations."""
    sc = load_scenario("gtm-aileron-roll")
    system = aircraft_system(sc.problem())
    tn = sc.t_nodes
    sol = flat_parametrization(system, tn, 7)
    assert sorted(sol.reports) == ["stage2", "stage4"]  # Newton on stages 2 and 4 only
    derived = system.derived(dict(sol), 7)
    for h, stage in enumerate(system.stages, start=1):
        k = 7 - h
        v = {n: s.truncate(min(s.order, k)) for n, s in sol.items()}
        v.update({n + "'": s.derivative().truncate(min(s.order - 1, k)) for n, s in sol.items() if s.order >= 1})
        v.update({n: s.truncate(min(s.order, k)) for n, s in derived.items()})
        v.update({n: system.neglected_start(n) for n in stage.neglected})
        for r in stage.residual(v):
            c = np.abs(np.real(np.broadcast_to(r.coeffs, (len(tn), r.order + 1))))
            assert np.max(c) < 1e-9, (h, np.max(c))


@pytest.mark.parametrize("method", ["fixed-point", "newton"])
def test_iterates_pickle_without_the_system(method):
    """An iterate's reusable series (and the aircraft system's closures they reference) stay behind."""
    import pickle

    sc = _variant("gtm-aileron-roll")
    plan = plan_scenario(sc, J=1, method=method)
    assert plan.iterates[0]._inputs["system"] is aircraft_system(plan.problem)
    back = pickle.loads(pickle.dumps(plan.iterates))
    assert np.array_equal(back[-1]["dl"].coeffs, plan.iterates[-1]["dl"].coeffs)
    assert back[0]._inputs is None
