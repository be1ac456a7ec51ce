"""Monte Carlo of one plan over dispersed aircraft with the batched in-house engine.

:func:`fly_batch` flies every sample of a list of draws at once
(:func:`harness.campaign.batch.simulate_batch`), closed loop with the
scenario's tracking feedback about the nominal plan, or open loop;
:func:`batch_metrics` gives each sample the figures of merit of a campaign case
(the in-house run's part of :func:`harness.campaign.execute.run_sample`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..validation.closed import closed_loop_setup
from .batch import batched_aircraft, simulate_batch

__all__ = ["fly_batch", "batch_metrics"]


def fly_batch(
    plan,
    scenario,
    draws,
    *,
    loop: str = "closed",
    t_span=None,
    dt_out: float = 0.05,
    method: str = "DOP853",
    max_steps: int | None = None,
):
    """Fly a plan on many dispersed aircraft at once.

    Parameters
    ----------
    plan : planners.plan.Plan
        The nominal plan.
    scenario : planners.scenario.Scenario
        Its scenario (``[tracking]`` settings; a perturbation there is ignored).
    draws : sequence of harness.campaign.sampling.SampleDraw
        One per sample (:func:`harness.campaign.sampling.draw_sample` on ``plan.aircraft``).
    loop : {"closed", "open"}
        With the tracking feedback, or the plan's controls alone.
    t_span : (float, float), optional
        Default the plan's span [s].
    dt_out : float
        Output grid [s].
    method : str
        Integrator (:data:`harness.campaign.batch.BATCH_METHODS`).
    max_steps : int, optional
        Per-sample step budget (:func:`harness.campaign.batch.simulate_batch`).

    Returns
    -------
    (BatchResult, TrackingController or None, int)
        The runs, the controller flown (closed loop) and the plan iterate tracked.
    """
    span = (plan.t0, plan.t1) if t_span is None else t_span
    aircraft = batched_aircraft(plan.aircraft, draws)
    offsets = np.stack([d.offsets for d in draws])
    if loop == "closed":
        nominal = replace(scenario, tracking=replace(scenario.tracking, perturbation=None))
        setup = closed_loop_setup(plan, nominal)
        ctl, j = setup.controller, setup.feedforward_iterate
        res = simulate_batch(
            aircraft,
            setup.x0[None, :] + offsets,
            ctl.controls,
            span,
            env=plan.env,
            controller=ctl,
            dt_out=dt_out,
            method=method,
            max_steps=max_steps,
        )
        return res, ctl, j
    j = plan.J
    x0 = np.asarray(plan.initial_state(j), dtype=float)
    res = simulate_batch(
        aircraft,
        x0[None, :] + offsets,
        plan.control_function(j),
        span,
        env=plan.env,
        dt_out=dt_out,
        method=method,
        max_steps=max_steps,
    )
    return res, None, j


def batch_metrics(result, plan, j: int, controller=None) -> list[dict]:
    """Per sample: status, end, largest distance to the flat outputs, seconds saturated.

    Parameters
    ----------
    result : BatchResult
        From :func:`fly_batch`.
    plan : planners.plan.Plan
        The plan (its iterate ``j`` is the reference).
    j : int
        Plan iterate tracked.
    controller : TrackingController, optional
        The feedback flown (for the saturation time).

    Returns
    -------
    list of dict
        ``status``, ``t_end`` [s], ``max_position_error_m``, ``max_position_error_after_5s_m`` [m]
        (None when empty or not finite), ``saturated_s`` [s] (rectangle rule on the grid, as
        :meth:`planners.tracking.TrackingController.saturated_time`).
    """
    t = result.t
    ref = np.asarray(plan.state(t, j), dtype=float)  # (12, m)
    dist = np.linalg.norm(result.X[:, :3, :] - ref[:3].T[:, :, None], axis=1)  # (m, n)
    sat = np.zeros((len(t), result.X.shape[2]), dtype=bool)
    if controller is not None and controller.saturate:
        free = replace(controller, saturate=False, samples=None)
        for k, tk in enumerate(t):
            du, _, u = free.output_and_derivative_many(float(tk), result.X[k], result.XC[k], with_feedforward=True)
            tot = u + du
            sat[k] = ((tot < controller.lower[:, None]) | (tot > controller.upper[:, None])).any(axis=0)
    dt = np.diff(t, append=t[-1])
    out = []
    for i in range(result.X.shape[2]):
        valid = t <= result.t_end[i] + 1e-12
        after = valid & (t >= plan.t0 + 5.0)

        def worst(mask):
            v = dist[mask, i]  # noqa: B023
            return float(v.max()) if v.size and np.isfinite(v).all() else None

        out.append(
            {
                "status": str(result.status[i]),
                "t_end": float(result.t_end[i]),
                "max_position_error_m": worst(valid),
                "max_position_error_after_5s_m": worst(after),
                "saturated_s": float(np.sum(dt[valid & sat[:, i]])),
            }
        )
    return out
