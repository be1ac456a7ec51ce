"""``gflat report DIR [--self-contained] [--pdf/--no-pdf] [--json]``: render a run's reports again from its saved results.

Reads the ``report.json`` of every case of the run in DIR (written by ``gflat
paper`` and ``gflat compare``) and writes ``DIR/index.html``, a ``case.html``
per case folder, with ``--self-contained`` a single ``DIR/report.html`` with
the images embedded (one file to mail), and ``DIR/report.pdf``.  Nothing is
planned or flown again: the pages are the run's, byte for byte apart from the
render date.

DIR is a gflat run's folder (or a folder inside one: the enclosing run is
rendered); a folder that is no gflat run's is refused.  A run is never changed
in place: its files (only those its manifest lists) are copied into a staging
folder beside it (each checked against its sha256), the pages rendered there,
the manifest rewritten (files and sha256), and the copy swapped in place of the run in one rename
(:class:`harness.rundir.RunDir`).  A rendering killed or failed at any moment
leaves the run as it was.
"""

from __future__ import annotations

import argparse
import os
import shutil
import time
from pathlib import Path

from gna.errors import InputError, expand_home, writing
from reports.html import render_date, render_run

from ..artefacts import manifest_problem
from ..recorded import confined, file_problem
from ..rundir import MANIFEST, RunDir, read_manifest
from ._help import add_command
from ._json import add_json, emit

#: The commands whose runs hold a report (``report.json`` per case) that ``gflat report`` renders.
RENDERED = ("paper", "compare")


def register(sub) -> None:
    """Add the ``gflat report`` parser to the sub-commands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``gflat`` parser's sub-commands (:func:`harness.cli.build_parser`).
    """
    p = add_command(
        sub,
        "report",
        help="render a run's HTML and PDF reports again from its saved results",
        description=__doc__.split("\n\n")[1],
        examples=[
            "gflat report reports/out/paper                    # index.html, case pages and report.pdf again",
            "gflat report reports/out/paper --self-contained   # plus report.html, one file to mail",
            "gflat report run --no-pdf --json",
        ],
    )
    p.add_argument("dir", metavar="DIR", help="output folder of a run (gflat paper --out DIR, gflat compare --out DIR)")
    p.add_argument(
        "--self-contained",
        action="store_true",
        help="also write DIR/report.html: every case in one file, images embedded",
    )
    p.add_argument(
        "--pdf", action=argparse.BooleanOptionalAction, default=True, help="write DIR/report.pdf (default yes)"
    )
    add_json(p, "report")
    p.set_defaults(func=run)


def run_folder(folder: str | Path) -> tuple[Path, dict]:
    """The gflat run ``folder`` is (or lies in), and its manifest.

    Parameters
    ----------
    folder : str or Path
        A run's folder, or a folder inside one.

    Returns
    -------
    (Path, dict)

    Raises
    ------
    InputError
        ``folder`` is not a folder, or neither it nor a parent holds a gflat run's ``manifest.json``: one line
        naming the nearest ``manifest.json`` and what is wrong with it (not JSON, not an object, another
        tool's, wrong types), or saying there is none.
    """
    path = expand_home(folder)
    if not path.is_dir():
        what = "does not exist" if not os.path.lexists(path) else "is a file, not a folder"
        raise InputError(f"{folder} {what}: give the folder of a gflat paper or gflat compare run")
    path = path.resolve()
    chain = (path, *path.parents)
    for d in chain:
        data = read_manifest(d)
        if data is not None:
            problem = manifest_problem(d)
            if problem is not None:
                raise InputError(f"{d} is not the folder of a gflat run that can be rendered: {problem}")
            return d, data
    nearest = next((d for d in chain if os.path.lexists(d / MANIFEST)), None)
    if nearest is not None:
        raise InputError(f"{path} is not the folder of a gflat run: {manifest_problem(nearest)}")
    from ..campaign.store import DB_NAME

    if (path / DB_NAME).is_file():
        raise InputError(
            f"{path} is a campaign folder (it holds {DB_NAME}), not a run's: gflat campaign report {folder} "
            f"renders its report"
        )
    raise InputError(
        f"{path} is not the folder of a gflat run: no {MANIFEST} there or in any folder above it; give the "
        f"folder of a gflat paper or gflat compare run"
    )


