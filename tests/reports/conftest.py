"""A small real run, made once per session: ``gflat paper --out DIR`` restricted to the GTM aileron roll
(8 s), flown open and closed loop on the in-house model and JSBSim; the results flown are kept for the
model tests, the pages the run rendered are kept for the re-rendering tests."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from harness.cli import main
from harness.commands import paper
from harness.commands.report import render_again

#: Folder of each loop's case under a scenario's folder (the layout of ``gflat paper --out DIR``).
CASE_FOLDERS = {"open": "open", "closed": "closed"}

SCENARIO = "gtm-aileron-roll"

#: Render date of the fixture's second rendering (the date is the only part allowed to change).
DATE = "2000-01-01T00:00:00+00:00"


@dataclass
class Run:
    root: Path
    results: dict  # loop -> CaseResult
    scenario: object
    paper_pages: dict  # path relative to root -> bytes of each HTML page gflat paper wrote
    paper_output: str  # what gflat paper printed
    render_s: float  # wall time of gflat report DIR --self-contained (HTML, single file and PDF)
    written: dict


@pytest.fixture(scope="session")
def report_run(tmp_path_factory) -> Run:
    root = tmp_path_factory.mktemp("run") / "paper"
    results = {}
    real = paper.finish_case  # each case's flights tabulated: its CaseResult

    def keep(flights, runs):
        r = real(flights, runs)
        results[r.case.loop] = r
        return r

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(paper, "PAPER_SCENARIOS", (SCENARIO,))
        mp.setattr(paper, "finish_case", keep)
        import contextlib
        import io

        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            assert main(["paper", "--out", str(root)]) == 0
    pages = {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*.html"))}
    t0 = time.perf_counter()
    written = render_again(root, self_contained=True, pdf=True, date=DATE)
    return Run(
        root=root,
        results=results,
        scenario=results["open"].scenario,
        paper_pages=pages,
        paper_output=buf.getvalue(),
        render_s=time.perf_counter() - t0,
        written=written,
    )
