"""``gflat compare SCENARIO [--J N] [--engines inhouse,jsbsim] [--out DIR]``.

Plans the scenario, flies the J-th iterate's controls open loop on every
engine from the same planned initial state, and prints the difference tables
(first 10 s and the whole span) of each engine against the first, plus each
engine's deviation from the plan; figures go to the output folder.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from planners.generalized import plan_scenario
from planners.scenario import list_scenarios, load_scenario

from ..compare import compare_engines, difference_table
from ..engines import engine_names, engines_from_names
from ._args import nonnegative_int


def register(sub) -> None:
    p = sub.add_parser("compare", help="fly a plan open loop on several engines and compare them",
                       description="Plan a scenario and fly its controls open loop on the in-house model and "
                                   "JSBSim from the same initial state. Bundled scenarios: "
                                   + ", ".join(list_scenarios()))
    p.add_argument("scenario", help="bundled scenario name or path to a scenario TOML file")
    p.add_argument("--J", type=nonnegative_int, default=None, help="generalized-flatness iterations "
                                                                   "(default: the scenario's)")
    p.add_argument("--engines", default="inhouse,jsbsim",
                   help=f"comma-separated engines, the first is the reference ({', '.join(engine_names())})")
    p.add_argument("--out", default=None, metavar="DIR", help="output folder (default reports/out/<scenario>/compare)")
    p.set_defaults(func=run)


def compare_scenario(scenario: str, J: int | None = None, engines: str = "inhouse,jsbsim",
                     out: str | Path | None = None, quiet: bool = False) -> dict:
    """Plan and fly one scenario; returns a summary (also written as ``summary.json``)."""
    sc = load_scenario(scenario, J=J)
    plan = plan_scenario(sc)
    if not plan.feasible:
        from gna.errors import DomainError
        raise DomainError(f"{sc.name}: the plan is not feasible, nothing to fly: {plan.newton_failures[0]}")
    Jp = plan.J
    out = Path(out) if out else Path("reports") / "out" / sc.name / "compare"
    comp = compare_engines(sc.aircraft, plan.control_function(Jp), (plan.t0, plan.t1), plan.initial_state(Jp),
                           engines=engines_from_names(engines, minimum=2), env=plan.env, out_dir=out,
                           reference=lambda t: plan.state(t, Jp), dt_out=0.05,
                           title=f"{sc.name} (J = {Jp}), open loop")
    grid = np.arange(plan.t0, plan.t1 + 0.025, 0.05)
    plan_df = plan.to_dataframe(grid[grid <= plan.t1 + 1e-9], j=Jp)
    vs_plan = {}
    for label, res in comp.results.items():
        # no tolerances: the open-loop drift from the plan is information, not a pass/fail criterion
        vs_plan[label] = difference_table(plan_df, res.df, tolerances={}, labels=("plan", label))
    lines = [f"{sc.name}: {sc.aircraft.id}, J = {Jp}, t = {plan.t0:g} .. {plan.t1:g} s, open loop",
             comp.report()]
    for label, tab in vs_plan.items():
        lines.append(f"[{label} against the plan, whole span]")
        lines.append(tab.format())
    text = "\n".join(lines)
    (out / "differences.txt").write_text(text + "\n", encoding="utf-8")
    if not quiet:
        print(text)
        print(f"figures and tables written to {out}/")
    summary = {"scenario": sc.name, "J": Jp, "engines": list(comp.results), "passed": comp.passed,
               "status": {k: r.status for k, r in comp.results.items()},
               "tables": {eng: {w: t.to_frame().reset_index().to_dict(orient="records") for w, t in per.items()}
                          for eng, per in comp.tables.items()},
               "figures": [str(p) for p in getattr(comp, "figures", [])]}
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float))
    return summary


def run(args) -> int:
    summary = compare_scenario(args.scenario, args.J, args.engines, args.out)
    if not summary["passed"]:
        print("gflat compare: the engines disagree beyond the tolerances (or a run ended early): FAIL")
        return 1
    return 0
