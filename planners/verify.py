"""Open-loop verification of a plan: its controls flown on the full model.

The figure of merit of a motion planner for a non-flat model: fly the planned controls open loop on
the *full* model (no feedback), from the plan's own initial state, and measure how far the position
leaves the prescribed flat outputs.  The same quantity judges any planner (the collocation benchmark
uses it on its own solutions), so it takes plain callables, not a :class:`~planners.plan.Plan` only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gna.eom import STATE_NAMES
from gna.errors import InputError
from gna.simulate import simulate

#: Integrator settings of the verification flight: tight enough that the integrator's own error
#: (below 1e-7 m over the paper's manoeuvres) is far under any planner's.
VERIFY_METHOD = "DOP853"
VERIFY_RTOL = 1e-10
VERIFY_ATOL = 1e-10


@dataclass(frozen=True)
class OpenLoopCheck:
    """The result of :func:`open_loop_error`.

    Attributes
    ----------
    max_position_error_m : float
        ``max_t |(x, y, z)(t) - (x, y, z)_flat(t)|`` [m] over the output grid (NaN if the flight
        stopped early; see ``status``).
    t_worst : float
        Time [s] of that largest distance.
    max_angle_error_rad : float
        Largest deviation [rad] of gamma, chi, alpha, beta, mu from the plan's own states.
    status : str
        The flight's status (``"completed"``, ``"domain"``, ``"failed"``).
    message : str
        The flight's message when it did not complete.
    settings : dict
        Integrator, tolerances and output step of the flight.
    """

    max_position_error_m: float
    t_worst: float
    max_angle_error_rad: float
    status: str
    message: str
    settings: dict


def open_loop_error(plan, j: int = -1, *, dt_out: float | None = None) -> OpenLoopCheck:
    """Fly a plan's controls open loop on the full model and measure the distance to the flat outputs.

    Parameters
    ----------
    plan : Plan
        A plan (:class:`planners.plan.Plan`): its problem's flat outputs ``x(t), y(t), z(t)`` [m,
        NED], its controls ``plan.control_function(j)`` and initial state ``plan.initial_state(j)``.
    j : int
        Iterate whose controls are flown (default: the last).
    dt_out : float, optional
        Output step [s] on which the distance is measured; default a tenth of the smallest node
        interval (the controls' structure between nodes is resolved), at most 0.01 s.

    Returns
    -------
    OpenLoopCheck
        Position error [m] against the exact flat outputs, its time, the angle deviation [rad].

    Raises
    ------
    InputError
        Unknown iterate.

    Notes
    -----
    The full model (``model="full"``) is integrated by DOP853 with ``rtol = atol = 1e-10``; the
    reference is the flat outputs themselves (the scenario's expressions), not the plan's
    interpolation of them.
    """
    if not -len(plan.iterates) <= j < len(plan.iterates):
        raise InputError(f"iterate j = {j} not in the plan (J = {plan.J})")
    tn = np.asarray(plan.t_nodes, dtype=float)
    if dt_out is None:
        dt_out = min(0.01, float(np.min(np.diff(tn))) / 10.0)
    n = max(1, int(round((plan.t1 - plan.t0) / dt_out)))
    grid = np.linspace(plan.t0, plan.t1, n + 1)
    run = simulate(plan.aircraft, plan.control_function(j), (plan.t0, plan.t1), plan.initial_state(j),
                   env=plan.env, t_eval=grid, method=VERIFY_METHOD, rtol=VERIFY_RTOL, atol=VERIFY_ATOL)
    settings = {"method": VERIFY_METHOD, "rtol": VERIFY_RTOL, "atol": VERIFY_ATOL, "dt_out": (plan.t1 - plan.t0) / n,
                "model": "full", "iterate": j % len(plan.iterates)}
    df = run.df
    t = df.index.to_numpy(dtype=float)
    pb = plan.problem
    flat = np.stack([np.broadcast_to(np.asarray(f(t), dtype=float), t.shape) for f in (pb.x, pb.y, pb.z)])
    err = np.sqrt(((df[["x", "y", "z"]].to_numpy().T - flat) ** 2).sum(axis=0))
    ref = plan.state(t, j)
    names = ("gamma", "chi", "alpha", "beta", "mu")
    ang = max(float(np.max(np.abs(df[k].to_numpy() - ref[STATE_NAMES.index(k)]))) for k in names)
    if run.status != "completed" or not np.all(np.isfinite(err)):
        return OpenLoopCheck(float("nan"), float(run.t_end), float("nan"), run.status, run.message, settings)
    k = int(np.argmax(err))
    return OpenLoopCheck(float(err[k]), float(t[k]), ang, run.status, "", settings)
