"""``gflat paper [--out DIR] [--J N] [--loop open|closed|both] [--csv] [--json] [comparison flags]``: the main job.

Plans the paper's three manoeuvres (single-engine Twin Otter, GTM forward slip,
GTM aileron roll in a zero-g parabola) by flatness and generalized flatness,
flies each plan on the in-house model and on JSBSim from the same initial
state, open loop and closed loop with the paper's tracking feedback, and writes
the plans, figures (the paper's four-curve figure per scenario) and difference
tables.

Layout of ``--out DIR``: ``DIR/manifest.json``; ``DIR/<scenario>/plan/`` (the
plan's series, ``plan-j<k>.parquet`` of every iterate, the convergence table,
``singularities.parquet``, ``summary.json``; CSV copies with ``--csv``); ``DIR/<scenario>/open/`` and ``DIR/<scenario>/closed/``
(``trajectory-<engine>.parquet``, figures, ``differences.txt``,
``summary.json``); the report pages (``index.html``, a ``case.html`` per case,
``report.pdf``).  The folder appears whole once everything is written
(:class:`harness.rundir.RunDir`: ``manifest.json`` last, with every file's
sha256).

The plans are made in this process; the flights of the cases and the writing
of their folders run in forked worker processes (``--jobs``,
:class:`harness.parallel.ForkPool`), each writing its case's files directly
into the run's staging folder; the closed loop's open-loop curve is the
open-loop case's reference run (the same flight, flown once).  The flights
start longest first (:func:`harness.validation.work.flight_work`), before any
case's files are written, and the figures are prepared while the first fly.
The pages and the PDF (printed by Typst, in this process) are rendered at the
end from the saved ``report.json`` files (:func:`reports.html.render_run`).
"""

from __future__ import annotations

import time
from dataclasses import replace

from planners.scenario import load_scenario
from reports.case_files import write_case
from reports.figures import prepare as prepare_figures
from reports.html import prepare as prepare_pages
from reports.html import render_run

from ..artefacts import cpu_split, cpu_time, run_manifest, write_plan_iterates
from ..parallel import ForkPool, default_jobs
from ..progress import stage
from ..validation import ValidationCase, case_settings, plan_case
from ..validation.flights import OPEN_LOOP, case_flights, finish_case, reusable_open_loop
from ..validation.validity import ValidityWarnings, check_plan, check_run
from ..validation.verdicts import verdict_lines
from ..validation.work import flight_work
from ._args import iterations, worker_count
from ._compare_args import add_compare_arguments, check_steps, compare_overrides
from ._help import add_command
from ._json import add_json, emit
from ._output import add_out, run_dir
from .plan import write_plan

PAPER_SCENARIOS = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")
ANGLE_STATES = ("gamma", "chi", "alpha", "beta", "mu")


def register(sub) -> None:
    """Add the ``gflat paper`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "paper",
        help="plan the paper's three manoeuvres and fly them on both engines",
        description=__doc__.split("\n\n")[1],
        examples=[
            "gflat paper                              # reports/out/paper/ under the current folder",
            "gflat paper --loop open --jobs 1 --out run   # open loop only, in one process",
            "gflat paper --json --out run --replace   # the verdicts as one JSON object",
        ],
    )
    add_out(
        p, "output folder, created whole once the run is complete (default reports/out/paper under the current folder)"
    )
    p.add_argument("--J", type=iterations, default=None, help="iterations, or auto (default: each scenario's)")
    p.add_argument(
        "--loop",
        choices=("open", "closed", "both"),
        default="both",
        help="fly the plans open loop, closed loop with the tracking feedback, or both (default both)",
    )
    p.add_argument(
        "--jobs",
        type=worker_count,
        default=None,
        metavar="N",
        help="worker processes flying the cases and drawing their figures concurrently (default: the "
        "CPUs available; 1: everything in this process); the results and files are the same",
    )
    add_compare_arguments(p)
    add_json(p, "paper")
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
    return [
        ValidationCase(name, J=J, engines=("inhouse", "jsbsim"), loop=loop, **overrides) for name in PAPER_SCENARIOS
    ]


def _timed(fn):
    """``fn`` wrapped to return ``(value, wall time [s])``."""

    def timed():
        t0 = time.perf_counter()
        return fn(), time.perf_counter() - t0

    return timed


def _write_priority(work: float) -> float:
    """The pool priority of writing a case's files: below every flight's (its :func:`flight_work`, positive), so
    that the flights go first, longest first, and the writes then, the case of most ``work`` first."""
    return -1.0 / (1.0 + work)


def _write_task(result, root, sub: tuple, plan_sub: tuple | None, csv: bool, progress=None):
    """A case folder's files (and the plan iterates with ``plan_sub``) written into the staging folder ``root``."""

    def write():
        write_case(result, root.joinpath(*sub), csv=csv, plan=False, manifest=False, progress=progress)
        if plan_sub is not None:
            write_plan_iterates(
                root.joinpath(*plan_sub), result.plan, result.runs[result.reference_engine].df.index, csv=csv
            )
        return True

    return write


