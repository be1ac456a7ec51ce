"""``gflat compare SCENARIO [--J N] [--engines inhouse,jsbsim] [--out DIR]``.

Plans the scenario, flies the J-th iterate's controls open loop on every
engine from the same planned initial state, and prints the difference tables
(first 10 s and the whole span) of each engine against the first, plus each
engine's deviation from the plan; figures go to the output folder.
"""

from __future__ import annotations

from pathlib import Path

from gna.errors import InputError
from planners.scenario import list_scenarios
from reports.case_files import write_case

from ..engines import engine_names
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
    p.add_argument("--out", default=None, metavar="DIR", help="output folder (default reports/out/<scenario>/compare)")
    p.set_defaults(func=run)


def engines_from_text(text: str) -> tuple[str, ...]:
    """Engine names of ``--engines`` (at least two, known to the registry)."""
    known = engine_names()
    names = tuple(e.strip() for e in text.split(",") if e.strip())
    bad = [e for e in names if e not in known]
    if bad or len(names) < 2:
        raise InputError(f"--engines needs at least two of {', '.join(known)}; got {text!r}")
    return names


def run(args) -> int:
    case = ValidationCase(args.scenario, J=args.J, engines=engines_from_text(args.engines))
    result = run_case(case)
    out = Path(args.out) if args.out else Path("reports") / "out" / result.plan.name / "compare"
    write_case(result, out)
    print(result.report_text())
    print(f"figures and tables written to {out}/")
    if not result.passed:
        print("gflat compare: the engines disagree beyond the tolerances (or a run ended early): FAIL")
        return 1
    return 0
