"""Batched in-house engine: many dispersed aircraft at once agree with single runs to 1e-6 m."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gna.errors import InputError
from harness.campaign import dispersed_aircraft, draw_sample, load_campaign
from harness.campaign.batch import batched_aircraft, simulate_batch
from harness.campaign.montecarlo import batch_metrics, fly_batch
from harness.engines import InHouseEngine
from harness.validation import plan_case
from harness.validation.closed import closed_loop_setup

TINY = Path(__file__).parent / "tiny.toml"


@pytest.fixture(scope="module")
def flown():
    camp = load_campaign(TINY)
    tasks = camp.tasks(4)
    planned = plan_case(tasks[0].spec.case)
    plan = planned.plan
    draws = [draw_sample(plan.aircraft, t.dispersion, t.seed) for t in tasks]
    setup = closed_loop_setup(plan, planned.scenario)
    singles = [
        InHouseEngine().simulate(
            dispersed_aircraft(plan.aircraft, d),
            setup.controller.controls,
            (plan.t0, plan.t1),
            setup.x0 + d.offsets,
            env=plan.env,
            controller=setup.controller,
            dt_out=0.1,
        )
        for d in draws
    ]
    return planned, draws, setup, singles


@pytest.mark.parametrize("method", ["DOP853", "DOP853-stacked"])
def test_batched_closed_loop_agrees_with_single_runs(flown, method):
    planned, draws, setup, singles = flown
    res, ctl, j = fly_batch(planned.plan, planned.scenario, draws, dt_out=0.1, method=method)
    assert list(res.status) == ["completed"] * len(draws)
    for i, r in enumerate(singles):
        assert np.allclose(res.t, r.df.index.to_numpy(), atol=1e-12, rtol=0)
        gap = np.linalg.norm(r.df[["x", "y", "z"]].to_numpy() - res.X[:, :3, i], axis=1).max()
        assert gap <= 1e-6
        assert np.abs(r.df[["V", "alpha", "beta", "mu"]].to_numpy() - res.X[:, [3, 6, 7, 8], i]).max() <= 1e-7
        assert np.abs(r.controller_states.to_numpy() - res.XC[:, :, i]).max() <= 1e-6
    if method == "DOP853":
        sat = [m["saturated_s"] for m in batch_metrics(res, planned.plan, j, ctl)]
        assert sat == pytest.approx([ctl.saturated_time(r.df, r.controller_states.to_numpy())["any"] for r in singles])
        assert any(s > 0 for s in sat)  # the saturation switches are part of what agrees


def test_batched_open_loop_and_shapes(flown):
    planned, draws, _, _ = flown
    plan = planned.plan
    res, ctl, j = fly_batch(plan, planned.scenario, draws[:2], loop="open", dt_out=0.5)
    assert ctl is None and res.X.shape == (len(res.t), 12, 2) and res.XC.shape == (len(res.t), 0, 2)
    single = InHouseEngine().simulate(
        dispersed_aircraft(plan.aircraft, draws[1]),
        plan.control_function(j),
        (plan.t0, plan.t1),
        np.asarray(plan.initial_state(j)) + draws[1].offsets,
        env=plan.env,
        dt_out=0.5,
    )
    assert np.linalg.norm(single.df[["x", "y", "z"]].to_numpy() - res.X[:, :3, 1], axis=1).max() <= 1e-6
    with pytest.raises(InputError, match="shape"):
        simulate_batch(
            batched_aircraft(plan.aircraft, draws[:1]), np.zeros((1, 11)), plan.control_function(j), (0.0, 1.0)
        )
    with pytest.raises(InputError, match="unknown batched integrator"):
        simulate_batch(
            plan.aircraft, np.asarray(plan.initial_state(j))[None], plan.control_function(j), (0.0, 1.0), method="euler"
        )


def test_a_sample_over_its_step_budget_is_stalled_and_the_others_go_on(flown):
    planned, draws, setup, singles = flown
    plan = planned.plan
    res, _, _ = fly_batch(plan, planned.scenario, draws[:2], dt_out=0.1, max_steps=3)
    assert list(res.status) == ["stalled", "stalled"] and np.all(res.t_end < plan.t1)
    assert np.all(res.X[-1] == res.X[-2])  # frozen at the last state reached


def test_a_sample_reaching_the_ground_stops_as_in_the_single_engine():
    # The batched engine applies the engines' domain (gna.trajectory.inside_domain): with ground effect a CG
    # at the ground stops the sample ("domain") near where the single run stops; the sample high above goes on.
    from gna.aircraft import load_aircraft
    from gna.atmosphere import ISA, Environment
    from gna.eom import Controls
    from gna.ground_effect import GroundEffect
    from gna.simulate import simulate
    from gna.trim import trim_level

    ac = load_aircraft("twin-otter")
    env = Environment(ISA(), ground_effect=GroundEffect(elevation=0.0))
    tr = trim_level(ac, 45.0, 300.0, env=env)
    x_high = np.array(tr.state, dtype=float)
    x_low = x_high.copy()
    x_low[2], x_low[4] = -6.0, -0.1  # 6 m above the ground, descending at 0.1 rad
    u = np.array(Controls(*tr.controls), dtype=float)
    res = simulate_batch(ac, np.stack([x_low, x_high]), lambda t: u, (0.0, 4.0), env=env, dt_out=0.1)
    single = simulate(ac, lambda t: u, (0.0, 4.0), x_low, env=env, dt_out=0.1)
    assert single.status == "domain" and "ground" in single.message
    assert list(res.status) == ["domain", "completed"]
    assert (
        0.5 < res.t_end[0] < 4.0 and single.t_end <= res.t_end[0] <= single.t_end + 0.1
    )  # checked at the output steps (dt_out)
    assert -res.X[-1, 2, 0] <= 0.5  # frozen at (one step past) the ground crossing
