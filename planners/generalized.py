"""Motion planning by flatness and generalized flatness (paper section "Generalized flatness").

Algorithm ``GeneralizedFlatParametrization(v, zeta, J, e)``: the neglected
terms H of the force equations start at given values ``v`` (zero or a
calibration), and are re-evaluated J times from the previous iterate::

    L := 2;  kappa_0 := e + r + J L          (r = 4 stages; 5 + 2J for the controls at order e = 1)
    for j = 0..J:
        X[j] := FlatParametrization(t, kappa_j, zeta, H = X[j-1])
        kappa_{j+1} := kappa_j - L

Every iterate is kept in the returned :class:`~planners.plan.Plan`; all the
nodes of the grid are computed together (array code), and iterate j starts
its Newton iterations from iterate j - 1.
"""

from __future__ import annotations

import time

import numpy as np

from .flat import FlatProblem, parametrize
from .plan import Plan
from .singularity import monitor

#: Order lost per iteration (the paper's L = max l_h - 1 = 2 for aircraft).
ORDER_LOSS = 2
#: Number of stages between the flat outputs and the controls.
STAGES = 4


#: Methods of the generalized flat parametrization: the paper's J iterations, or Newton's method
#: on their fixed point (:mod:`planners.generalized_newton`).
METHODS = ("fixed-point", "newton")


def plan_motion(problem: FlatProblem, t_nodes, J: int = 0, e: int = 1, name: str = "plan",
                method: str = "fixed-point", newton_tol: float = 1e-12, newton_maxiter: int = 8) -> Plan:
    """Plan with J generalized-flatness iterations, or Newton's method on their fixed point.

    Parameters
    ----------
    problem : FlatProblem
    t_nodes : array
        Increasing grid of at least two nodes.
    J : int
        Iterations after the plain flat plan (J = 0: flat plan only).
    e : int
        Order of the controls in the last iterate (>= 1 for the two-sided
        interpolation to carry slopes).
    name : str
        Name of the plan (for messages and outputs).
    method : {"fixed-point", "newton"}
        ``"fixed-point"``: the paper's ``GeneralizedFlatParametrization`` (iterate j uses the H
        values of iterate j - 1).  ``"newton"``: Newton's method on ``H = G(H)`` at the same starting
        order ``kappa = e + 4 + 2 J`` (J is then the depth, not the number of iterations), iterates
        truncated to the orders of the fixed point's iterate J (:func:`planners.generalized_newton.plan_newton`).
    newton_tol : float
        ``"newton"`` only: stop when ``max |H - G(H)|`` is below this [rad/s, rad].
    newton_maxiter : int
        ``"newton"`` only: Newton steps at most.

    Returns
    -------
    Plan
        Every iterate, the Newton, singularity and envelope warnings, timings; ``plan.generalized``
        holds the method and, for Newton, the fixed-point residual ``max |H - G(H)|`` of each iterate.

    Raises
    ------
    InputError
        A grid of fewer than two increasing nodes, or an unknown method.
    """
    t_nodes = np.asarray(t_nodes, dtype=float)
    if t_nodes.ndim != 1 or len(t_nodes) < 2 or np.any(np.diff(t_nodes) <= 0):
        from gna.errors import InputError
        raise InputError("the planning grid needs at least two increasing nodes")
    if method not in METHODS:
        from gna.errors import InputError
        raise InputError(f"generalized-flatness method must be one of {', '.join(METHODS)}, got {method!r}")
    if method == "newton":
        from .generalized_newton import plan_newton
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            iterates, info = plan_newton(problem, t_nodes, J, e, tol=newton_tol, maxiter=newton_maxiter)
        plan = Plan(problem, t_nodes, iterates, [], name, info["timings"])
        plan.generalized = {"method": method, "depth": J, **info}
        if info["status"] != "converged":
            plan.warnings.append(f"Newton on the generalized-flatness fixed point {info['status']} after "
                                 f"{len(info['residual']) - 1} step(s): max |H - G(H)| = {info['residual'][-1]:.3g} "
                                 f"(tolerance {newton_tol:g})")
        return _finish(plan)
    kappa = e + STAGES + J * ORDER_LOSS
    iterates, timings = [], {}
    prev = None
    for j in range(J + 1):
        t_start = time.perf_counter()
        h = None if prev is None else prev.h_values()
        # Near a singularity Newton may overflow: reported through the Newton and monitor warnings.
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            sol = parametrize(problem, t_nodes, kappa, h=h, guess=None if prev is None else prev.series)
        timings[j] = time.perf_counter() - t_start
        iterates.append(sol)
        prev = sol
        kappa -= ORDER_LOSS
    plan = Plan(problem, t_nodes, iterates, [], name, timings)
    plan.generalized = {"method": method}
    return _finish(plan)


def _finish(plan: Plan) -> Plan:
    """Newton failures, singularity monitor and envelope checks of a plan (both methods)."""
    problem, t_nodes = plan.problem, plan.t_nodes
    plan.warnings.extend(plan.newton_failures)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        plan.singularities = monitor(plan)
    plan.warnings.extend(plan.singularities.warnings)
    if plan.feasible:
        from gna.simulate import envelope_warnings
        fine = plan.to_dataframe(step=float(np.min(np.diff(t_nodes))) / 8)  # between the nodes too
        plan.warnings.extend(f"plan (j = {plan.J}): {w}" for w in envelope_warnings(problem.aircraft, fine))
    return plan


def plan_scenario(scenario, J: int | None = None, method: str | None = None) -> Plan:
    """Plan a :class:`~planners.scenario.Scenario`.

    Parameters
    ----------
    scenario : Scenario
        Flat outputs, aircraft, grid and J.
    J : int, optional
        Generalized-flatness iterations (default: the scenario's).
    method : {"fixed-point", "newton"}, optional
        Generalized-flatness method (default: the scenario's ``[generalized] method`` when it has
        one, else ``"fixed-point"``).

    Returns
    -------
    Plan
        See :func:`plan_motion`.

    Raises
    ------
    InputError
        An unknown ``[generalized] method`` in the scenario.
    """
    if method is None:
        gen = (getattr(scenario, "raw", None) or {}).get("generalized", {})
        method = gen.get("method", "fixed-point") if isinstance(gen, dict) else "fixed-point"
        if method not in METHODS:
            from gna.errors import InputError
            raise InputError(f"scenario {scenario.name} [generalized]: method must be one of "
                             f"{', '.join(repr(m) for m in METHODS)}, got {method!r}")
    return plan_motion(scenario.problem(), scenario.t_nodes, scenario.J if J is None else J, name=scenario.name,
                       method=method)
