"""``gflat paper [--out DIR] [--J N] [--loop open|closed|both]``: the main job.

Plans the paper's three manoeuvres (single-engine Twin Otter, GTM forward slip,
GTM aileron roll in a zero-g parabola) by flatness and generalized flatness,
flies each plan on the in-house model and on JSBSim from the same initial
state, open loop and closed loop with the paper's tracking feedback, and writes
the plans, figures (the paper's four-curve figure per scenario) and difference
tables.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

from reports.case_files import write_case
from reports.html import render_run

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
    p.add_argument("--loop", choices=("open", "closed", "both"), default="both",
                   help="fly the plans open loop, closed loop with the tracking feedback, or both (default both)")
    p.set_defaults(func=run)


def paper_cases(J: int | None = None, loop: str = "open") -> list[ValidationCase]:
    """The paper's three manoeuvres as validation cases (in-house reference, JSBSim).

    Parameters
    ----------
    J : int, optional
        Generalized-flatness iterations (default: each scenario's).
    loop : {"open", "closed"}
        Open loop, or closed loop with the tracking feedback.

    Returns
    -------
    list of ValidationCase
    """
    return [ValidationCase(name, J=J, engines=("inhouse", "jsbsim"), loop=loop) for name in PAPER_SCENARIOS]


def run(args) -> int:
    out = Path(args.out)
    rows, passed, closed_rows = [], [], []
    cases = paper_cases(args.J)
    for case in cases:
        print(f"=== {case.scenario}")
        t0 = time.perf_counter()
        planned = plan_case(case)
        name = planned.scenario.name
        print(write_plan(planned.scenario, planned.plan, planned.planning_time_s, out / name / "plan"))
        passed.append(True)
        if args.loop in ("open", "both"):
            result = run_case(case, plan=planned.plan)       # the plan just made: planned once
            write_case(result, out / name / "compare")
            passed[-1] = result.passed
            first, whole = result.tables["jsbsim"]["first 10 s"], result.tables["jsbsim"]["whole span"]
            pos = lambda tab: tab.row("position").max_abs  # noqa: E731
            ang = lambda tab: max(tab.row(v).max_abs for v in ANGLE_STATES)  # noqa: E731
            J = result.plan.J
            rows.append((name, planned.scenario.aircraft.id, J, pos(first), ang(first), pos(whole), ang(whole),
                         time.perf_counter() - t0))
            print(f"  in-house vs JSBSim (open loop, J = {J}): first 10 s {pos(first):.2e} m, "
                  f"{ang(first):.2e} rad; whole span {pos(whole):.2e} m, {ang(whole):.2e} rad")
            print(f"  figures and tables: {out / name / 'compare'}/")
        if args.loop == "open":
            continue
        closed = run_case(replace(case, loop="closed"), plan=planned.plan, scenario=planned.scenario)
        write_case(closed, out / name / "compare-closed")
        v = closed.verdict()
        passed[-1] = passed[-1] and v["pass"]
        runs = v["runs"]
        closed_rows.append((name, runs["inhouse"]["max_position_error_m"], runs["jsbsim"]["max_position_error_m"],
                            v["differences"]["jsbsim"]["max_position_m"], runs["inhouse"]["saturated_s"],
                            v["pass"]))
        print(f"  closed loop (tracking feedback): in-house {runs['inhouse']['status']}, max "
              f"{runs['inhouse']['max_position_error_m']:.2e} m from the flat outputs; JSBSim "
              f"{runs['jsbsim']['status']}, {runs['jsbsim']['max_position_error_m']:.2e} m; in-house vs JSBSim "
              f"{v['differences']['jsbsim']['max_position_m']:.2e} m")
        print(f"  four-curve figure: {out / name / 'compare-closed' / 'tracking.png'}")
    failed = [c.scenario for c, ok in zip(cases, passed) if not ok]
    if rows:
        print("\nsummary: in-house vs JSBSim, open loop with the generalized-flatness controls")
        print(f"  {'scenario':<26} {'aircraft':<10} {'J':>2} {'pos 10 s [m]':>12} {'ang 10 s [rad]':>14} "
              f"{'pos all [m]':>11} {'ang all [rad]':>13} {'time [s]':>8}")
    for r in rows:
        print(f"  {r[0]:<26} {r[1]:<10} {r[2]:>2} {r[3]:>12.2e} {r[4]:>14.2e} {r[5]:>11.2e} {r[6]:>13.2e} {r[7]:>8.1f}")
    if closed_rows:
        print("\nclosed loop with the tracking feedback (from the planned initial state)")
        print(f"  {'scenario':<26} {'in-house [m]':>12} {'JSBSim [m]':>11} {'in-house vs JSBSim [m]':>22} "
              f"{'saturated [s]':>13}  result")
    for r in closed_rows:
        print(f"  {r[0]:<26} {r[1]:>12.2e} {r[2]:>11.2e} {r[3]:>22.2e} {r[4]:>13.2f}  {'PASS' if r[5] else 'FAIL'}")
    report = render_run(out)                          # HTML and PDF from the saved report.json files
    print(f"\nreport: {report['index']} (PDF: {report['pdf']})")
    if failed:
        print(f"gflat paper: engines disagree beyond the tolerances, or a run ended early, for {', '.join(failed)}: FAIL")
        return 1
    return 0
