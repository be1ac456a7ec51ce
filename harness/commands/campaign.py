"""``gflat campaign run|status|report``: validation campaigns (Monte Carlo over dispersed aircraft).

``gflat campaign run NAME_OR_FILE --out DIR [--samples N] [--workers N] [--case-budget S] [--dask ADDRESS|local:N]
[--dask-timeout S] [--retry-failed] [--only CASE_ID] [-q/--quiet]`` runs or resumes a campaign (done cases are
skipped, failed ones rerun only with ``--retry-failed``); the campaign file, every case, ``--dask`` and the
scheduler at its address are checked before the folder is created or touched; ``gflat campaign status DIR [--json]`` counts the cases;
``gflat campaign report DIR`` writes the campaign report (summary.json, figures, index.html, a page per
worst or failed case, report.pdf) into ``DIR/report``, written whole and put in place of the earlier report in
one rename (:class:`harness.rundir.RunDir`).  The store's own transactions are the campaign's record (resumable
in place); one lock on the store (:func:`harness.campaign.store.locked`) keeps a second run or report out while
one works.
"""

from __future__ import annotations

import functools
import json
import shlex
import sqlite3
import sys
from dataclasses import replace
from pathlib import Path

from gna.errors import InputError, describe, expand_home

from ..campaign.checks import MAX_CASES, MAX_DASK_TIMEOUT_S
from ._args import add_tracking, bounded_float, cost_bound, positive_int, worker_count
from ._help import add_command
from ._json import add_json, emit
from ._output import out_path


