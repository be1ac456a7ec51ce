"""``gflat compare SCENARIO [--J N] [--loop open|closed] [--engines inhouse,jsbsim] [--out DIR] [--json]``.

Plans the scenario, flies the J-th iterate's controls on every engine from the
same planned initial state -- open loop, or closed loop with the paper's
tracking feedback (the scenario's ``[tracking]`` table) -- and prints the
difference tables (first 10 s and the whole span) of each engine against the
first, plus each engine's deviation from the plan; figures go to the output
folder.  With ``--json`` stdout carries one JSON object (the verdict) instead.
"""

from __future__ import annotations

import json
from pathlib import Path

from planners.scenario import list_scenarios
from reports.case_files import write_case
from reports.html import render_run

from ..engines import engine_names, engines_from_names
from ..validation import ValidationCase, run_case
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
    p.add_argument("--loop", choices=("open", "closed"), default="open",
                   help="open: the plan's controls alone; closed: with the tracking feedback (default open)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default reports/out/<scenario>/compare, or compare-closed)")
    p.add_argument("--json", action="store_true", help="print one JSON object (the verdict) instead of the tables")
    p.set_defaults(func=run)


def run(args) -> int:
    engines = tuple(engines_from_names(args.engines, minimum=2))
    case = ValidationCase(args.scenario, J=args.J, engines=engines, loop=args.loop)
    result = run_case(case)
    folder = "compare" if args.loop == "open" else "compare-closed"
    out = Path(args.out) if args.out else Path("reports") / "out" / result.plan.name / folder
    write_case(result, out)
    render_run(out, pdf=False)                        # the case page and an index of one
    verdict = result.verdict()
    if args.json:
        print(json.dumps(verdict, indent=2, default=float))
        return 0 if verdict["pass"] else 1
    print(result.report_text())
    if args.loop == "closed":
        for label, r in verdict["runs"].items():
            print(f"{label} against the flat outputs: max {r['max_position_error_m']:.3e} m, after 5 s "
                  f"{r['max_position_error_after_5s_m']:.3e} m; controls saturated {r['saturated_s']:.2f} s")
    print(f"figures and tables written to {out}/, report {out / 'index.html'}")
    if not verdict["pass"]:
        print("gflat compare: the engines disagree beyond the tolerances (or a run ended early): FAIL")
        return 1
    return 0
