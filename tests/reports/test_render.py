"""Rendering: deterministic apart from the render date; ``gflat report DIR`` reproduces a run's pages."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from gna.errors import InputError
from harness.cli import main
from harness.rundir import MANIFEST
from reports.html import cell, fmt, render_documents, render_run

from .conftest import CASE_FOLDERS, DATE, SCENARIO

RENDERED = re.compile(r'<p class="rendered">Rendered [^<]*</p>')


def _pages(root):
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*.html"))}


def _undated(data: bytes) -> bytes:
    text = data.decode("utf-8")
    assert len(RENDERED.findall(text)) == 1  # the date appears once, in the footer
    return RENDERED.sub("", text).encode("utf-8")


def test_render_is_the_same_apart_from_the_date(report_run):
    a = render_documents(report_run.root, date=DATE, embed=True)
    b = render_documents(report_run.root, date="2099-12-31T23:59:59+00:00", embed=True)
    assert a.keys() == b.keys()
    for path in a:
        assert a[path] != b[path] and _undated(a[path].encode()) == _undated(b[path].encode())
        assert a[path].encode() == (report_run.root / path).read_bytes()  # what the run wrote, date included


def test_gflat_paper_writes_the_report_and_says_where(report_run):
    root = report_run.root
    assert f"report: {root.resolve() / 'index.html'} (PDF: {root.resolve() / 'report.pdf'})" in report_run.paper_output
    for f in (
        "index.html",
        "report.pdf",
        "manifest.json",
        f"{SCENARIO}/open/case.html",
        f"{SCENARIO}/closed/case.html",
    ):
        assert (root / f).stat().st_size > 0, f
    for folder in CASE_FOLDERS.values():
        for engine in ("inhouse", "jsbsim"):
            assert (root / SCENARIO / folder / f"trajectory-{engine}.parquet").is_file()
    assert set(report_run.paper_pages) == {
        Path("index.html"),
        Path(SCENARIO, "open", "case.html"),
        Path(SCENARIO, "closed", "case.html"),
    }


def test_gflat_report_reproduces_the_html_of_a_run(report_run, tmp_path, capsys):
    copy = tmp_path / "run"
    shutil.copytree(report_run.root, copy)
    before = dict(report_run.paper_pages)  # as gflat paper rendered them
    before[Path("report.html")] = (report_run.root / "report.html").read_bytes()
    pdf = (copy / "report.pdf").read_bytes()
    assert main(["report", str(copy), "--self-contained", "--no-pdf"]) == 0
    out = capsys.readouterr().out
    assert f"report: {copy / 'index.html'} (2 case page(s))" in out
    after = _pages(copy)
    assert after.keys() == before.keys()
    for rel in before:
        assert _undated(after[rel]) == _undated(before[rel]), rel
    assert (copy / "report.pdf").read_bytes() == pdf  # --no-pdf: the run's PDF (of the same results) stays
    assert "report.pdf" in [f["path"] for f in json.loads((copy / MANIFEST).read_text())["files"]]
    assert main(["report", str(copy)]) == 0 and (copy / "report.pdf").stat().st_size > 0


def test_report_of_a_folder_without_results_is_one_clear_error(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "is not the folder of a gflat run" in err and err.count("\n") == 1
    with pytest.raises(InputError, match="no report.json under"):
        render_run(tmp_path)


def test_the_self_contained_file_embeds_every_image(report_run):
    text = (report_run.root / "report.html").read_text(encoding="utf-8")
    srcs = re.findall(r'<img src="([^"]*)"', text)
    n_figures = sum(len(list((report_run.root / SCENARIO / f).glob("*.png"))) for f in CASE_FOLDERS.values())
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    assert len(srcs) == n_figures  # every figure of every case
    hrefs = re.findall(r'href="([^"]*)"', text)
    assert hrefs and all(h.startswith(("#", "data:")) for h in hrefs)  # one file to mail: no link leaves it


def test_a_case_folder_alone_renders_the_same_twice(report_run, tmp_path):
    # gflat compare --out DIR: the case folder is the run folder; the pages rendered there are not data files
    case = tmp_path / "case"
    shutil.copytree(report_run.root / SCENARIO / CASE_FOLDERS["open"], case)
    for p in case.glob("*.html"):
        p.unlink()
    first = render_run(case, self_contained=True, pdf=False, date=DATE)
    assert first["index"] == case / "index.html" and first["pages"] == [case / "case.html"]
    again = render_documents(case, date="2099-12-31T23:59:59+00:00", embed=True)
    for path, text in again.items():
        assert _undated(text.encode()) == _undated(path.read_bytes()), path.name
    assert (
        'href="index.html"' in (case / "case.html").read_text()
        and "report.html" not in (case / "case.html").read_text()
    )


def test_a_corrupt_or_misshapen_model_is_one_clear_error(report_run, tmp_path, capsys):
    copy = tmp_path / "run"
    shutil.copytree(report_run.root, copy)
    model = copy / SCENARIO / CASE_FOLDERS["open"] / "report.json"
    for text, cause in (("{broken", "invalid JSON"), ("{}", "missing or wrong type"), ("[1]", "not an object")):
        model.write_text(text)
        with pytest.raises(InputError, match=cause) as exc:
            render_run(copy, pdf=False)
        assert str(model) in str(exc.value) and "\n" not in str(exc.value)
        assert main(["report", str(copy), "--no-pdf"]) == 2  # the run changed since it ran: refused, untouched
        err = capsys.readouterr().err
        assert f"{model}, listed in its manifest, is " in err and "the run was changed since it ran" in err
        assert len(err.strip().splitlines()) == 1
        assert model.read_text() == text


def test_a_model_whose_scenario_has_no_name_is_one_clear_error(report_run, tmp_path):
    # a new user's fuzz of the nested keys: "scenario": {"a": 1} ended in a KeyError traceback
    copy = tmp_path / "run"
    shutil.copytree(report_run.root, copy)
    model = copy / SCENARIO / CASE_FOLDERS["open"] / "report.json"
    data = json.loads(model.read_text())
    for scenario in ({"a": 1}, {"name": ["x"]}):
        data["scenario"] = scenario
        model.write_text(json.dumps(data))
        with pytest.raises(InputError, match=r"missing or wrong type: scenario\.name") as exc:
            render_run(copy, pdf=False)
        assert str(model) in str(exc.value) and "\n" not in str(exc.value)


def test_settings_are_on_off_and_an_undefined_delta_is_a_dash(report_run):
    assert (fmt(True), fmt(False), cell(True, "passed"), cell(False, "passed")) == ("on", "off", "pass", "FAIL")
    assert cell("nan", "delta_pct") == cell(None, "delta_pct") == "\u2013" and cell(0.5, "delta_pct") == "0.5"
    page = (report_run.root / SCENARIO / CASE_FOLDERS["open"] / "case.html").read_text(encoding="utf-8")
    settings = page.split("Comparison settings")[1].split("Provenance")[0]
    assert "FAIL" not in settings and "pass" not in settings
    assert "Undefined (&ndash;) where the scale is at most the floor of its kind" in page
    assert "excursion max &minus; min over the window for x, y, z and &chi;" in page


def test_the_index_has_a_column_per_verdict_and_the_case_page_the_violations(report_run, tmp_path):
    index = (report_run.root / "index.html").read_text(encoding="utf-8")
    head = index.split('<table class="summary">')[1].split("</tr>")[0]
    assert [h in head for h in ("flyable", "tracking", "engines agree", "result")] == [True] * 4
    rows = index.split('<table class="summary">')[1].split("</table>")[0]
    assert rows.count('class="text verdict-flyable"') == 2  # open and closed loop
    assert "within limits" in rows and "after 5 s" in rows  # each case's worst figure: the roll is flyable
    # a case whose plan leaves a limit, recorded by the scenario, and one not recorded
    case = tmp_path / "case"
    shutil.copytree(report_run.root / SCENARIO / CASE_FOLDERS["closed"], case)
    for p in case.glob("*.html"):
        p.unlink()
    model = json.loads((case / "report.json").read_text())
    fly = model["verdict"]["verdicts"]["flyable"]
    record = {"name": "dl", "limit": -0.3490658503988659, "worst": -0.4847, "time": 14.47, "fraction": 1.0}
    record.update(first=0.0, last=120.0, unit="rad", side="lower", known=True, reason="the paper's slip")
    fly.update({"pass": False, "violations": [record]})
    (case / "report.json").write_text(json.dumps(model))
    render_run(case, pdf=False, date=DATE)
    page = (case / "case.html").read_text(encoding="utf-8")
    section = page.split(">Verdicts<")[1].split(">Scenario<")[0]
    assert "FAIL (recorded)" in section and "-27.77&deg;" in section and "-20.00&deg;" in section
    assert "yes: the paper&#39;s slip" in section and "<td>100</td>" in section and "span [%]" in section
    assert "FAIL (recorded)" in (case / "index.html").read_text(encoding="utf-8")
    model["verdict"]["failures"] = ["flyable: dl"]
    record.update(known=False, reason=None)
    (case / "report.json").write_text(json.dumps(model))
    render_run(case, pdf=False, date=DATE)
    index = (case / "index.html").read_text(encoding="utf-8")
    assert '<span class="badge fail">FAIL</span><br><span class="worst">dl -27.77\u00b0 at t = 14.47 s' in index