class _Scenario:
    """One scenario of the run: its plan, the flights and files of its cases (in worker processes), its lines.

    The plan is made in this process (the workers, forked later, inherit it);
    the closed loop's open-loop run is the open case's reference run when it is
    the same flight (:func:`harness.validation.flights.reusable_open_loop`).
    """

    def __init__(self, case, loops: tuple, root, shown, csv: bool, progress=None, validity=None):
        self.case, self.loops, self.root, self.shown, self.csv = case, loops, root, shown, csv
        self.progress, self.validity = progress, validity or ValidityWarnings()
        self.name = case.scenario
        self.lines = [f"=== {case.scenario}"]
        self.flights, self.runs, self.results, self.files = {}, {}, {}, {}
        self.elapsed = {loop: 0.0 for loop in loops}
        self.submitted: set = set()
        self.t_plan = 0.0
        self.cpu_plan = 0.0

    def plan(self, pool: ForkPool) -> None:
        """Plan, write the plan's files, set the cases up and submit their flights."""
        t0, c0 = time.perf_counter(), time.process_time()
        with stage(self.progress, f"planning {self.case.scenario}"):
            planned = plan_case(self.case)
        self.name = planned.scenario.name
        self.aircraft = planned.plan.aircraft
        check_plan(self.validity, planned.plan)  # the validity box said aloud, once per quantity in the run
        with pool.held():  # the scenario's flights submitted as soon as it is set up, the longest started first
            for loop in self.loops:
                self.flights[loop] = case_flights(
                    replace(self.case, loop=loop), plan=planned.plan, scenario=planned.scenario
                )
                self.runs[loop] = {}
                for name in self.flights[loop].flights:
                    if not (loop == "closed" and name == OPEN_LOOP and "open" in self.loops):
                        self._fly(pool, loop, name)  # the open-loop run waits for the open case's
        folder = self.root / self.name / "plan"
        shown = self.shown / self.name / "plan"
        text, self.plan_summary = write_plan(
            planned.scenario, planned.plan, planned.planning_time_s, folder, shown=shown, csv=self.csv, iterates=False
        )  # the iterates are written with the first case's files, on its flights' output grid
        self.lines.append(text)
        self.t_plan = time.perf_counter() - t0
        self.cpu_plan = time.process_time() - c0

    def _fly(self, pool: ForkPool, loop: str, name: str) -> None:
        self.submitted.add((loop, name))
        pool.submit(
            ("fly", self.name, loop, name),
            _timed(self.flights[loop].flights[name]),
            priority=flight_work(self.flights[loop], name),
            what=f"flying {self.name} ({loop} loop, {name})",
        )

    def receive(self, pool: ForkPool, key: tuple, value) -> None:
        """A worker's result: a run, or a case folder written; the next steps submitted."""
        (out, dt), loop = value, key[2]
        self.elapsed[loop] += dt
        if key[0] == "write":
            self.files[loop] = out
            return
        self.runs[loop][key[3]] = out
        check_run(self.validity, self.aircraft, out, f"{key[3]} flight of {self.name}, {loop} loop")
        runs = self.runs.get("closed")
        ref = self.case.engines[0]
        if runs is not None and "open" in self.loops and OPEN_LOOP not in runs and ref in self.runs["open"]:
            if reusable_open_loop(self.flights["closed"], self.runs["open"][ref]):
                runs[OPEN_LOOP] = self.runs["open"][ref]
            elif ("closed", OPEN_LOOP) not in self.submitted:
                self._fly(pool, "closed", OPEN_LOOP)
        for lp in self.loops:
            cf = self.flights[lp]
            if lp in self.results or any(name not in self.runs[lp] for name in cf.flights):
                continue
            self.results[lp] = result = finish_case(cf, self.runs[lp])
            result.verdict()  # judged here once (and the saturation): the forked writer inherits it (summary, report)
            plan_sub = (self.name, "plan") if lp == self.loops[0] else None
            pool.submit(
                ("write", self.name, lp),
                _timed(_write_task(result, self.root, (self.name, lp), plan_sub, self.csv, self.progress)),
                priority=_write_priority(sum(flight_work(cf, name) for name in cf.flights)),
                what=f"writing the {lp}-loop files of {self.name}",
            )

    @property
    def done(self) -> bool:
        """Every case's files are written."""
        return all(loop in self.files for loop in self.loops)


