"""Bundled demonstrations of the chained systems, run by ``gflat plan <name>``.

Each demo plans its system by generalized flatness (:mod:`planners.chained`) and checks the plan
against an exact reference: the operator relation for the first-order lag, the exact off-axle model
flown open loop for the car with two trailers.
"""

from __future__ import annotations

import io
import time
from dataclasses import dataclass

import numpy as np

from gna.errors import InputError

from ..chained import generalized_parametrization, newton_parametrization
from .car_trailers import CarTrailers, car_two_trailers, simulate_car_two_trailers
from .first_order_lag import first_order_lag, lag_reference


def _lag(J):
    eps, w = 0.1, 1.0
    system = first_order_lag(eps)
    zeta = {"x": lambda t: np.sin(w * t)}
    ref = lag_reference((w, 0.0), eps, w)

    def check(plan):
        tn = plan.t_nodes
        y = np.real(plan.iterates[-1]["y"].constant_term)
        return {"max |y - (1 + eps d/dt)^-1 x'| at the nodes": float(np.max(np.abs(y - ref(tn))))}

    desc = f"x' = y + eps y', eps = {eps:g} s, generalized flat output x = sin({w:g} t)"
    return system, np.linspace(0.0, 3.0, 13), zeta, 12 if J is None else J, 1, desc, check


def _car(J):
    g, V, A, w = CarTrailers(), 5.0, 2.0, 0.5
    system = car_two_trailers(g, V)
    zeta = {"x2": lambda t: V * t, "y2": lambda t: A * np.sin(w * t)}

    def check(plan):
        te = np.linspace(plan.t_nodes[0], plan.t_nodes[-1], 241)
        x0 = [plan.evaluate(n, te[0]) for n in ("x2", "y2", "theta2", "theta1", "theta0")]
        X = simulate_car_two_trailers(g, lambda t: plan.evaluate("v0", t), lambda t: plan.evaluate("phi", t), x0, te)
        err = np.hypot(X[:, 0] - zeta["x2"](te), X[:, 1] - zeta["y2"](te))
        return {"open-loop error of the exact off-axle model [m]": float(np.max(err))}

    desc = (f"car + two off-axle trailers (d1 = {g.d1:g} m, d2 = {g.d2:g} m), last trailer on x2 = {V:g} t, "
            f"y2 = {A:g} sin({w:g} t)")
    return system, np.linspace(0.0, 12.0, 49), zeta, 4 if J is None else J, 3, desc, check


#: Demo name -> builder ``f(J) -> (system, t_nodes, zeta, J, e, description, check)``.
DEMOS = {"first-order-lag": _lag, "car-two-trailers": _car}


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
        System, method, J, nodes, planning time [s], the checks and the Newton residuals.
    plan : ChainedPlan
        The plan.
    """

    text: str
    csv: str
    summary: dict
    plan: object


def run_demo(name: str, J: int | None = None, method: str = "fixed-point") -> DemoResult:
    """Plan a bundled chained-system demo and check it against its exact reference.

    Parameters
    ----------
    name : str
        A key of :data:`DEMOS`.
    J : int, optional
        Iterations (fixed point) or depth (Newton); default the demo's.
    method : {"fixed-point", "newton"}
        Generalized-flatness method.

    Returns
    -------
    DemoResult
        Report text, CSV table of the plan, summary.

    Raises
    ------
    InputError
        An unknown demo or method.
    """
    if name not in DEMOS:
        raise InputError(f"unknown chained-system demo {name!r}; known: {', '.join(DEMOS)}")
    if method not in ("fixed-point", "newton"):
        raise InputError(f"method must be 'fixed-point' or 'newton', got {method!r}")
    system, tn, zeta, J, e, desc, check = DEMOS[name](J)
    t0 = time.perf_counter()
    if method == "newton":
        plan = newton_parametrization(system, tn, zeta, J=J, e=e)
    else:
        plan = generalized_parametrization(system, tn, zeta, J=J, e=e)
    elapsed = time.perf_counter() - t0
    checks = check(plan)
    lines = [f"{name}: {desc}", f"  {len(tn)} nodes, t = {tn[0]:g} .. {tn[-1]:g}, {method}, J = {J}, "
             f"{len(plan.iterates)} iterate(s), planning time {elapsed:.3f} s"]
    if plan.residuals:
        lines.append("  Newton max |X^ - G(X^)| per step: " + ", ".join(f"{r:.2e}" for r in plan.residuals))
    lines += [f"  {k}: {v:.3e}" for k, v in checks.items()]
    grid = np.linspace(tn[0], tn[-1], 4 * (len(tn) - 1) + 1)
    names = list(plan.iterates[-1])
    buf = io.StringIO()
    np.savetxt(buf, np.column_stack([grid] + [plan.evaluate(n, grid) for n in names]), delimiter=",",
               header=",".join(["t"] + names), comments="", fmt="%.10g")
    summary = {"system": name, "description": desc, "method": method, "J": J, "nodes": len(tn),
               "planning_time_s": elapsed, "checks": checks, "newton_residuals": plan.residuals}
    return DemoResult("\n".join(lines), buf.getvalue(), summary, plan)
