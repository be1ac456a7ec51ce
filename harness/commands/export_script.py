"""``gflat export-jsbsim-script SCENARIO --out DIR [--json]``: a plan as files stock JSBSim replays natively.

The replay command printed (and ``replay`` of ``--json``) runs as printed: the ``jsbsim`` executable the
jsbsim Python package installs, the paths absolute and quoted for a POSIX shell (:func:`replay_command`),
the CSV written into the current folder (never into the run's folder, which stays as its manifest lists).
"""

from __future__ import annotations

import os
import shlex
from pathlib import Path

from gna.errors import InputError
from planners.generalized import plan_scenario
from planners.scenario import list_scenarios, load_scenario

from ..engines.jsbsim.engine import JSBSimEngine
from ..engines.jsbsim.grid import output_grid
from ..engines.jsbsim.script import export_script, steps_of
from ._args import iterations, positive_float
from ._help import add_command
from ._json import add_json, emit
from ._output import add_out, run_dir


def register(sub) -> None:
    """Add the ``gflat export-jsbsim-script`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "export-jsbsim-script",
        help="write a plan as a JSBSim script (aircraft, initialization, control tables, CSV output)",
        description="Plan a scenario and write what stock JSBSim needs to replay the plan open loop: "
        "DIR/aircraft/<id>/<id>.xml, DIR/aircraft/<id>/<scenario>-init.xml, "
        "DIR/scripts/<scenario>.xml (the controls as tables of sim-time, the gflat JSBSim "
        "engine's step and integrators) writing <scenario>.csv. It prints the command that replays it, "
        "'jsbsim --root=DIR --script=scripts/<scenario>.xml --outputpath=FOLDER' (the jsbsim Python "
        "package's executable; the CSV goes to FOLDER, the current one), or use the package's "
        "FGFDMExec(DIR).load_script(...). Bundled scenarios: " + ", ".join(list_scenarios()),
        examples=[
            "gflat export-jsbsim-script gtm-aileron-roll --out roll-script   # then run the printed jsbsim line",
            "gflat export-jsbsim-script gtm-aileron-roll --out roll-script --replace --table-dt 0.05 --json",
        ],
    )
    p.add_argument("scenario", help="bundled scenario name or path to a scenario TOML file")
    add_out(p, "output folder, created whole once written", required=True)
    p.add_argument(
        "--J", type=iterations, default=None, help="generalized-flatness iterations, or auto (default: the scenario's)"
    )
    p.add_argument(
        "--dt-out",
        type=positive_float,
        default=0.025,
        metavar="S",
        help="output interval of the CSV [s], a whole number of JSBSim steps (1/480 s) dividing the "
        "span (default 0.025, 12 steps)",
    )
    p.add_argument(
        "--table-dt",
        type=positive_float,
        default=None,
        metavar="S",
        help="interval of the control tables [s], a whole number of JSBSim steps and at most the "
        "plan's node step, linear interpolation in between (smaller files; default: every step, "
        "the JSBSim engine's control samples exactly)",
    )
    add_json(p, "export-jsbsim-script")
    p.set_defaults(func=run)


def replay_command(root: Path, script: str, output_folder: Path) -> str:
    """The shell command that replays an export with the jsbsim package's ``jsbsim`` executable.

    Parameters
    ----------
    root : Path
        The export's folder (JSBSim's root directory).
    script : str
        The script, relative to ``root`` (``scripts/<scenario>.xml``).
    output_folder : Path
        Where JSBSim writes the CSV (its output path).

    Returns
    -------
    str
        ``jsbsim --root=ROOT --script=SCRIPT --outputpath=FOLDER``, the paths absolute and quoted
        (:func:`shlex.quote`): it runs as printed from any folder.
    """
    words = [
        "jsbsim",
        f"--root={os.path.abspath(root)}",
        f"--script={script}",
        f"--outputpath={os.path.abspath(output_folder)}",
    ]
    return " ".join(shlex.quote(w) for w in words)


def run(args) -> int:
    """Run ``gflat export-jsbsim-script`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).

    Raises
    ------
    gna.errors.InputError
        A bad option value, file or output folder (one line; exit status 2).
    """
    sc = load_scenario(args.scenario, J=args.J)
    n, dt, _, _ = output_grid(sc.t0, sc.t1, JSBSimEngine().dt, args.dt_out, None)  # intervals checked first
    steps_of(args.dt_out, dt, "--dt-out")
    if args.table_dt is not None:
        steps_of(args.table_dt, dt, "--table-dt")
        if args.table_dt > sc.step * (1 + 1e-9):
            raise InputError(
                f"--table-dt {args.table_dt:g} s is longer than the plan's node step {sc.step:g} s: "
                f"the tables' straight lines would replace the plan's controls between its nodes"
            )
    with run_dir(args, command="export-jsbsim-script") as out:  # checked before planning
        plan = plan_scenario(sc)
        if not plan.feasible:
            why = (
                f"Newton failed: {'; '.join(plan.newton_failures[:3])}"
                if plan.newton_failures
                else plan.domain_failures[-1]
            )
            raise InputError(f"the plan of {sc.name} is not feasible ({why}); nothing written")
        b = export_script(
            out.root,
            sc.name,
            sc.aircraft,
            plan,
            (plan.t0, plan.t1),
            plan.initial_state(),
            env=sc.env,
            dt_out=args.dt_out,
            table_dt=args.table_dt,
        )
        out.commit()
    replay = replay_command(out.out, b.script, Path.cwd())
    if getattr(args, "json", False):
        emit(
            args,
            {
                "scenario": sc.name,
                "aircraft": sc.aircraft.id,
                "out": str(out.out),
                "t_span_s": list(b.t_span),
                "jsbsim_dt_s": b.dt,
                "dt_out_s": args.dt_out,
                "table_dt_s": args.table_dt,
                "rows": b.rows,
                "files": {what: str(out.out / getattr(b, what)) for what in ("aircraft", "initialization", "script")},
                "output": b.output,
                "replay": replay,
            },
        )
        return 0
    print(f"{sc.name}: t = {b.t_span[0]:g} .. {b.t_span[1]:g} s, JSBSim step {b.dt:.6g} s, {b.rows} control-table rows")
    for what in ("aircraft", "initialization", "script"):
        print(f"  {what}: {out.out / getattr(b, what)}")
    print(f"  replay (writes {b.output} in the current folder):")
    print(f"    {replay}")
    return 0
