"""``gflat report DIR [--self-contained] [--pdf/--no-pdf]``: render a run's reports again from its saved results.

Reads the ``report.json`` of every case under DIR (written by ``gflat paper``
and ``gflat compare``) and writes ``DIR/index.html``, a ``case.html`` per case
folder, with ``--self-contained`` a single ``DIR/report.html`` with the images
embedded (one file to mail), and ``DIR/report.pdf``.  Nothing is planned or
flown again: the pages are the run's, byte for byte apart from the render date.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from gna.errors import InputError
from reports.html import incomplete_notice, render_run

from ..marker import record_in_marker
from ..parallel import default_jobs


def register(sub) -> None:
    p = sub.add_parser("report", help="render a run's HTML and PDF reports again from its saved results",
                       description=__doc__.split("\n\n")[1])
    p.add_argument("dir", metavar="DIR", help="output folder of a run (gflat paper --out DIR, gflat compare --out DIR)")
    p.add_argument("--self-contained", action="store_true",
                   help="also write DIR/report.html: every case in one file, images embedded")
    p.add_argument("--pdf", action=argparse.BooleanOptionalAction, default=True,
                   help="write DIR/report.pdf (default yes)")
    p.set_defaults(func=run)


def run(args) -> int:
    root = Path(args.dir)
    if not root.is_dir():
        raise InputError(f"{root} is not a folder")
    t0 = time.perf_counter()
    out = render_run(root, self_contained=args.self_contained, pdf=args.pdf, jobs=default_jobs())
    # the single page and the PDF join the run's files: a later run into the folder replaces or removes them
    record_in_marker(root, [out[k] for k in ("single", "pdf") if k in out])
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
