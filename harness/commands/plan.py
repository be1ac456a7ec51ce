"""``gflat plan SCENARIO [--J N] [--out DIR]``: plan a manoeuvre by (generalized) flatness."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from planners.plan import save_plan
from planners.scenario import list_scenarios
from planners.systems.demos import DEMOS, run_demo

from ..validation import ValidationCase, plan_case
from ._args import nonnegative_int


def register(sub) -> None:
    p = sub.add_parser("plan", help="plan a manoeuvre (flatness + generalized flatness)",
                       description="Plan a scenario: flat parametrization on a grid of power series, then J "
                                   "generalized-flatness iterations. Bundled scenarios: " + ", ".join(list_scenarios())
                                   + "; chained-system demos: " + ", ".join(DEMOS))
    p.add_argument("scenario", help="bundled scenario name or path to a scenario TOML file")
    p.add_argument("--J", type=nonnegative_int, default=None, help="generalized-flatness iterations (default: the "
                                                                   "scenario's)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default reports/out/<scenario>)")
    p.set_defaults(func=run)


def write_plan(sc, plan, elapsed: float, out: Path) -> str:
    """Write a plan's files (series, CSV tables, convergence table, summary) to ``out``; return the report text."""
    written = save_plan(plan, out)
    tn = plan.t_nodes
    lines = [f"{sc.name}: {sc.aircraft.id}, t = {tn[0]:g} .. {tn[-1]:g} s, {len(tn)} nodes, flat output "
             f"{sc.zeta.kind}, J = {plan.J}"]
    orders = [it.order for it in plan.iterates]
    lines.append(f"  orders of x, y, z per iterate: {orders} (controls at order {orders[-1] - 4})")
    lines.append(f"  planning time {elapsed:.3f} s ({', '.join(f'j={j}: {t:.3f}' for j, t in plan.timings.items())})")
    lines.append(f"  worst Newton residual: {plan.worst_newton_residual():.2e}")
    res = [float(plan.equation_residuals("full", j).abs().max(skipna=False).max(skipna=False))
           for j in range(plan.J + 1)]
    lines.append("  full-model equation residual at the nodes (max over the 12 equations) per iterate: "
                 + ", ".join(f"j={j}: {r:.2e}" for j, r in enumerate(res)))
    if plan.warnings:
        lines.append(f"  warnings ({len(plan.warnings)}):")
        lines += [f"    - {w}" for w in plan.warnings]
    else:
        lines.append("  no Newton or singularity warnings")
    times = sc.report_times or [float(tn[0])]
    table = plan.convergence_table(sc.report_variables, times)
    lines.append("  convergence table (value at t for each iterate j):")
    with np.printoptions(linewidth=200):
        lines.append("    " + table.to_string(float_format=lambda v: f"{v:.6g}").replace("\n", "\n    "))
    table.to_csv(out / "convergence.csv", float_format="%.10g")
    summary = {"scenario": sc.name, "aircraft": sc.aircraft.id, "J": plan.J, "nodes": len(tn),
               "orders": orders, "planning_time_s": elapsed, "timings_s": plan.timings,
               "worst_newton_residual": plan.worst_newton_residual(), "full_residual_per_iterate": res,
               "warnings": plan.warnings, "files": written}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    lines.append(f"  written to {out}/")
    return "\n".join(lines)


def run(args) -> int:
    if args.scenario in DEMOS:  # a chained system of planners.systems, not an aircraft scenario
        print(run_demo(args.scenario, J=args.J, out=Path(args.out or Path("reports") / "out" / args.scenario)))
        return 0
    planned = plan_case(ValidationCase(args.scenario, J=args.J))
    sc, plan = planned.scenario, planned.plan
    out = Path(args.out) if args.out else Path("reports") / "out" / sc.name
    print(write_plan(sc, plan, planned.planning_time_s, out))
    if not plan.feasible:
        print(f"gflat plan: the plan is not feasible: Newton failed ({len(plan.newton_failures)} warning(s) "
              f"above); its values at those times are not a solution of the model")
        return 1
    return 0
