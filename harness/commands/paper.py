"""``gflat paper [--out DIR] [--J N]``: the main job.

Plans the paper's three manoeuvres (single-engine Twin Otter, GTM forward slip,
GTM aileron roll in a zero-g parabola) by flatness and generalized flatness,
flies each plan open loop on the in-house model and on JSBSim from the same
initial state, and writes the plans, figures and difference tables.
"""

from __future__ import annotations

import time
from pathlib import Path

from reports.case_files import write_case

from ..validation import ValidationCase, plan_case, run_case
from ._args import nonnegative_int
from .plan import write_plan

PAPER_SCENARIOS = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")
ANGLE_STATES = ("gamma", "chi", "alpha", "beta", "mu")


def register(sub) -> None:
    p = sub.add_parser("paper", help="plan the paper's three manoeuvres and fly them on both engines",
                       description=__doc__.split("\n\n")[1])
    p.add_argument("--out", default="reports/out/paper", metavar="DIR", help="output folder")
    p.add_argument("--J", type=nonnegative_int, default=None, help="iterations (default: each scenario's)")
    p.set_defaults(func=run)


def paper_cases(J: int | None = None) -> list[ValidationCase]:
    """The paper's three manoeuvres as validation cases (in-house reference, JSBSim, open loop)."""
    return [ValidationCase(name, J=J, engines=("inhouse", "jsbsim")) for name in PAPER_SCENARIOS]


def run(args) -> int:
    out = Path(args.out)
    rows, passed = [], []
    for case in paper_cases(args.J):
        print(f"=== {case.scenario}")
        t0 = time.perf_counter()
        planned = plan_case(case)
        name = planned.scenario.name
        print(write_plan(planned.scenario, planned.plan, planned.planning_time_s, out / name / "plan"))
        result = run_case(case, plan=planned.plan)       # the plan just made: planned once
        write_case(result, out / name / "compare")
        passed.append(result.passed)
        first, whole = result.tables["jsbsim"]["first 10 s"], result.tables["jsbsim"]["whole span"]
        pos = lambda tab: tab.row("position").max_abs  # noqa: E731
        ang = lambda tab: max(tab.row(v).max_abs for v in ANGLE_STATES)  # noqa: E731
        J = result.plan.J
        rows.append((name, planned.scenario.aircraft.id, J, pos(first), ang(first), pos(whole), ang(whole),
                     time.perf_counter() - t0))
        print(f"  in-house vs JSBSim (open loop, J = {J}): first 10 s {pos(first):.2e} m, "
              f"{ang(first):.2e} rad; whole span {pos(whole):.2e} m, {ang(whole):.2e} rad")
        print(f"  figures and tables: {out / name / 'compare'}/")
    failed = [r[0] for r, ok in zip(rows, passed) if not ok]
    print("\nsummary: in-house vs JSBSim, open loop with the generalized-flatness controls")
    print(f"  {'scenario':<26} {'aircraft':<10} {'J':>2} {'pos 10 s [m]':>12} {'ang 10 s [rad]':>14} "
          f"{'pos all [m]':>11} {'ang all [rad]':>13} {'time [s]':>8}")
    for r in rows:
        print(f"  {r[0]:<26} {r[1]:<10} {r[2]:>2} {r[3]:>12.2e} {r[4]:>14.2e} {r[5]:>11.2e} {r[6]:>13.2e} {r[7]:>8.1f}")
    if failed:
        print(f"gflat paper: engines disagree beyond the tolerances for {', '.join(failed)}: FAIL")
        return 1
    return 0
