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


def plan_motion(problem: FlatProblem, t_nodes, J: int = 0, e: int = 1, name: str = "plan") -> Plan:
    """Plan with J generalized-flatness iterations.

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

    Returns
    -------
    Plan
        Every iterate, the Newton, singularity and envelope warnings, timings.

    Raises
    ------
    InputError
        A grid of fewer than two increasing nodes.
    """
    t_nodes = np.asarray(t_nodes, dtype=float)
    if t_nodes.ndim != 1 or len(t_nodes) < 2 or np.any(np.diff(t_nodes) <= 0):
        from gna.errors import InputError
        raise InputError("the planning grid needs at least two increasing nodes")
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
    plan.warnings.extend(plan.newton_failures)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        plan.singularities = monitor(plan)
    plan.warnings.extend(plan.singularities.warnings)
    if plan.feasible:
        from gna.simulate import envelope_warnings
        fine = plan.to_dataframe(step=float(np.min(np.diff(t_nodes))) / 8)  # between the nodes too
        plan.warnings.extend(f"plan (j = {plan.J}): {w}" for w in envelope_warnings(problem.aircraft, fine))
    return plan


def plan_scenario(scenario, J: int | None = None) -> Plan:
    """Plan a :class:`~planners.scenario.Scenario`.

    Parameters
    ----------
    scenario : Scenario
        Flat outputs, aircraft, grid and J.
    J : int, optional
        Generalized-flatness iterations (default: the scenario's).

    Returns
    -------
    Plan
        See :func:`plan_motion`.
    """
    return plan_motion(scenario.problem(), scenario.t_nodes, scenario.J if J is None else J, name=scenario.name)