def run(args) -> int:
    """Run ``gflat paper`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).
    """
    rows, passed, closed_rows, results, verdict_rows = [], [], [], [], []
    cases = paper_cases(args.J, **compare_overrides(args))
    loops = ("open", "closed") if args.loop == "both" else (args.loop,)
    planned = []
    progress = getattr(args, "progress", None)
    with stage(progress, "reading the scenarios"):
        for case in cases:  # every scenario's [compare] table checked before any planning
            scenario = load_scenario(case.scenario, J=case.J)
            planned += [(replace(case, loop=loop), scenario, case_settings(case, scenario)) for loop in loops]
        check_steps(planned, args.max_steps, "paper")  # and the work of every flight
    out = run_dir(args, "paper", command="paper")  # the default, the tool's own folder: an earlier run replaced
    cpu0 = cpu_time()
    with out, ForkPool(args.jobs or default_jobs(), progress=progress) as pool:
        validity = ValidityWarnings()
        scenarios = [_Scenario(case, loops, out.root, out.out, args.csv, progress, validity) for case in cases]
        by_name = {}
        for sc in scenarios:
            sc.plan(pool)
            by_name[sc.name] = sc
            pool.poll()  # a worker done meanwhile takes the next flight (the longest queued)
        pool.start_ahead()  # one flight more while this process prepares (a worker done meanwhile waits for it)
        c_prep = cpu_time()
        with stage(progress, "preparing the figures"):  # while the first flights fly
            prepare_figures()  # one figure and its axes made here, inherited by every forked writer (none yet)
            prepare_pages()  # the HTML templates compiled while the flights fly
        cpu_prepare = cpu_time() - c_prep  # writing's, though spent here
        emitted = 0
        while emitted < len(scenarios):
            if not scenarios[emitted].done:
                key, value = pool.next_result()
                by_name[key[1]].receive(pool, key, value)
                continue
            sc = scenarios[emitted]  # files written and lines printed in the scenarios' order
            emitted += 1
            name = sc.name
            print("\n".join(sc.lines))
            passed.append(True)
            if "open" in loops:
                result = sc.results["open"]
                results.append(result)
                ov = result.verdict()
                passed[-1] = ov["pass"]
                verdict_rows.append((name, "open", ov))
                first, whole = result.tables["jsbsim"]["first 10 s"], result.tables["jsbsim"]["whole span"]
                pos = lambda tab: tab.row("position").max_abs  # noqa: E731
                ang = lambda tab: max(tab.row(v).max_abs for v in ANGLE_STATES)  # noqa: E731
                J = result.plan.J
                rows.append(
                    (
                        name,
                        result.plan.aircraft.id,
                        J,
                        pos(first),
                        ang(first),
                        pos(whole),
                        ang(whole),
                        sc.t_plan + sc.elapsed["open"],
                    )
                )
                print(
                    f"  in-house vs JSBSim (open loop, J = {J}): first 10 s {pos(first):.2e} m, "
                    f"{ang(first):.2e} rad; whole span {pos(whole):.2e} m, {ang(whole):.2e} rad"
                )
                print("\n".join(f"  {line}" for line in verdict_lines(ov["verdicts"], {"unrecorded": ov["failures"]})))
                print(f"  figures, trajectories and tables: {out.out / name / 'open'}/")
            if "closed" not in loops:
                continue
            closed = sc.results["closed"]
            results.append(closed)
            v = closed.verdict()
            passed[-1] = passed[-1] and v["pass"]
            verdict_rows.append((name, "closed", v))
            runs = v["runs"]
            closed_rows.append(
                (
                    name,
                    runs["inhouse"]["max_position_error_m"],
                    runs["jsbsim"]["max_position_error_m"],
                    v["differences"]["jsbsim"]["max_position_m"],
                    runs["inhouse"]["saturated_s"],
                    v["pass"],
                )
            )
            print(
                f"  closed loop (tracking feedback): in-house {runs['inhouse']['status']}, max "
                f"{runs['inhouse']['max_position_error_m']:.2e} m from the flat outputs; JSBSim "
                f"{runs['jsbsim']['status']}, {runs['jsbsim']['max_position_error_m']:.2e} m; in-house vs JSBSim "
                f"{v['differences']['jsbsim']['max_position_m']:.2e} m"
            )
            print("\n".join(f"  {line}" for line in verdict_lines(v["verdicts"], {"unrecorded": v["failures"]})))
            print(f"  four-curve figure: {out.out / name / 'closed' / 'tracking.png'}")
        jobs, log = pool.jobs, pool.log
        pool.close()
        how = "cases flown and written by forked worker processes" if jobs > 1 else "in one process"
        record = run_manifest(
            results,
            command_line=getattr(args, "command_line", None),
            execution={"jobs": jobs, "how": how, "planning_s": {sc.name: sc.t_plan for sc in scenarios}, "tasks": log},
        )
        c0 = cpu_time()
        report = render_run(out.root, manifest=record, progress=progress)  # from the saved report.json files
        record["execution"]["cpu_s"] = cpu_split(
            log, sum(sc.cpu_plan for sc in scenarios), cpu_time() - c0 + cpu_prepare, cpu_time() - cpu0
        )
        with stage(progress, "writing the manifest"):
            out.commit(record)
    print(f"\nmanifest, plans, trajectories, figures, tables and report written to {out.out}/")
    failed = [c.scenario for c, ok in zip(cases, passed) if not ok]
    if rows:
        print("\nsummary: in-house vs JSBSim, open loop with the generalized-flatness controls")
        print(
            f"  {'scenario':<26} {'aircraft':<10} {'J':>2} {'pos 10 s [m]':>12} {'ang 10 s [rad]':>14} "
            f"{'pos all [m]':>11} {'ang all [rad]':>13} {'time [s]':>8}"
        )
    for r in rows:
        print(f"  {r[0]:<26} {r[1]:<10} {r[2]:>2} {r[3]:>12.2e} {r[4]:>14.2e} {r[5]:>11.2e} {r[6]:>13.2e} {r[7]:>8.1f}")
    if closed_rows:
        print("\nclosed loop with the tracking feedback (from the planned initial state)")
        print(
            f"  {'scenario':<26} {'in-house [m]':>12} {'JSBSim [m]':>11} {'in-house vs JSBSim [m]':>22} "
            f"{'beyond limits [s]':>17}  result"
        )
    for r in closed_rows:
        print(f"  {r[0]:<26} {r[1]:>12.2e} {r[2]:>11.2e} {r[3]:>22.2e} {r[4]:>17.2f}  {'PASS' if r[5] else 'FAIL'}")
    if closed_rows:
        print(
            "  (beyond limits: time the commanded controls exceed the aircraft's limits, clipped when the scenario's\n"
            "   [tracking] saturate is on)"
        )
    if verdict_rows:
        print(
            "\nverdicts (flyable: the plan within the aircraft's limits; tracking: closed loop, the flat outputs held;"
        )
        print("engines_agree: the difference tables; FAIL* = failing, recorded by the scenario's [verdicts] known)")
        print(f"  {'scenario':<26} {'loop':<6} {'flyable':>8} {'tracking':>8} {'engines_agree':>13}  result")

        def word(verdict, name):
            ok = verdict["verdicts"][name]["pass"]
            if ok is None:
                return "n/a"
            if ok:
                return "PASS"
            return "FAIL" if any(f == name or f.startswith(name + ":") for f in verdict["failures"]) else "FAIL*"

        for name, loop, verdict in verdict_rows:
            print(
                f"  {name:<26} {loop:<6} {word(verdict, 'flyable'):>8} {word(verdict, 'tracking'):>8} "
                f"{word(verdict, 'engines_agree'):>13}  {'PASS' if verdict['pass'] else 'FAIL'}"
            )
        for name, loop, verdict in verdict_rows:
            for rec in verdict["recorded"]:
                print(f"  recorded ({name}, {loop}): {rec['failure']}: {rec['reason']}")
    print(f"\nreport: {out.out / report['index'].name} (PDF: {out.out / report['pdf'].name})")
    if args.json:
        emit(
            args,
            {
                "out": str(out.out),
                "report": {"index": str(out.out / report["index"].name), "pdf": str(out.out / report["pdf"].name)},
                "pass": not failed,
                "failed": failed,
                "cases": [{**v, "folder": str(out.out / name / loop)} for name, loop, v in verdict_rows],
                "open_loop": [
                    dict(
                        zip(
                            (
                                "scenario",
                                "aircraft",
                                "J",
                                "position_10s_m",
                                "angle_10s_rad",
                                "position_m",
                                "angle_rad",
                                "time_s",
                            ),
                            r,
                        )
                    )
                    for r in rows
                ],
                "closed_loop": [
                    dict(
                        zip(("scenario", "inhouse_m", "jsbsim_m", "inhouse_vs_jsbsim_m", "beyond_limits_s", "pass"), r)
                    )
                    for r in closed_rows
                ],
                "execution": {k: record["execution"][k] for k in ("jobs", "planning_s", "cpu_s")},
            },
        )
    if failed:
        why = sorted({f for _, _, v in verdict_rows for f in v["failures"]})
        print(f"gflat paper: {', '.join(why)} not recorded by the scenario, for {', '.join(failed)}: FAIL")
        return 1
    return 0
