"""The paper's three manoeuvres (issue 4, tests 8(a)-(c) on the bundled scenarios).

Full plans are cheap (well under a second each); the open-loop integration of
8(c) is done over the scenario's span for the two slow manoeuvres and
the whole parabola for the aileron roll.
"""

from __future__ import annotations

import numpy as np
import pytest

from gna.simulate import simulate
from planners.generalized import plan_scenario
from planners.scenario import load_scenario

SCENARIOS = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")


@pytest.fixture(scope="module", params=SCENARIOS)
def paper_plan(request):
    sc = load_scenario(request.param)
    return sc, plan_scenario(sc, J=max(sc.J, 4))


def test_8a_simple_model_equations_at_nodes(paper_plan):
    sc, plan = paper_plan
    for j in (0, plan.J):
        r = plan.equation_residuals("simple", j)
        d = plan.node_derivatives(j)
        for name in r.columns:
            scale = max(1.0, float(np.max(np.abs(getattr(d, name)))))
            assert float(r[name].abs().max()) / scale <= 1e-8, (sc.name, j, name)
    assert plan.worst_newton_residual() < 1e-8


def test_8b_full_residual_decreases_with_j(paper_plan):
    sc, plan = paper_plan
    res = [float(plan.equation_residuals("full", j).abs().max().max()) for j in range(plan.J + 1)]
    assert all(b < a for a, b in zip(res, res[1:])), (sc.name, res)


def test_8c_open_loop_follows_generalized_plan(paper_plan):
    sc, plan = paper_plan
    J = plan.J
    r = simulate(
        sc.aircraft, plan.control_function(J), (plan.t0, plan.t1), plan.initial_state(J), env=sc.env, dt_out=0.1
    )
    assert r.completed, r.message
    ref = plan.to_dataframe(r.df.index.values, j=J)
    pos = np.sqrt((r.df["x"] - ref["x"]) ** 2 + (r.df["y"] - ref["y"]) ** 2 + (r.df["z"] - ref["z"]) ** 2).max()
    ang = max(float((r.df[k] - ref[k]).abs().max()) for k in ("alpha", "beta", "mu", "gamma", "chi"))
    # bounds: see docs/planning.md (measured deviations and why)
    assert pos < BOUNDS[sc.name][0], (sc.name, pos)
    assert ang < BOUNDS[sc.name][1], (sc.name, ang)


#: (position [m], angle [rad]) bounds of test 8(c), about 3x the measured deviations at the bundled
#: settings (``python research/planning_report.py``; docs/planning.md explains them): 25 um / 1.3e-6 rad
#: (Twin Otter, J = 6), 3.1 mm / 3.4e-6 rad (forward slip, J = 6: its full-model residual 3e-6 m/s^2
#: integrated over 120 s), 0.34 mm / 8.3e-6 rad (roll, J = 7); controls between nodes by Hermite
#: interpolation of the series, so the residual left by J dominates.
BOUNDS = {
    "twin-otter-single-engine": (7.5e-5, 4e-6),
    "gtm-forward-slip": (1e-2, 1e-5),
    "gtm-aileron-roll": (1e-3, 2.5e-5),
}


def test_aileron_roll_convergence_table():
    sc = load_scenario("gtm-aileron-roll")
    plan = plan_scenario(sc)
    assert plan.J == 7
    table = plan.convergence_table(("F", "dl", "dm", "dn"), [-1.9])
    assert table.shape == (4, 8)
    # successive differences shrink: the iteration converges at t = -1.9 s
    for var in ("F", "dl", "dm", "dn"):
        row = table.loc[(-1.9, var)].to_numpy()
        steps = np.abs(np.diff(row))
        assert steps[-1] < steps[0] / 10, (var, row)
