"""Chained-system scenarios run by ``gflat plan <name or file>``.

Each scenario (:mod:`planners.systems.scenario`) is planned by generalized flatness
(:mod:`planners.chained`) and its plan checked against an exact reference: the operator relation for
the first-order lag, the exact off-axle model flown open loop for the car with two trailers.
"""

from __future__ import annotations

import io
import time
from dataclasses import dataclass

import numpy as np

from gna.errors import DomainError

from .scenario import (
    ChainedScenario,
    is_chained_scenario,
    list_chained_scenarios,
    load_chained_scenario,
    plan_chained_scenario,
)

#: The bundled chained-system scenarios (``planners/systems/scenarios/*.toml``), run by ``gflat plan NAME``.
DEMOS = tuple(list_chained_scenarios())


@dataclass
class DemoResult:
    """What :func:`run_demo` produced.

    Attributes
    ----------
    text : str
        The report text.
    csv : str
        Every variable of the last iterate on a grid four times finer than the nodes (CSV, header ``t, ...``).
    summary : dict
        System, method, J, nodes, planning time [s], the checks, ``feasible`` and ``failure`` (why the
        plan is not a solution of the exact model, or None) and the Newton residuals.
    plan : ChainedPlan
        The plan.
    """

    text: str
    csv: str
    summary: dict
    plan: object


def run_demo(name: str, J: int | None = None, method: str | None = None) -> DemoResult:
    """Plan a chained-system scenario (bundled name or TOML path) and check it against its exact reference.

    Parameters
    ----------
    name : str
        A bundled chained scenario (:data:`DEMOS`) or the path of a chained scenario file.
    J : int, optional
        Iterations (fixed point) or depth (Newton); default the scenario's.
    method : {"fixed-point", "newton"}, optional
        Generalized-flatness method; default the scenario's.

    Returns
    -------
    DemoResult
        Report text, CSV table of the plan, summary.

    Raises
    ------
    InputError
        An unknown scenario or method, or a bad scenario file.
    """
    sc: ChainedScenario = load_chained_scenario(name, J=J)
    t0 = time.perf_counter()
    plan = plan_chained_scenario(sc, method=method)
    elapsed = time.perf_counter() - t0
    method = sc.method if method is None else method
    try:
        checks = sc.spec.check(plan, sc)
        failure = sc.spec.verdict(checks, sc) if sc.spec.verdict is not None else None
    except DomainError as exc:  # the exact model cannot be flown along the plan
        checks, failure = {}, str(exc)
    tn = plan.t_nodes
    outputs = ", ".join(f"{z} = {e.text}" for z, e in sc.flat_outputs.items())
    params = ", ".join(f"{k} = {v:g}" for k, v in sc.parameters.items())
    lines = [
        f"{sc.name}: {sc.system.description}",
        f"  parameters: {params}; flat outputs: {outputs}",
        f"  {len(tn)} nodes, t = {tn[0]:g} .. {tn[-1]:g}, {method}, J = {sc.J}, e = {sc.e}, "
        f"{len(plan.iterates)} iterate(s), planning time {elapsed:.3f} s",
    ]
    if plan.residuals:
        lines.append("  Newton max |X^ - G(X^)| per step: " + ", ".join(f"{r:.2e}" for r in plan.residuals))
    lines += [f"  {k}: {v:.3e}" for k, v in checks.items()]
    if failure:
        lines.append(f"  NOT a solution of the exact model: {failure}")
    grid = np.linspace(tn[0], tn[-1], 4 * (len(tn) - 1) + 1)
    names = list(plan.iterates[-1])
    buf = io.StringIO()
    np.savetxt(
        buf,
        np.column_stack([grid] + [plan.evaluate(n, grid) for n in names]),
        delimiter=",",
        header=",".join(["t"] + names),
        comments="",
        fmt="%.10g",
    )
    summary = {
        "scenario": sc.name,
        "system": sc.system_name,
        "description": sc.description,
        "parameters": sc.parameters,
        "flat_outputs": {z: e.text for z, e in sc.flat_outputs.items()},
        "method": method,
        "J": sc.J,
        "e": sc.e,
        "nodes": len(tn),
        "planning_time_s": elapsed,
        "checks": checks,
        "feasible": failure is None,
        "failure": failure,
        "newton_residuals": plan.residuals,
    }
    return DemoResult("\n".join(lines), buf.getvalue(), summary, plan)


__all__ = ["DEMOS", "DemoResult", "is_chained_scenario", "run_demo"]