def register(sub) -> None:
    """Add the ``gflat campaign`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "campaign",
        help="validation campaigns: many cases over dispersed aircraft",
        description="Run, inspect and report validation campaigns (a product of validation cases "
        "and aircraft dispersions, stored in an SQLite-indexed folder).",
        examples=[
            "gflat campaign run paper-dispersions --out camp --samples 4",
            "gflat campaign status camp --json",
            "gflat campaign report camp",
        ],
    )
    csub = p.add_subparsers(dest="campaign_command", metavar="ACTION")
    csub.required = True
    r = add_command(
        csub,
        "run",
        help="run or resume a campaign",
        description="Run a campaign (a bundled one or a TOML file) into DIR, or resume it there: the cases done "
        "are skipped, the failed ones run again only with --retry-failed. The campaign file, every case and "
        "--dask are checked before DIR is created or touched. Exit 1 while cases are pending or failed (an "
        "error or a timeout: no result).",
        examples=[
            "gflat campaign run paper-dispersions --out camp --samples 4 --workers 2",
            "gflat campaign run my-campaign.toml --out camp --dask local:4 --json",
            "gflat campaign run paper-dispersions --out camp --only CASE_ID   # one case again, compared",
        ],
    )
    r.add_argument("campaign", metavar="NAME_OR_FILE", help="bundled campaign (paper-dispersions) or a TOML file")
    r.add_argument(
        "--out",
        type=out_path,
        required=True,
        metavar="DIR",
        help="campaign folder: new or empty, or a campaign folder of the same campaign (then resumed)",
    )
    r.add_argument("--samples", type=positive_int, default=None, help="samples per case and dispersion set")
    r.add_argument(
        "--max-cases",
        type=cost_bound,
        default=MAX_CASES,
        metavar="N",
        help=f"bound on the cases run, samples x cases x dispersion sets, checked before any work "
        f"(default {MAX_CASES:.0e}; 'inf' for none)",
    )
    r.add_argument(
        "--workers",
        type=worker_count,
        default=None,
        help="local worker processes (default: the number of CPUs; 1: in this process; at most 4 per CPU)",
    )
    r.add_argument(
        "--case-budget",
        type=cost_bound,
        default=None,
        metavar="S",
        help="wall-time budget of one case [s]: a case beyond it ends as a timeout and the campaign goes on "
        "(default the campaign file's case_budget_s, else 600; 'inf' for none)",
    )
    r.add_argument(
        "--dask",
        default=None,
        metavar="ADDRESS|local:N",
        help="run on Dask distributed: a scheduler address [tcp://]HOST:PORT (also tls, ws, wss, "
        "ucx), or local:N for a local cluster of N workers",
    )
    r.add_argument(
        "--dask-timeout",
        type=bounded_float(MAX_DASK_TIMEOUT_S),
        default=None,
        metavar="S",
        help=f"seconds to wait for the scheduler at a --dask address (default 20, at most {MAX_DASK_TIMEOUT_S:g})",
    )
    add_tracking(r)
    r.add_argument("--retry-failed", action="store_true", help="run the failed cases again")
    r.add_argument(
        "--only",
        action="append",
        default=None,
        metavar="CASE_ID",
        help="run only this case (a done case is computed again alone and compared with the store)",
    )
    add_json(r, "campaign-run")
    r.set_defaults(func=run)
    s = add_command(
        csub,
        "status",
        help="count the cases of a campaign folder",
        description="Count the cases of a campaign folder: done (and how many pass), failed, pending, and "
        "those whose stored files fail their check (untrusted). Writes nothing.",
        examples=["gflat campaign status camp", "gflat campaign status camp --json"],
    )
    s.add_argument("dir", metavar="DIR", help="the campaign folder (gflat campaign run --out DIR)")
    add_json(s, "campaign-status", help="one JSON object: cases, done, failed, pending, passed, untrusted")
    s.set_defaults(func=status)
    t = add_command(
        csub,
        "report",
        help="write the campaign report (summary, figures, HTML) into DIR/report",
        description="Write the campaign report into DIR/report: summary.json, figures, index.html, a page per "
        "worst or failed case and report.pdf, written whole and put in place of an earlier report in one "
        "rename. A case whose stored files fail their check is refused (nothing written).",
        examples=["gflat campaign report camp", "gflat campaign report camp --no-pdf --json"],
    )
    t.add_argument("dir", metavar="DIR", help="the campaign folder (gflat campaign run --out DIR)")
    t.add_argument("--no-pdf", action="store_true", help="skip report.pdf")
    add_json(t, "campaign-report")
    t.set_defaults(func=report)


def _store_errors(command):
    """``command(args)`` with an SQLite error of the store (read-only, corrupt, locked) as one line naming it."""

    @functools.wraps(command)
    def checked(args) -> int:
        try:
            return command(args)
        except sqlite3.Error as exc:
            folder = Path(getattr(args, "dir", None) or getattr(args, "out", None) or ".")
            raise InputError(f"campaign index {folder / 'campaign.sqlite'}: {describe(exc)}") from None

    return checked


def _store(folder: str, readonly: bool = True):
    """The store of a campaign folder given on the command line; read-only unless ``readonly`` is false."""
    from harness.campaign.store import DB_NAME, CampaignStore

    index = Path(folder) / DB_NAME
    if not index.is_file() and not index.is_symlink():
        held = f"{DB_NAME} is a folder" if index.is_dir() else f"no {DB_NAME}"
        raise InputError(f"{folder} is not a campaign folder ({held})")
    return CampaignStore(folder, readonly=readonly)


@_store_errors
def run(args) -> int:
    """Run ``gflat campaign`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).
    """
    from harness.campaign import rerun_case, run_campaign
    from harness.campaign.checks import check_samples
    from harness.campaign.runner import parse_dask
    from harness.campaign.spec import load_campaign

    parse_dask(args.dask)  # a bad --dask refused first, whatever runs
    camp = load_campaign(args.campaign).with_tracking(args.tracking)
    if args.case_budget is not None:
        camp = replace(camp, case_budget_s=args.case_budget)
    check_samples(camp, args.samples, args.max_cases)  # the work bounded before any case is expanded
    reruns: list[dict] = []
    if args.only:
        from harness.campaign.store import DB_NAME

        if (Path(args.out) / DB_NAME).is_file():
            st = _store(args.out)
            try:  # a case done whose files fail their check is computed again in the store (below), not aside
                rows = {r["case_id"]: r for r in st.rows()}
                done = [c for c in args.only if c in rows and rows[c]["status"] == "done" and st.check(rows[c]) is None]
            finally:
                st.close()
            for cid in done:
                out = rerun_case(args.out, cid, camp)
                again = {
                    "case_id": cid,
                    "status": out["status"],
                    "metrics": out["metrics"],
                    "same_as_stored": out["same_as_stored"],
                }
                reruns.append(again)
                if not args.json:
                    print(json.dumps(again, indent=2))
            args.only = [c for c in args.only if c not in done]
            if not args.only:
                if args.json:
                    st = _store(args.out)
                    try:
                        counts = st.counts()
                    finally:
                        st.close()
                    emit(
                        args,
                        {
                            **counts,
                            "computed": 0,
                            "skipped": 0,
                            "elapsed_s": 0.0,
                            "folder": str(args.out),
                            "reruns": reruns,
                        },
                    )
                return 0
    quiet = bool(getattr(args, "quiet", 0))  # gflat's -q/--quiet: no note (and no progress)
    timeout = {} if args.dask_timeout is None else {"dask_timeout": args.dask_timeout}
    res = run_campaign(
        camp,
        args.out,
        samples=args.samples,
        workers=args.workers,
        dask=args.dask,
        retry_failed=args.retry_failed,
        quiet=quiet,
        only=args.only,
        progress=getattr(args, "progress", None),
        **timeout,
    )
    note = (
        f"{res['computed']} computed in {res['elapsed_s']:.1f} s, {res['skipped']} skipped; "
        f"{res['done']} done, {res['failed']} failed, {res['pending']} pending of {res['cases']} -> {res['folder']}"
    )
    print(note, file=sys.stderr if quiet else sys.stdout)  # -q: the counts on stderr, apart from --json
    if res["failed"]:  # a case without a result is no success, whatever the others show
        print(
            f"gflat campaign run: {res['failed']} of {res['cases']} case(s) failed (an error or a timeout: no "
            f"result): gflat campaign status {shlex.quote(str(res['folder']))}; --retry-failed runs them again",
            file=sys.stderr,
        )
    if args.json:
        emit(args, {**res, "reruns": reruns})
    return 0 if res["pending"] == 0 and res["failed"] == 0 else 1


@_store_errors
def status(args) -> int:
    """Run ``gflat campaign status`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).
    """
    from harness.campaign.report import first_line
    from harness.campaign.runner import untrusted

    st = _store(args.dir)
    try:
        counts = st.counts()
        rows = st.rows()
        damaged = untrusted(st, quiet=True)
    finally:
        st.close()
    passed = sum(1 for r in rows if r["pass"])
    if args.json:
        emit(args, {**counts, "passed": passed, "untrusted": damaged})
    else:
        print(
            f"{args.dir}: {counts['cases']} cases: {counts['done']} done ({passed} pass), "
            f"{counts['failed']} failed, {counts['pending']} pending"
        )
        for r in rows:
            if r["status"] == "failed":
                print(f"  failed {r['case_id']}: {first_line(r['error'])}")
        for cid, problem in damaged.items():  # computed again by the next campaign run, refused by the report
            print(f"  untrusted {cid}: {problem}")
    return 0


@_store_errors
def report(args) -> int:
    """Run ``gflat campaign report`` with the parsed command line ``args``.

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
        A recorded case whose files are missing or damaged (no report written), or a folder that is no
        campaign's (one line; exit status 2).
    """
    from harness.campaign.report import write_report
    from harness.campaign.runner import untrusted
    from harness.campaign.store import CampaignStore, locked
    from harness.rundir import RunDir
    from reports.campaign import render_campaign

    _store(args.dir).close()
    folder = expand_home(args.dir).resolve()
    with locked(folder):  # refused while a campaign run works there, and held meanwhile
        st = CampaignStore(folder, readonly=True)
        try:
            bad = untrusted(st, quiet=True)  # nothing unchecked is rendered
        finally:
            st.close()
        if bad:
            cid, problem = next(iter(bad.items()))
            more = f" ({len(bad) - 1} more case(s) too)" if len(bad) > 1 else ""
            raise InputError(
                f"{folder}: case {cid}: {problem}{more}: no report written; run gflat campaign run CAMPAIGN --out "
                f"{args.dir} to compute it again"
            )
        # a report/ link is refused (never followed out of DIR); an earlier report/ is replaced once this is whole
        with RunDir(folder / "report", command="campaign report", replace=True) as out:
            summary, rows, paths = write_report(folder, out.root)
            pages = render_campaign(folder, summary, rows, target=out.root, pdf=not args.no_pdf)
            out.commit()
    paths += [pages["index"], *pages["pages"]] + ([pages["pdf"]] if "pdf" in pages else [])
    if args.json:
        moved = lambda p: out.out / Path(p).relative_to(out.root)  # noqa: E731
        emit(
            args,
            {
                "folder": str(folder),
                "report": str(out.out),
                "index": str(out.out / "index.html"),
                "pdf": str(out.out / "report.pdf") if "pdf" in pages else None,
                "files": [str(moved(p)) for p in paths],
                "cases": len(rows),
            },
        )
        return 0
    print(f"campaign report: {out.out / 'index.html'} ({len(paths)} files)")
    return 0