def _listed(manifest: dict) -> list[tuple[str, int, str]]:
    """The files a run's manifest lists, as (path, bytes, sha256) (their types checked by :func:`run_folder`)."""
    return [(f["path"], f["bytes"], f["sha256"]) for f in manifest["files"]]


def render_again(
    folder: str | Path, *, self_contained: bool = False, pdf: bool = True, date: str | None = None, progress=None
) -> dict[str, Path]:
    """Render the pages of the run ``folder`` is (or lies in) again, in a copy swapped in place of the run.

    Parameters
    ----------
    folder : str or Path
        A run's folder, or a folder inside one (:func:`run_folder`).
    self_contained, pdf : bool
        As :func:`reports.html.render_run`.
    date : str, optional
        Render date printed on every page (default now, UTC).
    progress : harness.progress.Progress, optional
        The copy, the pages and the PDF are stages.

    Returns
    -------
    dict
        :func:`reports.html.render_run`'s paths, in the run's folder.

    Raises
    ------
    InputError
        No gflat run there; the run's folder holds a file its manifest does not list (never removed), or a
        listed file is missing or differs from its sha256 (the run was changed since it was written); a page
        cannot be rendered.  The run is left as it was.
    """
    top, old = run_folder(folder)
    if old.get("command") not in RENDERED:
        other = "; gflat campaign report DIR renders a campaign's" if old.get("command") == "campaign report" else ""
        raise InputError(
            f"{top} is the folder of a gflat {old.get('command')} run, which holds no report: gflat report renders "
            f"the runs of gflat paper and gflat compare{other}"
        )
    with RunDir(top, command=str(old.get("command")), replace=True, advice=None) as out:  # a foreign file: refused
        copying = progress.begin(f"copying the run's {len(_listed(old))} files") if progress is not None else None
        for name, size, digest in _listed(old):
            src = confined(top, name, f"{top / MANIFEST} lists the file")
            problem = file_problem(src, size, digest)
            if problem is None:
                dst = out.path(*Path(name).parts)
                with writing(top / name):  # named as the run's file (the copy is staged beside it)
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copyfile(src, dst)
                problem = file_problem(dst, size, digest)  # the copy checked, not the file read before
            if problem is not None:
                raise InputError(f"{src}, listed in its manifest, is {problem}: the run was changed since it ran")
        if copying is not None:
            progress.end(copying)
        try:
            pages = render_run(
                out.root,
                self_contained=self_contained,
                pdf=pdf,
                date=date,
                manifest=old,
                progress=progress,
            )
        except InputError as exc:  # named as the run's files, not as their staged copies
            raise InputError(str(exc).replace(str(out.root), str(top))) from None
        out.commit({**old, "rendered_utc": render_date() if date is None else date})
    moved = lambda p: top / p.relative_to(out.root)  # noqa: E731
    return {k: [moved(p) for p in v] if isinstance(v, list) else moved(v) for k, v in pages.items()}


def run(args) -> int:
    """Run ``gflat report`` with the parsed command line ``args``.

    Parameters
    ----------
    args : argparse.Namespace
        The options of the command (its parser: :func:`register`).

    Returns
    -------
    int
        The exit status (:data:`harness.cli.EXIT_CODES`).
    """
    t0 = time.perf_counter()
    pages = render_again(
        args.dir, self_contained=args.self_contained, pdf=args.pdf, progress=getattr(args, "progress", None)
    )
    if args.json:
        emit(
            args,
            {
                "dir": str(pages["index"].parent),
                "index": str(pages["index"]),
                "pages": [str(p) for p in pages["pages"]],
                "single": str(pages["single"]) if "single" in pages else None,
                "pdf": str(pages["pdf"]) if "pdf" in pages else None,
                "elapsed_s": time.perf_counter() - t0,
            },
        )
        return 0
    print(f"report: {pages['index']} ({len(pages['pages'])} case page(s))")
    for key in ("single", "pdf"):
        if key in pages:
            print(f"{key}: {pages[key]}")
    print(f"rendered in {time.perf_counter() - t0:.2f} s")
    return 0
