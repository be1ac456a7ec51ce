"""``gflat compare SCENARIO [--J N] [--loop open|closed] [--engines inhouse,jsbsim] [--out DIR] [--json] [--csv]``.

Plans the scenario, flies the J-th iterate's controls on every engine from the
same planned initial state -- open loop, or closed loop with the paper's
tracking feedback (the scenario's ``[tracking]`` table) -- and prints the
difference tables (first 10 s and the whole span) of each engine against the
first, plus each engine's deviation from the plan; figures go to the output
folder with each engine's trajectory (Parquet, CSV with ``--csv``), the plan of
every iterate, ``summary.json`` (verdict and the tolerances that made it) and
``manifest.json``.  Tolerances, windows, output grid and JSBSim step come from
the flags, else the scenario's ``[compare]`` table, else the defaults.  With
``--json`` stdout carries one JSON object (the verdict) instead.  The three
verdicts (flyable, tracking, engines_agree) are printed last; the exit status
is 1 when one fails that the scenario does not record (``[verdicts] known``).
"""

from __future__ import annotations

import math

from planners.scenario import list_scenarios, load_scenario
from reports.case_files import write_case
from reports.html import render_run

from ..artefacts import run_manifest
from ..engines import engine_names, engines_from_names
from ..validation import ValidationCase, case_settings, run_case
from ..validation.validity import ValidityWarnings, check_result
from ..validation.verdicts import verdict_lines
from ._args import iterations
from ._compare_args import add_compare_arguments, check_steps, compare_overrides
from ._help import add_command
from ._json import add_json, emit
from ._output import add_out, run_dir


def register(sub) -> None:
    """Add the ``gflat compare`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "compare",
        help="fly a plan on several engines, open or closed loop, and compare them",
        description="Plan a scenario and fly its controls on the in-house model and JSBSim (or the "
        "--engines given) from the same initial state, open loop or, with --loop closed, with the "
        "tracking feedback; print the difference tables of each engine against the first and the three "
        "verdicts, and write the trajectories (Parquet; CSV with --csv), figures, summary.json and a "
        "report page. Bundled scenarios: " + ", ".join(list_scenarios()),
        examples=[
            "gflat compare gtm-forward-slip                       # open loop, in-house model and JSBSim",
            "gflat compare twin-otter-single-engine --loop closed --json   # with the tracking feedback",
            "gflat compare f16-s-turn --engines inhouse,jsbsim-source --out s-turn   # on JSBSim's own F-16",
        ],
    )
    p.add_argument("scenario", help="bundled scenario name or path to a scenario TOML file")
    p.add_argument(
        "--J", type=iterations, default=None, help="generalized-flatness iterations, or auto (default: the scenario's)"
    )
    p.add_argument(
        "--engines",
        default="inhouse,jsbsim",
        help=f"comma-separated engines, the first is the reference ({', '.join(engine_names())})",
    )
    p.add_argument(
        "--loop",
        choices=("open", "closed"),
        default="open",
        help="open: the plan's controls alone; closed: with the tracking feedback (default open)",
    )
    add_out(
        p,
        "output folder, created whole once the run is complete (default reports/out/<scenario>/open, or closed, under the current folder)",
    )
    add_json(p, "compare", help="print one JSON object (the verdict; docs/cli.md) instead of the tables")
    add_compare_arguments(p)
    p.set_defaults(func=run)


def error_text(value: float, t_end: float) -> str:
    """A position error for the command output: metres, or why there is none (the run ended before the window).

    Parameters
    ----------
    value : float
        The error [m]; NaN when the run ended before the window it is measured over.
    t_end : float
        The time the run ended [s].

    Returns
    -------
    str
        ``"1.500e-03 m"``, or ``"n/a (run ended at t = 3.25 s)"``.
    """
    return f"{value:.3e} m" if math.isfinite(value) else f"n/a (run ended at t = {t_end:g} s)"


def run(args) -> int:
    """Run ``gflat compare`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).
    """
    engines = tuple(engines_from_names(args.engines, minimum=2))
    case = ValidationCase(args.scenario, J=args.J, engines=engines, loop=args.loop, **compare_overrides(args))
    scenario = load_scenario(case.scenario, J=case.J)
    settings = case_settings(case, scenario)  # settings, work and destination checked before planning
    check_steps([(case, scenario, settings)], args.max_steps, "compare")
    progress = getattr(args, "progress", None)
    with run_dir(args, scenario.name, args.loop, command="compare") as out:
        result = run_case(case, scenario=scenario, progress=progress)
        check_result(ValidityWarnings(), result)  # the validity box of the aerodynamic data said aloud (stderr)
        write_case(result, out.root, csv=args.csv, manifest=False, progress=progress)
        record = run_manifest([result], command_line=getattr(args, "command_line", None))
        render_run(out.root, manifest=record, progress=progress)  # the case page, an index of one and the PDF
        out.commit(record)
    verdict = result.verdict()
    if args.json:
        emit(args, {**verdict, "out": str(out.out), "report": str(out.out / "index.html")})
        return 0 if verdict["pass"] else 1
    print(result.report_text())
    if args.loop == "closed":
        for label, r in verdict["runs"].items():
            after = error_text(r["max_position_error_after_5s_m"], result.runs[label].t_end)
            print(
                f"{label} against the flat outputs: max {r['max_position_error_m']:.3e} m, after 5 s "
                f"{after}; controls saturated {r['saturated_s']:.2f} s"
            )
    print(f"figures, trajectories and tables written to {out.out}/, report {out.out / 'index.html'}")
    print("\n".join(verdict_lines(verdict["verdicts"], {"unrecorded": verdict["failures"]})))
    if not verdict["pass"]:
        print(f"gflat compare: {', '.join(verdict['failures'])} not recorded by the scenario: FAIL")
        return 1
    return 0
