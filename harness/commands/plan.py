"""``gflat plan SCENARIO [--J N] [--out DIR] [--json] [--verify] [--csv]``: plan a manoeuvre by (generalized) flatness.

A scenario with free parameters (``[parameters]`` with ranges) is planned bounded
(:func:`planners.bounded.plan_bounded`): the summary then has ``bounded`` (the optimum, its cost, the active
limits, the number of plans evaluated; :meth:`planners.bounded.BoundedResult.to_dict`) and the files are the
optimum's plan; bounds no parameter value can meet print one line naming the binding limit and its best
value (stderr) and exit with status 1 (the files of the least-violating plan are written).

``--json`` prints one JSON object (the plan's summary: ``planning_time_s``, ``feasible``, the full-model
equation residual per iterate, ...) instead of the text report; ``--verify`` flies the planned controls
open loop on the full model (:func:`planners.verify.open_loop_error`) and adds
``open_loop_max_position_error_m``.  An infeasible plan (exit status 1) is not flown: ``infeasible_reason``
says why, and with ``--verify`` the ``open_loop_*`` keys are present as null, ``open_loop_message`` saying
why the flight was not made.  A plan whose flat parametrization is singular (stage 2,
:data:`planners.singularity.SINGULAR`) keeps only its flat plan (``plan-j0.parquet``) and
``singularities.parquet``: the later iterates, built on an undetermined stage 2, are not written.  Tables are
Parquet; ``--csv`` writes each also as CSV, the same stem.
"""

from __future__ import annotations

import io
import math
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from gna.errors import InputError
from gna.schema import find_file
from planners.generalized import plan_scenario
from planners.scenario import list_scenarios, load_scenario
from planners.systems.demos import DEMOS, is_chained_scenario, run_demo
from planners.verify import open_loop_error

from ..artefacts import file_record, json_safe, manifest, write_json, write_plan_iterates, write_trajectory
from ..validation.validity import ValidityWarnings, check_plan
from ._args import cost_bound, iterations
from ._help import add_command
from ._json import add_json, emit
from ._output import add_out, default_out, run_dir


