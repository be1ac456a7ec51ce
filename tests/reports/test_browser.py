"""The HTML report opened in a real headless browser (Debian's chromium driven by playwright).

Every page of the run (the index, each case page, the single-file report) is
served over HTTP and loaded; every image must decode (``naturalWidth > 0``),
every link must stay inside the report and resolve (the file is served, the
anchor exists), and the console must show no error.  Then a look at what the
reader sees: every figure names the unit of each of its axes (the labels the
figure recorded, in its alt text), no text overflows its box (each element's
``scrollWidth`` within its ``clientWidth``, each table, figure and image inside
its parent, no horizontal scrolling of the page), and the screenshots of the
index and of a case page hold a drawn page (not blank).  The screenshots are
saved in the test's folder and copied to ``reports/out/``.  Without a browser
the test is skipped locally and fails under CI (``CI`` set).
"""

from __future__ import annotations

import functools
import http.server
import json
import os
import re
import shutil
import threading
import urllib.parse
from pathlib import Path

import pytest

CHROMIUM = "/usr/bin/chromium"
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
SCREENSHOT_DIR = Path(__file__).resolve().parents[2] / "reports" / "out"

#: Elements whose content may scroll by design (the scenario file, the manifest).
SCROLLING = ("PRE",)

#: The browser's look at a page: elements whose text overflows their box, boxes outside their parent.
OVERFLOW_JS = """() => {
  const bad = [];
  const name = e => e.tagName.toLowerCase() + (e.id ? '#' + e.id : '') + (e.className ? '.' + e.className : '');
  for (const e of document.querySelectorAll('body *')) {
    const cs = getComputedStyle(e);
    if (cs.display === 'none' || cs.display === 'inline' || SCROLLING.includes(e.tagName)) continue;
    if (e.closest('pre')) continue;
    if (cs.overflowX === 'visible' && e.scrollWidth > e.clientWidth + 1 && e.clientWidth > 0)
      bad.push(`${name(e)}: text ${e.scrollWidth} px wide in a box of ${e.clientWidth} px: ${e.textContent.slice(0, 60)}`);
  }
  for (const e of document.querySelectorAll('table, figure, img, p, h1, h2, h3, h4, ul')) {
    const r = e.getBoundingClientRect(), p = e.parentElement.getBoundingClientRect();
    if (r.width > 0 && (r.right > p.right + 1 || r.left < p.left - 1))
      bad.push(`${name(e)} outside its parent ${name(e.parentElement)}: ${Math.round(r.left)}..${Math.round(r.right)} px in ${Math.round(p.left)}..${Math.round(p.right)} px`);
  }
  const d = document.documentElement;
  if (d.scrollWidth > window.innerWidth + 1) bad.push(`the page scrolls sideways: ${d.scrollWidth} px in ${window.innerWidth} px`);
  return bad;
}""".replace("SCROLLING", json.dumps(list(SCROLLING)))

#: An axis label with its unit, as the figures record them (``"alpha [deg]"``, ``"t [s]"``).
AXIS_LABEL = re.compile(r".+ \[[^\]]+\]")


def _drawn(path: Path) -> float:
    """Share of a screenshot's pixels that are not the page's white: a page with content, not a blank one."""
    from PIL import Image

    with Image.open(path) as im:
        grey = im.convert("L")
        hist = grey.histogram()
    return 1.0 - sum(hist[250:]) / max(sum(hist), 1)


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def _sync_playwright():
    reason = None
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        reason, sync_playwright = "playwright is not installed (pip install '.[test]')", None
    if reason is None and not Path(CHROMIUM).exists():
        reason = f"{CHROMIUM} is missing (apt-get install chromium; .ci/run installs it)"
    if reason:
        (pytest.fail if _in_ci() else pytest.skip)(reason)
    return sync_playwright


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture
def served(report_run):
    handler = functools.partial(_Quiet, directory=str(report_run.root))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


