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

import logging
import time

import numpy as np

from gna.errors import InputError
from gna.trajectory import first_domain_violation

from .flat import FlatProblem, check_grid, check_iterations, parametrize
from .plan import Plan
from .singularity import monitor

#: Order lost per iteration (the paper's L = max l_h - 1 = 2 for aircraft).
ORDER_LOSS = 2
#: Number of stages between the flat outputs and the controls.
STAGES = 4
#: Default bound on :func:`plan_cost`: 5e6 node-order^2 units, about 30 s of planning (about 6 us per unit
#: measured on 2 cores; the paper's largest plan, the J = 7 aileron roll on 81 nodes, costs 1.07e5).
MAX_PLAN_COST = 5.0e6
#: Plans costing more than this log their progress per iterate (logger ``planners.generalized``, INFO).
PROGRESS_COST = 5.0e5

_log = logging.getLogger(__name__)

#: Methods of the generalized flat parametrization: the paper's J iterations, or Newton's method
#: on their fixed point (:mod:`planners.generalized_newton`).
METHODS = ("fixed-point", "newton")


def plan_cost(nodes: int, J: int, e: int = 1) -> float:
    """Cost estimate of a plan: ``nodes * sum_j kappa_j^2``, ``kappa_j = e + 4 + 2 (J - j)``.

    The truncated-series products at order ``kappa`` cost ``kappa^2`` per
    node; the time of a plan grows like this figure (about 6 us per unit,
    memory like ``nodes * kappa``).

    Parameters
    ----------
    nodes : int
        Number of grid nodes.
    J : int
        Generalized-flatness iterations.
    e : int
        Order of the controls in the last iterate.

    Returns
    -------
    float
        Node-order^2 units.
    """
    kappa0 = e + STAGES + J * ORDER_LOSS
    return float(nodes) * sum((kappa0 - ORDER_LOSS * j) ** 2 for j in range(J + 1))


