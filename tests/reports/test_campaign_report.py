"""The campaign report (gflat campaign report) in a real headless browser, like the run reports.

A three-sample campaign is run and reported; the index and every case page it
links are loaded in chromium over HTTP: every image decodes, every link stays
inside the campaign folder and resolves (pages, anchors, trajectories), and the
console shows no error.  The PDF is read back.
"""

from __future__ import annotations

import functools
import http.server
import re
import threading
import urllib.parse
from pathlib import Path

import pytest

from harness.campaign import run_campaign
from harness.cli import main

from .test_browser import CHROMIUM, FLAGS, _Quiet, _sync_playwright

TINY = Path(__file__).resolve().parents[1] / "harness" / "campaign" / "tiny.toml"


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("campaign-report") / "c"
    run_campaign(TINY, out, workers=1, quiet=True)
    assert main(["campaign", "report", str(out)]) == 0
    return out


def test_campaign_report_files(campaign):
    rep = campaign / "report"
    for name in (
        "summary.json",
        "index.html",
        "report.pdf",
        "pass_rate.png",
        "max_position_error_m.png",
        "saturated_s.png",
        "engine_differences.png",
        "correlations.png",
    ):
        assert (rep / name).stat().st_size > 0, name
    pypdf = pytest.importorskip("pypdf")
    text = "".join(p.extract_text() for p in pypdf.PdfReader(rep / "report.pdf").pages)
    assert "Campaign tiny" in text and "Worst cases" in text


def test_campaign_report_gives_pass_rates_per_verdict_and_per_cause(campaign):
    import json
    import sqlite3

    summary = json.loads((campaign / "report" / "summary.json").read_text())
    (g,) = summary["groups"].values()
    assert set(g["verdicts"]) == {"flyable", "tracking", "engines_agree"}
    for v in g["verdicts"].values():
        assert v["n"] == 3 and v["pass"] + v["fail"] == 3 and v["pass_rate"] == v["pass"] / 3
    assert sum(g["causes"].values()) == 3 and set(g["causes"]) >= {"pass", "infeasible", "controller failure"}
    assert g["causes"]["pass"] == g["passed"]
    con = sqlite3.connect(campaign / "campaign.sqlite")
    try:  # the store: one column per verdict and the cause, as the metrics say
        rows = con.execute("SELECT flyable, tracking, engines_agree, cause, metrics, timings FROM cases").fetchall()
    finally:
        con.close()
    for fly, trk, agree, cause, metrics, timings in rows:
        m = json.loads(metrics)
        assert (fly, trk, agree) == tuple(
            int(m["verdicts"][k]["pass"]) for k in ("flyable", "tracking", "engines_agree")
        )
        assert cause == m["cause"] and json.loads(timings)["sample_plan_s"] > 0  # the path planned for the sample
    page = (campaign / "report" / "index.html").read_text(encoding="utf-8")
    assert '<table class="verdicts">' in page and '<table class="causes">' in page and "controller failure" in page


def test_campaign_report_in_chromium(campaign):
    sync_playwright = _sync_playwright()
    handler = functools.partial(_Quiet, directory=str(campaign))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    served = f"http://127.0.0.1:{server.server_address[1]}/"
    problems, visited, links, html_of = [], [], set(), {}
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
            try:
                page = browser.new_page(viewport={"width": 1280, "height": 900})
                page.on("console", lambda m: problems.append(f"console: {m.text}") if m.type == "error" else None)
                page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
                page.on("response", lambda r: problems.append(f"HTTP {r.status}: {r.url}") if r.status >= 400 else None)
                todo = ["report/index.html"]
                while todo:
                    rel = todo.pop(0)
                    if rel in visited:
                        continue
                    visited.append(rel)
                    assert page.goto(served + rel, wait_until="load").ok, rel
                    html_of[rel] = page.content()
                    for alt, ok, width in page.eval_on_selector_all(
                        "img", "els => els.map(e => [e.getAttribute('alt'), e.complete, e.naturalWidth])"
                    ):
                        if not (ok and width > 0):
                            problems.append(f"{rel}: image {alt!r} does not decode")
                    for href in page.eval_on_selector_all("a[href]", "els => els.map(e => e.href)"):
                        if not href.startswith(served):
                            problems.append(f"{rel}: link leaves the campaign folder: {href}")
                            continue
                        links.add(href)
                        target = urllib.parse.urldefrag(href).url[len(served) :]
                        if target.endswith(".html"):
                            todo.append(target)
                for href in sorted(links):
                    target, fragment = urllib.parse.urldefrag(href)
                    status = page.request.get(target).status
                    if status != 200:
                        problems.append(f"link {href}: HTTP {status}")
                    elif fragment and not re.search(
                        rf'id="{re.escape(fragment)}"', html_of.get(target[len(served) :], "")
                    ):
                        problems.append(f"link {href}: no element with id {fragment!r}")
            finally:
                browser.close()
    finally:
        server.shutdown()
        server.server_close()
    assert not problems, "\n".join(problems)
    assert len(visited) == 1 + 3  # the index and the three cases (all among the worst)
    assert any(h.endswith(".parquet") for h in links)
