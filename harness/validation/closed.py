"""Closed loop of a validation case: a tracking feedback along the plan.

For ``loop = "closed"`` a case flies the feedforward controls of one plan
iterate (default the last, the generalized plan; 0 is the flat plan, the
paper's dark-blue curve) plus the tracking feedback of the scenario's
``[tracking] design``: the paper's (:func:`planners.tracking.tracking_controller`,
the default) or the time-varying LQR (:func:`planners.lqr.lqr_controller`), from
the iterate's initial state.  The design, lambda lists or tolerances, feedforward
iterate, saturation and an optional
perturbation of the flown aircraft and initial state come from the scenario's
``[tracking]`` table (:class:`planners.scenario.Tracking`, every setting with a
default).  The plan itself is always made with the nominal aircraft: a
perturbation changes only what is flown.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from gna.errors import InputError
from planners.lqr import lqr_controller
from planners.tracking import tracking_controller


@dataclass(frozen=True)
class ClosedLoopSetup:
    """What the engines fly in a closed-loop case.

    Attributes
    ----------
    controller : planners.tracking.TrackingController
        The tracking feedback (integral states ``I1..I4``, or ``I1..I3`` with the thrust output); a
        :class:`planners.lqr.LQRController` with ``design = "lqr"``.  Its ``design`` names which.
    aircraft : gna.aircraft.Aircraft
        The aircraft flown (the plan's, or a perturbed copy).
    x0 : ndarray, shape (12,)
        Initial state flown [SI, rad]: the feedforward iterate's, plus any offset.
    feedforward_iterate : int
        Plan iterate whose controls are the feedforward and whose states the reference.
    perturbation : object or None
        The perturbation applied (None: nominal aircraft and initial state).
    """

    controller: Any
    aircraft: Any
    x0: np.ndarray
    feedforward_iterate: int
    perturbation: Any = None


def closed_loop_setup(plan, scenario, *, feedforward_iterate: int | None = None) -> ClosedLoopSetup:
    """Build the tracking controller, flown aircraft and initial state for a plan.

    Parameters
    ----------
    plan : planners.plan.Plan
        A feasible plan (flat output beta, mu or F).
    scenario : planners.scenario.Scenario
        Its scenario; its ``tracking`` settings (design, lambdas or tolerances,
        feedforward iterate, saturation, perturbation) are used.
    feedforward_iterate : int, optional
        Overrides the scenario's feedforward iterate.

    Returns
    -------
    ClosedLoopSetup

    Raises
    ------
    InputError
        An iterate not in the plan.
    """
    tr = scenario.tracking
    j = tr.feedforward_iterate if feedforward_iterate is None else feedforward_iterate
    if not -len(plan.iterates) <= j <= plan.J:
        raise InputError(f"feedforward iterate j = {j} not in the plan (J = {plan.J})")
    if tr.design == "lqr":
        controller = lqr_controller(plan, feedforward_iterate=j, saturate=tr.saturate, tolerances=tr.tolerances)
    else:
        controller = tracking_controller(plan, tr.lambdas, feedforward_iterate=j, saturate=tr.saturate)
    aircraft, x0 = plan.aircraft, np.asarray(plan.initial_state(j), dtype=float)
    pert = tr.perturbation
    if pert is not None:
        from gna.perturbation import offset_state, perturbed_aircraft

        aircraft = perturbed_aircraft(aircraft, pert)
        x0 = np.asarray(offset_state(x0, pert), dtype=float)
    return ClosedLoopSetup(
        controller=controller, aircraft=aircraft, x0=x0, feedforward_iterate=j % len(plan.iterates), perturbation=pert
    )


def saturated_seconds(controller, run) -> dict:
    """Seconds each control of a closed-loop run spent commanded beyond its limits.

    Parameters
    ----------
    controller : planners.tracking.TrackingController
        The controller flown.
    run : gna.trajectory.SimulationResult
        Its run, with ``controller_states``.

    Returns
    -------
    dict
        ``{"F": s, "eta": s, "dl": s, "dm": s, "dn": s, "any": s}`` [s].
    """
    states = None if run.controller_states is None else run.controller_states.to_numpy(dtype=float)
    if states is None:
        return {"any": 0.0}
    return controller.saturated_time(run.df, states)


def sampled_engines(engines: dict, controller_dt: float | None) -> dict:
    """The engines with the feedback's sampling interval set where they sample it.

    Parameters
    ----------
    engines : dict
        Engine label -> engine.
    controller_dt : float or None
        Sampling interval [s] (scenario ``[tracking] controller_dt``); None
        samples at every engine step.  Engines without the setting (the
        in-house engine evaluates the feedback continuously) are unchanged.

    Returns
    -------
    dict
        Engine label -> engine (copies where the setting changed).
    """
    from dataclasses import fields, is_dataclass, replace

    return {
        label: replace(e, controller_dt=controller_dt)
        if is_dataclass(e) and "controller_dt" in {f.name for f in fields(e)}
        else e
        for label, e in engines.items()
    }
