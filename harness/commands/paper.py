"""``gflat paper [--out DIR] [--J N] [--loop open|closed|both] [--csv] [comparison flags]``: the main job.

Plans the paper's three manoeuvres (single-engine Twin Otter, GTM forward slip,
GTM aileron roll in a zero-g parabola) by flatness and generalized flatness,
flies each plan on the in-house model and on JSBSim from the same initial
state, open loop and closed loop with the paper's tracking feedback, and writes
the plans, figures (the paper's four-curve figure per scenario) and difference
tables.

Layout of ``--out DIR``: ``DIR/manifest.json``; ``DIR/<scenario>/plan/`` (the
plan's series, CSV tables, ``plan-j<k>.parquet`` of every iterate,
``summary.json``); ``DIR/<scenario>/open/`` and ``DIR/<scenario>/closed/``
(``trajectory-<engine>.parquet``, figures, ``differences.txt``,
``summary.json``); ``DIR/.gflat-complete.json`` once everything is written.
"""

from __future__ import annotations

import time
from dataclasses import replace

from planners.scenario import load_scenario
from reports.case_files import write_case
from reports.html import render_run

from ..artefacts import write_manifest, write_plan_iterates
from ..outdir import OutputDir
from ..validation import ValidationCase, case_settings, plan_case, run_case
from ._args import iterations, out_path
from ._compare_args import add_compare_arguments, compare_overrides
from .plan import write_plan

PAPER_SCENARIOS = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")
ANGLE_STATES = ("gamma", "chi", "alpha", "beta", "mu")


def register(sub) -> None:
    p = sub.add_parser("paper", help="plan the paper's three manoeuvres and fly them on both engines",
                       description=__doc__.split("\n\n")[1])
    p.add_argument("--out", type=out_path, default=None, metavar="DIR", help="output folder (default reports/out/paper)")
    p.add_argument("--J", type=iterations, default=None, help="iterations, or auto (default: each scenario's)")
    p.add_argument("--loop", choices=("open", "closed", "both"), default="both",
                   help="fly the plans open loop, closed loop with the tracking feedback, or both (default both)")
    add_compare_arguments(p)
    p.set_defaults(func=run)


def paper_cases(J: int | None = None, loop: str = "open", **overrides) -> list[ValidationCase]:
    """The paper's three manoeuvres as validation cases (in-house reference, JSBSim).

    Parameters
    ----------
    J : int, optional
        Generalized-flatness iterations (default: each scenario's).
    loop : {"open", "closed"}
        Open loop, or closed loop with the tracking feedback.
    **overrides
        Comparison settings of every case (``tolerances``, ``rtol``,
        ``windows``, ``dt_out``, ``jsbsim_dt``, ``self_convergence``).

    Returns
    -------
    list of ValidationCase
    """
    return [ValidationCase(name, J=J, engines=("inhouse", "jsbsim"), loop=loop, **overrides)
            for name in PAPER_SCENARIOS]


def run(args) -> int:
    rows, passed, closed_rows, results = [], [], [], []
    cases = paper_cases(args.J, **compare_overrides(args))
    for case in cases:                         # every scenario's [compare] table checked before any planning
        case_settings(case, load_scenario(case.scenario, J=case.J))
    out = OutputDir(args.out) if args.out else OutputDir("reports/out/paper", parents=True)
    for case in cases:
        print(f"=== {case.scenario}")
        t0 = time.perf_counter()
        planned = plan_case(case)
        name = planned.scenario.name
        plan_dir = out.sub(name, "plan")
        print(write_plan(planned.scenario, planned.plan, planned.planning_time_s, plan_dir)[0])
        passed.append(True)
        iterates_written = False
        if args.loop in ("open", "both"):
            result = run_case(case, plan=planned.plan, scenario=planned.scenario)   # the plan just made: planned once
            write_case(result, out.sub(name, "open"), csv=args.csv, plan=False, manifest=False)
            write_plan_iterates(plan_dir, planned.plan, result.runs[result.reference_engine].df.index, csv=args.csv)
            iterates_written = True
            results.append(result)
            passed[-1] = result.passed
            first, whole = result.tables["jsbsim"]["first 10 s"], result.tables["jsbsim"]["whole span"]
            pos = lambda tab: tab.row("position").max_abs  # noqa: E731
            ang = lambda tab: max(tab.row(v).max_abs for v in ANGLE_STATES)  # noqa: E731
            J = result.plan.J
            rows.append((name, planned.scenario.aircraft.id, J, pos(first), ang(first), pos(whole), ang(whole),
                         time.perf_counter() - t0))
            print(f"  in-house vs JSBSim (open loop, J = {J}): first 10 s {pos(first):.2e} m, "
                  f"{ang(first):.2e} rad; whole span {pos(whole):.2e} m, {ang(whole):.2e} rad")
            print(f"  figures, trajectories and tables: {out.path(name, 'open')}/")
        if args.loop == "open":
            continue
        closed = run_case(replace(case, loop="closed"), plan=planned.plan, scenario=planned.scenario)
        write_case(closed, out.sub(name, "closed"), csv=args.csv, plan=False, manifest=False)
        if not iterates_written:
            write_plan_iterates(plan_dir, planned.plan, closed.runs[closed.reference_engine].df.index, csv=args.csv)
        results.append(closed)
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
        print(f"  four-curve figure: {out.path(name, 'closed', 'tracking.png')}")
    write_manifest(out, results, command_line=getattr(args, "command_line", None))
    out.finish()
    print(f"\nmanifest, plans, trajectories, figures and tables written to {out.root}/")
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
              f"{'beyond limits [s]':>17}  result")
    for r in closed_rows:
        print(f"  {r[0]:<26} {r[1]:>12.2e} {r[2]:>11.2e} {r[3]:>22.2e} {r[4]:>17.2f}  {'PASS' if r[5] else 'FAIL'}")
    if closed_rows:
        print("  (beyond limits: time the commanded controls exceed the aircraft's limits, clipped when the scenario's\n"
              "   [tracking] saturate is on; the forward slip's plan itself needs dl of about -28 deg, beyond the GTM's\n"
              "   20 deg, and is flown unclipped)")
    report = render_run(out.root)                     # HTML and PDF from the saved report.json files
    print(f"\nreport: {report['index']} (PDF: {report['pdf']})")
    if failed:
        print(f"gflat paper: engines disagree beyond the tolerances, or a run ended early, for {', '.join(failed)}: FAIL")
        return 1
    return 0
