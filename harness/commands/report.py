"""``gflat report DIR [--self-contained] [--pdf/--no-pdf]``: render a run's reports again from its saved results.

Reads the ``report.json`` of every case under DIR (written by ``gflat paper``
and ``gflat compare``) and writes ``DIR/index.html``, a ``case.html`` per case
folder, with ``--self-contained`` a single ``DIR/report.html`` with the images
embedded (one file to mail), and ``DIR/report.pdf``.  Nothing is planned or
flown again: the pages are the run's, byte for byte apart from the render date.

DIR is a run's output folder (or a case folder inside one); a folder that is no
run's but holds runs in its sub-folders is refused, naming them: each run's
pages are its own (render each).  A root or the home folder is refused, and
only the run's files are touched: case pages of an earlier rendering whose
case is gone are removed only when the run's marker lists them.

DIR is held as a run holds its output folder (the run's top folder too, when
DIR is a case folder inside a run): a run writing there meanwhile is refused,
and this refuses while one writes (one line, exit status 2, nothing changed).
The pages are rendered on behalf of the run that wrote DIR, whatever its
command: the pages, the single page and the PDF join that run's files in its marker
(:mod:`harness.marker`), so that the run's command, run again into DIR,
replaces or removes them as its own.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from gna.errors import InputError
from reports.html import incomplete_notice, render_run

from ..marker import amending, is_run, runs_inside
from ..outguard import _few
from ..parallel import default_jobs


def _one_run(path: Path, top: Path) -> None:
    """Refuse a folder that is no run's but holds runs in its sub-folders: their pages are each run's own."""
    if is_run(top):
        return
    runs = runs_inside(path)
    if runs:
        names = _few([str(r.relative_to(path)) for r in runs], 4)
        raise InputError(
            f"{path} is not a run's folder; it holds {len(runs)} separate run(s) ({names}): render "
            f"each with gflat report {runs[0]} (and so on)"
        )


def register(sub) -> None:
    p = sub.add_parser(
        "report",
        help="render a run's HTML and PDF reports again from its saved results",
        description=__doc__.split("\n\n")[1],
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
    p.set_defaults(func=run)


def run(args) -> int:
    root = Path(args.dir)
    t0 = time.perf_counter()
    with amending(root) as top:  # refused while a run writes there, and held meanwhile
        _one_run(root.expanduser().resolve(), top)
        # the pages, the single page and the PDF join the run's files (render_run): a later run into the folder
        # replaces or removes them
        out = render_run(root, self_contained=args.self_contained, pdf=args.pdf, jobs=default_jobs())
    notice = incomplete_notice(root)
    if notice:
        print(f"gflat report: warning: incomplete run: {notice}", file=sys.stderr)
    print(f"report: {out['index']} ({len(out['pages'])} case page(s))")
    if "removed_pdf" in out:
        print(f"removed the stale {out['removed_pdf']} of an earlier rendering (--no-pdf)")
    for key in ("single", "pdf"):
        if key in out:
            print(f"{key}: {out[key]}")
    print(f"rendered in {time.perf_counter() - t0:.2f} s")
    return 0