def test_report_pages_load_in_chromium_with_images_links_and_no_console_error(report_run, served, tmp_path):
    sync_playwright = _sync_playwright()
    pages = ["index.html", "report.html"] + [
        p.relative_to(report_run.root).as_posix() for p in report_run.written["pages"]
    ]
    problems, visited, html_of, shots = [], [], {}, {}
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
            page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
            page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url}"))
            page.on("response", lambda r: problems.append(f"HTTP {r.status}: {r.url}") if r.status >= 400 else None)
            links = set()
            while pages:
                rel = pages.pop(0)
                if rel in visited:
                    continue
                visited.append(rel)
                url = served + rel
                response = page.goto(url, wait_until="load")
                assert response is not None and response.ok, url
                html_of[rel] = page.content()
                images = page.eval_on_selector_all(
                    "img", "els => els.map(e => [e.getAttribute('alt'), e.complete, e.naturalWidth])"
                )
                if rel != "index.html":
                    assert images, f"{rel}: no image"
                for alt, complete, width in images:
                    if not (complete and width > 0):
                        problems.append(f"{rel}: image {alt!r} does not decode")
                for alt, axes in page.eval_on_selector_all(
                    "figure img", "els => els.map(e => [e.getAttribute('alt'), e.dataset.axes || ''])"
                ):
                    labels = json.loads(axes or "[]")
                    if not labels or not all(AXIS_LABEL.fullmatch(a) for a in labels):
                        problems.append(f"{rel}: figure {alt!r} without a unit on every axis: {labels}")
                    elif not all(a in alt for a in labels):
                        problems.append(f"{rel}: figure {alt!r}: its alt text does not name its axes")
                problems += [f"{rel}: {p}" for p in page.evaluate(OVERFLOW_JS)]
                if rel == "index.html" or (rel.endswith("/case.html") and "case" not in shots):
                    key = "index" if rel == "index.html" else "case"
                    shots[key] = tmp_path / f"report-{key}.png"
                    page.screenshot(path=str(shots[key]), full_page=(key == "index"))
                for href in page.eval_on_selector_all("a[href]", "els => els.map(e => e.href)"):
                    if not href.startswith(served):
                        problems.append(f"{rel}: link leaves the report: {href}")
                        continue
                    links.add(href)
                    target = urllib.parse.urldefrag(href).url[len(served) :]
                    if target.endswith(".html"):
                        pages.append(target)
            for href in sorted(links):  # every link resolves: file served, anchor present
                target, fragment = urllib.parse.urldefrag(href)
                rel = target[len(served) :]
                status = page.request.get(target).status
                if status != 200:
                    problems.append(f"link {href}: HTTP {status}")
                elif fragment:
                    doc = html_of.get(rel) or page.request.get(target).text()
                    if not re.search(rf'id="{re.escape(fragment)}"', doc):
                        problems.append(f"link {href}: no element with id {fragment!r}")
        finally:
            browser.close()
    assert not problems, "\n".join(problems)
    assert set(visited) >= {"index.html", "report.html"} and len(visited) == 2 + len(report_run.written["pages"])
    assert len(links) > 10
    assert set(shots) == {"index", "case"}
    SCREENSHOT_DIR.mkdir(parents=True, exist_ok=True)
    for shot in shots.values():  # a look at the screenshots: a drawn page, kept for the docs
        assert shot.stat().st_size > 10_000 and _drawn(shot) > 0.02, shot
        shutil.copyfile(shot, SCREENSHOT_DIR / shot.name)


def test_a_missing_browser_fails_under_ci_and_skips_elsewhere(monkeypatch, tmp_path):
    import sys

    module = sys.modules[__name__]
    monkeypatch.setattr(module, "CHROMIUM", str(tmp_path / "no-chromium"))
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="no-chromium is missing"):
        _sync_playwright()
    monkeypatch.delenv("CI")
    with pytest.raises(pytest.skip.Exception):
        _sync_playwright()