def plan_motion(problem: FlatProblem, t_nodes, J: int = 0, e: int = 1, name: str = "plan",
                max_cost: float | None = None, method: str = "fixed-point", newton_tol: float = 1e-12,
                newton_maxiter: int = 8) -> Plan:
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
    max_cost : float, optional
        Bound on :func:`plan_cost` (default :data:`MAX_PLAN_COST`;
        ``math.inf`` removes it).  Plans above :data:`PROGRESS_COST` log each
        iterate (INFO, logger ``planners.generalized``).
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
        holds the method and, for Newton, its status and fixed-point residual ``max |H - G(H)|`` of each
        iterate.

    Raises
    ------
    InputError
        A grid of fewer than two increasing nodes, J not a whole number in 0..30, a plan costing more
        than ``max_cost``, or an unknown method.
    DomainError
        The flat output's altitude ``-z`` at a node is outside the
        atmosphere model's range (the ISA's -2 to 20 km).
    """
    J = check_iterations(J, f"plan {name}")
    t_nodes = check_grid(t_nodes)
    if method not in METHODS:
        raise InputError(f"generalized-flatness method must be one of {', '.join(METHODS)}, got {method!r}")
    with np.errstate(all="ignore"):  # a non-finite z is reported by the parametrization with its cause
        z = np.broadcast_to(np.real(np.asarray(problem.z(t_nodes), dtype=complex)), t_nodes.shape)
    finite = np.isfinite(z)
    problem.env.check_altitude(-z[finite], f"plan {name}, flat output z", times=t_nodes[finite])
    cost = plan_cost(len(t_nodes), J, e)
    limit = MAX_PLAN_COST if max_cost is None else float(max_cost)
    if cost > limit:
        raise InputError(f"plan {name}: J = {J} on {len(t_nodes)} nodes costs {cost:.3g} node-order^2 units, "
                         f"above the bound {limit:.3g} (about {6e-6 * cost / 60:.0f} min of planning); use fewer "
                         f"nodes or a smaller J, or raise the bound (--max-cost, max_cost= in Python; inf for none)")
    verbose = cost > PROGRESS_COST
    if verbose:
        _log.info("plan %s: J = %d on %d nodes, cost %.3g units (about %.0f s)", name, J, len(t_nodes), cost,
                  6e-6 * cost)
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
        if verbose:
            done = sum(timings.values())
            share = plan_cost(len(t_nodes), j, e + ORDER_LOSS * (J - j)) / cost
            _log.info("plan %s: iterate j = %d of %d (order %d) in %.1f s; %.1f s so far, about %.0f s left",
                      name, j, J, kappa, timings[j], done, done * (1.0 / max(share, 1e-12) - 1.0))
        iterates.append(sol)
        prev = sol
        kappa -= ORDER_LOSS
    plan = Plan(problem, t_nodes, iterates, [], name, timings)
    plan.generalized = {"method": method}
    return _finish(plan)


def _finish(plan: Plan) -> Plan:
    """Newton failures, domain, singularity monitor and envelope checks of a plan (both methods)."""
    problem, t_nodes = plan.problem, plan.t_nodes
    plan.warnings.extend(plan.newton_failures)
    plan.domain_failures = domain_failures(plan)
    plan.warnings.extend(plan.domain_failures)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        plan.singularities = monitor(plan)
    plan.warnings.extend(plan.singularities.warnings)
    if plan.feasible:
        from gna.simulate import envelope_warnings
        fine = plan.to_dataframe(step=float(np.min(np.diff(t_nodes))) / 8)  # between the nodes too
        plan.warnings.extend(f"plan (j = {plan.J}): {w}" for w in envelope_warnings(problem.aircraft, fine))
    return plan


def domain_failures(plan: Plan) -> list[str]:
    """The iterates whose node values leave the physical domain, one message each (time, variable, value).

    Parameters
    ----------
    plan : Plan
        A plan with its iterates.

    Returns
    -------
    list of str
        ``"iterate j = ...: left the physical domain at t = ... s: ..."`` for
        each iterate with a node outside :data:`gna.trajectory.DOMAIN`.
    """
    out = []
    for j in range(plan.J + 1):
        s, _ = plan.node_values(j)
        bad = first_domain_violation(plan.t_nodes, np.array([np.broadcast_to(v, plan.t_nodes.shape) for v in s]))
        if bad is not None:
            out.append(f"iterate j = {j}: {bad}")
    return out


def plan_scenario(scenario, J: int | None = None, max_cost: float | None = None, method: str | None = None) -> Plan:
    """Plan a :class:`~planners.scenario.Scenario`.

    Parameters
    ----------
    scenario : Scenario
        Flat outputs, aircraft, grid and J.
    J : int, optional
        Generalized-flatness iterations (default: the scenario's).
    max_cost : float, optional
        Bound on :func:`plan_cost` (default :data:`MAX_PLAN_COST`).
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
        ``scenario`` is not a Scenario, ``J`` is not a whole number in 0..30, or an unknown
        ``[generalized] method`` in the scenario.
    """
    if not (callable(getattr(scenario, "problem", None)) and hasattr(scenario, "t_nodes")):
        raise InputError(f"a Scenario is needed, got {type(scenario).__name__} {scenario!r:.60}; "
                         f"planners.scenario.load_scenario(name) makes one")
    if J is not None:
        J = check_iterations(J, f"plan_scenario({scenario.name})")
    if method is None:
        gen = (getattr(scenario, "raw", None) or {}).get("generalized", {})
        method = gen.get("method", "fixed-point") if isinstance(gen, dict) else "fixed-point"
        if method not in METHODS:
            raise InputError(f"scenario {scenario.name} [generalized]: method must be one of "
                             f"{', '.join(repr(m) for m in METHODS)}, got {method!r}")
    return plan_motion(scenario.problem(), scenario.t_nodes, scenario.J if J is None else J, name=scenario.name,
                       max_cost=max_cost, method=method)