def register(sub) -> None:
    """Add the ``gflat plan`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "plan",
        help="plan a manoeuvre (flatness + generalized flatness)",
        description="Plan a scenario: flat parametrization on a grid of power series, then J "
        "generalized-flatness iterations; writes the plan of every iterate (plan-j<k>.parquet), the "
        "convergence table and summary.json. Bundled scenarios: "
        + ", ".join(list_scenarios())
        + "; chained-system demos: "
        + ", ".join(DEMOS),
        examples=[
            "gflat plan gtm-aileron-roll             # J = 7, the convergence table at t = -1.9 s",
            "gflat plan gtm-aileron-roll --json --verify --out roll   # and flown open loop on the full model",
            "gflat plan turn.toml --J auto --csv     # your own scenario, J by the convergence test, CSV too",
        ],
    )
    p.add_argument("scenario", help="bundled scenario name or path to a scenario TOML file")
    p.add_argument(
        "--J",
        type=iterations,
        default=None,
        help="generalized-flatness iterations, or auto (a convergence test; default: the scenario's)",
    )
    add_out(
        p,
        "output folder, created whole once the run is complete (default reports/out/<scenario>/plan under the current folder)",
    )
    p.add_argument(
        "--max-cost",
        type=cost_bound,
        default=None,
        metavar="UNITS",
        help="bound on the plan's cost, nodes x sum of squared orders (default 5e6, about 30 s; 'inf' for none)",
    )
    add_json(
        p,
        "plan",
        help="print one JSON object (planning_time_s, feasible, residual per iterate, ...; docs/cli.md) "
        "instead of the text report",
    )
    p.add_argument("--csv", action="store_true", help="write every table as CSV too (Parquet always)")
    p.add_argument(
        "--verify",
        action="store_true",
        help="fly the planned controls open loop on the full model (DOP853, rtol = atol = 1e-10) from "
        "the plan's initial state and report the largest distance to the flat outputs "
        "(open_loop_max_position_error_m)",
    )
    p.set_defaults(func=run)


def infeasible_reason(plan) -> str | None:
    """Why a plan is not feasible, in one line, or None when it is.

    Parameters
    ----------
    plan : planners.plan.Plan
        The plan.

    Returns
    -------
    str or None
        A singular flat parametrization first (the cause of the later iterates' divergence), then the
        last iterate's departure from the physical domain, then the Newton failures.
    """
    sing = plan.singularities.failures if plan.singularities is not None else []
    if sing:
        return sing[0]
    if plan.domain_failures:
        return plan.domain_failures[-1]
    if not plan.feasible:
        return (
            f"Newton failed ({len(plan.newton_failures)} warning(s)); its values at those times are not a "
            f"solution of the model"
        )
    return None


def _singular(plan) -> bool:
    return plan.singularities is not None and bool(plan.singularities.failures)


def save_plan_files(
    plan, out: str | Path, step: float | None = None, *, csv: bool = False, iterates: bool = True
) -> dict:
    """Write a plan's node series (npz), the plan of every iterate (``plan-j<k>.parquet``) and its singularity
    table (``singularities.parquet``) into a folder; with ``csv`` each table also as CSV (the same stem).

    A plan whose flat parametrization is singular (stage 2) gets only ``plan-j0.parquet`` and
    ``singularities.parquet``: its later iterates are not solutions of the model (values up to 1e+150 and
    beyond).

    Parameters
    ----------
    plan : planners.plan.Plan
        The plan.
    out : str or Path
        Folder (made when missing).
    step : float, optional
        Step [s] of the iterates' time grid (default: a quarter of the smallest node spacing).
    csv : bool
        Also write every table as CSV.
    iterates : bool
        Write the iterates here; without, they are only named (``gflat paper`` writes them on its flights'
        output grid, :func:`harness.artefacts.write_plan_iterates`).

    Returns
    -------
    dict
        What was written (``"series"``, ``"plan-j0"``, ``"singularities"``, ...) -> its file name in ``out``
        (with ``csv``, ``"plan-j0.csv"`` -> ...).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    singular = _singular(plan)
    if not singular:
        arrays = {"t_nodes": plan.t_nodes}
        for j, it in enumerate(plan.iterates):
            for name, s in it.series.items():
                arrays[f"j{j}/{name}"] = np.real(np.asarray(s.coeffs))
        with open(out / "plan_series.npz", "wb") as fh:
            np.savez_compressed(fh, **arrays)
        written["series"] = "plan_series.npz"
    js = [0] if singular else list(range(plan.J + 1))
    if iterates:
        step = step if step is not None else float(np.min(np.diff(plan.t_nodes))) / 4
        write_plan_iterates(out, plan, plan.to_dataframe(step=step, j=0).index, csv=csv, iterates=js)
    for j in js:
        written[f"plan-j{j}"] = f"plan-j{j}.parquet"
        if csv:
            written[f"plan-j{j}.csv"] = f"plan-j{j}.csv"
    sing = plan.singularities
    if sing is not None:
        table = sing.table
        table.to_parquet(out / "singularities.parquet")
        written["singularities"] = "singularities.parquet"
        if csv:
            table.to_csv(out / "singularities.csv", float_format="%.8g")
            written["singularities.csv"] = "singularities.csv"
    return written


def plan_summary(sc, plan, elapsed: float, check=None, not_flown: str | None = None) -> dict:
    """The numbers of a plan that ``summary.json`` and ``gflat plan --json`` carry.

    Parameters
    ----------
    sc : planners.scenario.Scenario
        The scenario planned.
    plan : planners.plan.Plan
        Its plan.
    elapsed : float
        Planning wall time [s].
    check : planners.verify.OpenLoopCheck, optional
        The open-loop verification flight, when made.
    not_flown : str, optional
        Why the verification flight asked for was not made (an infeasible plan): the ``open_loop_*``
        keys are then present as None, ``open_loop_status`` is ``"not flown"`` and ``open_loop_message``
        this text.

    Returns
    -------
    dict
        ``scenario``, ``aircraft``, ``environment`` (atmosphere and ground effect), ``g`` [m/s^2], ``J``, ``J_rule``
        (``"given"`` or the convergence test's stopping reason), ``e``, ``interpolation``, ``nodes``, ``orders``, ``planning_time_s``, ``timings_s``
        (per iterate), ``feasible``, ``infeasible_reason`` (None when feasible, :func:`infeasible_reason`),
        ``worst_newton_residual``, ``equation_residual_per_iterate`` (max
        over the 12 full-model equations at the nodes, SI units), ``warnings``; with ``check`` also
        ``open_loop_max_position_error_m`` [m] (None when the flight stopped early),
        ``open_loop_t_worst_s``, ``open_loop_max_angle_error_rad``, ``open_loop_status`` and
        ``open_loop_settings``; with ``not_flown`` the same keys as None and ``open_loop_message``.
    """
    res = plan.iterate_residuals()
    out = {
        "scenario": sc.name,
        "aircraft": sc.aircraft.id,
        "environment": plan.env.describe(),
        "g": plan.env.g,
        "J": plan.J,
        "J_rule": plan.generalized.get("J_rule", "given"),
        "J_stop": plan.generalized.get("J_stop"),
        "e": plan.e,
        "interpolation": plan.interpolation,
        "nodes": len(plan.t_nodes),
        "orders": [it.order for it in plan.iterates],
        "planning_time_s": elapsed,
        "timings_s": plan.timings,
        "feasible": bool(plan.feasible and not plan.domain_failures),
        "infeasible_reason": infeasible_reason(plan),
        "worst_newton_residual": plan.worst_newton_residual(),
        "equation_residual_per_iterate": res,
        "warnings": plan.warnings,
    }
    if getattr(plan, "bounded", None) is not None:
        out["bounded"] = plan.bounded.to_dict()
    if check is not None:
        ok = math.isfinite(check.max_position_error_m)
        out.update(
            {
                "open_loop_max_position_error_m": check.max_position_error_m if ok else None,
                "open_loop_t_worst_s": check.t_worst,
                "open_loop_max_angle_error_rad": check.max_angle_error_rad if ok else None,
                "open_loop_status": check.status,
                "open_loop_settings": check.settings,
            }
        )
        if not ok:
            out["open_loop_message"] = check.message
    elif not_flown is not None:
        out.update(
            {
                "open_loop_max_position_error_m": None,
                "open_loop_t_worst_s": None,
                "open_loop_max_angle_error_rad": None,
                "open_loop_status": "not flown",
                "open_loop_settings": None,
                "open_loop_message": not_flown,
            }
        )
    return out


def write_plan(
    sc,
    plan,
    elapsed: float,
    out,
    check=None,
    not_flown: str | None = None,
    shown: Path | None = None,
    *,
    csv: bool = False,
    iterates: bool = True,
) -> tuple[str, dict]:
    """Write a plan's files (series, CSV tables, convergence table, summary) to ``out``.

    Parameters
    ----------
    sc : planners.scenario.Scenario
        The scenario planned.
    plan : planners.plan.Plan
        Its plan.
    elapsed : float
        Planning wall time [s].
    out : str or Path
        Folder (made when missing).
    check : planners.verify.OpenLoopCheck, optional
        The open-loop verification flight, when made (reported and saved in the summary).
    not_flown : str, optional
        Why the verification flight asked for was not made (:func:`plan_summary`).
    shown : Path, optional
        The folder the report names (default ``out``; a command gives its final ``--out``, not the staging
        folder).
    csv, iterates : bool
        As :func:`save_plan_files`.

    Returns
    -------
    text : str
        The report printed by ``gflat plan``.
    summary : dict
        The contents of ``summary.json`` (:func:`plan_summary` plus the files written).
    """
    od = Path(out)
    written = save_plan_files(plan, od, csv=csv, iterates=iterates)
    summary = plan_summary(sc, plan, elapsed, check, not_flown)
    tn = plan.t_nodes
    lines = [
        f"{sc.name}: {sc.aircraft.id}, t = {tn[0]:g} .. {tn[-1]:g} s, {len(tn)} nodes, flat output "
        f"{sc.zeta.kind}, J = {plan.J}"
    ]
    orders = summary["orders"]
    if summary["J_rule"] != "given":
        lines.append(
            f"  J = {plan.J} chosen by the convergence test (stopped by {summary['J_stop']}): {summary['J_rule']}"
        )
    if getattr(plan, "bounded", None) is not None:
        lines.append(plan.bounded.text())
    lines.append(f"  orders of x, y, z per iterate: {orders} (controls at order {orders[-1] - 4})")
    lines.append(f"  planning time {elapsed:.3f} s ({', '.join(f'j={j}: {t:.3f}' for j, t in plan.timings.items())})")
    lines.append(f"  worst Newton residual: {plan.worst_newton_residual():.2e}")
    lines.append(
        "  full-model equation residual at the nodes (max over the 12 equations) per iterate: "
        + ", ".join(f"j={j}: {r:.2e}" for j, r in enumerate(summary["equation_residual_per_iterate"]))
    )
    if check is not None:
        if summary["open_loop_max_position_error_m"] is None:
            lines.append(f"  open-loop check: the flight stopped ({check.status}): {check.message}")
        else:
            lines.append(
                f"  open-loop check (full model, {check.settings['method']}, rtol = atol = "
                f"{check.settings['rtol']:g}): max distance to the flat outputs "
                f"{check.max_position_error_m:.3g} m at t = {check.t_worst:g} s; angles within "
                f"{check.max_angle_error_rad:.2g} rad of the plan"
            )
    elif not_flown is not None:
        lines.append(f"  open-loop check: {not_flown}")
    if plan.warnings:
        lines.append(f"  warnings ({len(plan.warnings)}):")
        lines += [f"    - {w}" for w in plan.warnings]
    else:
        lines.append("  no Newton or singularity warnings")
    if _singular(plan):
        lines.append(
            f"  no convergence table, plan_series.npz or plan-j1 .. plan-j{plan.J}: the iterates j >= 1 are built "
            "on a singular stage 2 and are not solutions of the model (plan-j0.parquet: the flat plan; "
            "singularities.parquet: the condition at the nodes)"
        )
    else:
        times = sc.report_times or [float(tn[0])]
        table = plan.convergence_table(sc.report_variables, times)
        lines.append("  convergence table (value at t for each iterate j):")
        with np.printoptions(linewidth=200):
            lines.append("    " + table.to_string(float_format=lambda v: f"{v:.6g}").replace("\n", "\n    "))
        buf = io.StringIO()
        table.to_csv(buf, float_format="%.10g")
        (od / "convergence.csv").write_text(buf.getvalue(), encoding="utf-8")
        written["convergence"] = "convergence.csv"
    summary["files"] = written
    write_json(od / "summary.json", json_safe(summary))
    lines.append(f"  written to {shown or od}/")
    return "\n".join(lines), summary


def run(args) -> int:
    """Run ``gflat plan`` with the parsed command line ``args``.

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
    if is_chained_scenario(args.scenario):  # a chained system of planners.systems, not an aircraft scenario
        refused = [
            flag
            for flag, given in (
                ("--verify", args.verify),
                ("--max-cost", args.max_cost is not None),
                ("--J auto", args.J == "auto"),
            )
            if given
        ]
        if refused:
            raise InputError(
                f"{', '.join(refused)}: for aircraft scenarios only; a chained system's plan is always "
                f"checked against its exact model (summary: checks, feasible) and takes a whole J"
            )
        out = run_dir(args, command="plan") if args.out else None  # checked before planning
        demo = run_demo(args.scenario, J=args.J)
        out = out if out is not None else default_out(demo.summary["scenario"], "plan", command="plan")
        last = f"plan-j{demo.summary['J']}"
        with out:
            table = pd.read_csv(io.StringIO(demo.csv)).set_index("t")
            written = write_trajectory(out.root, last, table, csv=getattr(args, "csv", False))
            summary = {**demo.summary, "files": {p.name if p.suffix == ".csv" else last: p.name for p in written}}
            out.write_json("summary.json", obj=json_safe(summary))
            out.commit(manifest(command_line=getattr(args, "command_line", None)))
        if args.json:
            emit(args, {**summary, "out": str(out.out)})
        else:
            print(demo.text + f"\n  written to {out.out}/")
        if demo.summary["failure"]:
            print(f"gflat plan: the plan is not feasible: {demo.summary['failure']}", file=sys.stderr)
            return 1
        return 0
    bundled = list_scenarios()
    if find_file(args.scenario, {n: Path(n) for n in bundled}, "scenario") is None:  # a bare name, not bundled
        raise InputError(
            f"unknown scenario {str(args.scenario)!r}; bundled scenarios: {', '.join(bundled)}; chained systems: "
            f"{', '.join(DEMOS)} (or give the path of a .toml file)"
        )
    sc = load_scenario(args.scenario, J=args.J)
    with run_dir(args, sc.name, "plan", command="plan") as out:  # checked before planning
        t0 = time.perf_counter()
        plan = plan_scenario(sc, max_cost=args.max_cost)
        elapsed = time.perf_counter() - t0
        check_plan(ValidityWarnings(), plan)  # the validity box of the aerodynamic data said aloud (stderr)
        reason = infeasible_reason(plan)
        check = open_loop_error(plan) if args.verify and reason is None else None
        not_flown = f"not flown: the plan is not feasible: {reason}" if args.verify and reason is not None else None
        text, summary = write_plan(sc, plan, elapsed, out.root, check, not_flown, shown=out.out, csv=args.csv)
        out.commit(
            manifest(inputs={"scenario": file_record(sc.path)}, command_line=getattr(args, "command_line", None))
        )
    if args.json:
        emit(args, {**summary, "out": str(out.out)})
    else:
        print(text)
    if reason is not None:
        if plan.domain_failures or _singular(plan):
            print(f"gflat plan: the plan is not feasible: {reason}", file=sys.stderr)
        else:
            print(
                f"gflat plan: the plan is not feasible: Newton failed ({len(plan.newton_failures)} warning(s) "
                f"above); its values at those times are not a solution of the model",
                file=sys.stderr,
            )
        return 1
    if check is not None and summary["open_loop_max_position_error_m"] is None:
        print(f"gflat plan: the open-loop check did not reach the end of the plan: {check.message}", file=sys.stderr)
        return 1
    bounded = getattr(plan, "bounded", None)
    if bounded is not None and not bounded.feasible:
        print(f"gflat plan: infeasible bounds: {bounded.infeasible_line()}", file=sys.stderr)
        return 1
    return 0
