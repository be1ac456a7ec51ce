"""Open-loop verification of a plan: its controls flown on the full model.

The figure of merit of a motion planner for a non-flat model: fly the planned controls open loop on
the *full* model (no feedback), from the plan's own initial state, and measure how far the position
leaves the prescribed flat outputs.  The same quantity judges any planner (the collocation benchmark
uses it on its own solutions): :func:`open_loop_check` takes plain controls and an initial state,
:func:`open_loop_error` a :class:`~planners.plan.Plan`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

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


def verification_grid(t_nodes) -> np.ndarray:
    """Output times of a verification flight: a tenth of the smallest node step, at most 0.01 s.

    Parameters
    ----------
    t_nodes : array_like, shape (n,)
        The planning grid [s], increasing.

    Returns
    -------
    ndarray, shape (N,)
        Evenly spaced times [s] from ``t_nodes[0]`` to ``t_nodes[-1]``.
    """
    tn = np.asarray(t_nodes, dtype=float)
    dt_out = min(0.01, float(np.min(np.diff(tn))) / 10.0)
    n = max(1, int(round((tn[-1] - tn[0]) / dt_out)))
    return np.linspace(tn[0], tn[-1], n + 1)


def open_loop_check(problem, controls, x0, t_eval, reference=None) -> OpenLoopCheck:
    """Fly controls open loop on the full model and measure the distance to a problem's flat outputs.

    Parameters
    ----------
    problem : FlatProblem
        Aircraft, environment and the flat outputs ``x(t), y(t), z(t)`` [m, NED]
        (:class:`planners.flat.FlatProblem`).
    controls : callable
        ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])`` (any planner's controls; a
        :class:`gna.piecewise.PiecewisePolynomial` is cheapest).
    x0 : array_like, shape (12,)
        Initial state (SI, rad) at ``t_eval[0]``.
    t_eval : array_like, shape (N,)
        Output times [s], increasing; the flight spans ``t_eval[0] .. t_eval[-1]``.
    reference : callable, optional
        ``t (N,) -> states (12, N)``: the planned states, for the angle deviation (NaN without).

    Returns
    -------
    OpenLoopCheck
        Position error [m] against the exact flat outputs, its time, the angle deviation [rad].

    Raises
    ------
    InputError
        Bad initial state, controls or grid (:func:`gna.simulate.simulate`).
    """
    grid = np.asarray(t_eval, dtype=float)
    span = (float(grid[0]), float(grid[-1]))
    run = simulate(
        problem.aircraft,
        controls,
        span,
        x0,
        env=problem.env,
        t_eval=grid,
        method=VERIFY_METHOD,
        rtol=VERIFY_RTOL,
        atol=VERIFY_ATOL,
    )
    settings = {
        "method": VERIFY_METHOD,
        "rtol": VERIFY_RTOL,
        "atol": VERIFY_ATOL,
        "dt_out": (span[1] - span[0]) / max(1, grid.size - 1),
        "model": "full",
    }
    df = run.df
    t = df.index.to_numpy(dtype=float)
    flat = np.stack(
        [np.broadcast_to(np.asarray(f(t), dtype=float), t.shape) for f in (problem.x, problem.y, problem.z)]
    )
    err = np.sqrt(((df[["x", "y", "z"]].to_numpy().T - flat) ** 2).sum(axis=0))
    if run.status != "completed" or not np.all(np.isfinite(err)):
        return OpenLoopCheck(float("nan"), float(run.t_end), float("nan"), run.status, run.message, settings)
    ang = float("nan")
    if reference is not None:
        ref = reference(t)
        ang = max(
            float(np.max(np.abs(df[k].to_numpy() - ref[STATE_NAMES.index(k)])))
            for k in ("gamma", "chi", "alpha", "beta", "mu")
        )
    k = int(np.argmax(err))
    return OpenLoopCheck(float(err[k]), float(t[k]), ang, run.status, "", settings)


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
        Output step [s] on which the distance is measured; default :func:`verification_grid` (a
        tenth of the smallest node interval, at most 0.01 s).

    Returns
    -------
    OpenLoopCheck
        Position error [m] against the exact flat outputs, its time, the angle deviation [rad]
        from the plan's states.

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
    if dt_out is None:
        grid = verification_grid(plan.t_nodes)
    else:
        n = max(1, int(round((plan.t1 - plan.t0) / dt_out)))
        grid = np.linspace(plan.t0, plan.t1, n + 1)
    check = open_loop_check(
        plan.problem, plan.control_function(j), plan.initial_state(j), grid, reference=lambda t: plan.state(t, j)
    )
    return replace(check, settings={**check.settings, "iterate": j % len(plan.iterates)})
