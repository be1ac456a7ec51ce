"""``gflat export-jsbsim-script SCENARIO --out DIR``: a plan as files stock JSBSim replays natively."""

from __future__ import annotations

from gna.errors import InputError
from planners.generalized import plan_scenario
from planners.scenario import list_scenarios, load_scenario

from ..engines.jsbsim.engine import JSBSimEngine
from ..engines.jsbsim.grid import output_grid
from ..engines.jsbsim.script import export_script, steps_of
from ._args import iterations, positive_float
from ._output import add_out, run_dir


def register(sub) -> None:
    """Add the ``gflat export-jsbsim-script`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = sub.add_parser(
        "export-jsbsim-script",
        help="write a plan as a JSBSim script (aircraft, initialization, control tables, CSV output)",
        description="Plan a scenario and write what stock JSBSim needs to replay the plan open loop: "
        "DIR/aircraft/<id>/<id>.xml, DIR/aircraft/<id>/<scenario>-init.xml, "
        "DIR/scripts/<scenario>.xml (the controls as tables of sim-time, the gflat JSBSim "
        "engine's step and integrators) writing <scenario>.csv. Run it with "
        "'JSBSim --root=DIR --script=scripts/<scenario>.xml' or the jsbsim Python "
        "package's FGFDMExec(DIR).load_script(...). Bundled scenarios: " + ", ".join(list_scenarios()),
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
    p.set_defaults(func=run)


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
    print(f"{sc.name}: t = {b.t_span[0]:g} .. {b.t_span[1]:g} s, JSBSim step {b.dt:.6g} s, {b.rows} control-table rows")
    for what in ("aircraft", "initialization", "script"):
        print(f"  {what}: {args.out / getattr(b, what)}")
    print(
        f"  replay: JSBSim --root={args.out} --script={b.script}  (writes {b.output} in JSBSim's output path, "
        f"{args.out} with the jsbsim Python package)"
    )
    return 0
