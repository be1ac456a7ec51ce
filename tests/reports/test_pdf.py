"""The PDF report read back: contents, page numbers, one section (bookmark) per case with its PASS/FAIL, text
extractable, figures in it (a scenario's plan figures once)."""

from __future__ import annotations

import re

import pytest

from reports.model import load_case_models

pypdf = pytest.importorskip("pypdf")


def _top_level(reader):
    return [
        (item.title, reader.get_destination_page_number(item)) for item in reader.outline if not isinstance(item, list)
    ]


def _images_drawn(page) -> int:
    """Image XObjects painted by the page's content stream (weasyprint shares one resource dict)."""
    xobjects = page["/Resources"].get("/XObject")
    images = {
        k
        for k, v in (xobjects.get_object() if xobjects else {}).items()
        if v.get_object().get("/Subtype") == "/Image" and v.get_object()["/Width"] > 0
    }
    drawn = re.findall(r"(/\S+)\s+Do\b", page.get_contents().get_data().decode("latin-1"))
    return sum(name in images for name in drawn)


def test_pdf_has_one_section_per_case_with_its_verdict_and_figures(report_run):
    path = report_run.written["pdf"]
    reader = pypdf.PdfReader(path)
    cases = load_case_models(report_run.root)
    sections = _top_level(reader)
    assert sections[0] == ("gflat validation report", 0)
    assert [t for t, _ in sections[1:]] == [f"{m['title']}: {'PASS' if m['passed'] else 'FAIL'}" for _, m in cases]
    starts = [p for _, p in sections[1:]] + [len(reader.pages)]
    seen = set()
    for (title, first), end, (_, model) in zip(sections[1:], starts[1:], cases):
        pages = reader.pages[first:end]
        text = "\n".join(p.extract_text() for p in pages)
        assert title in text  # extractable text, verdict included
        assert "Differences between engines" in text and model["scenario"]["aircraft"]["name"] in text
        # the scenario's later case refers to the first for the plan's figure (the same plan)
        shared = model["scenario"]["name"] in seen
        seen.add(model["scenario"]["name"])
        figures = [f["file"] for f in model["figures"] if not (shared and f["file"] == "singularity.png")]
        for fig in figures:
            assert fig in text  # each figure's caption ...
        assert sum(_images_drawn(p) for p in pages) == len(figures)  # ... and its image
        assert ("the same plan" in text) == shared
        assert "deg/s" in text and "[rad]" not in text  # angles in degrees, rates in deg/s
    n = len(reader.pages)
    for k, page in enumerate(reader.pages, start=1):  # numbered k / n at the foot
        assert page.extract_text().rstrip().endswith(f"{k} / {n}")
    front = reader.pages[0].extract_text()
    assert "2 of 2 case(s) pass" in front and "Contents" in front
    for (_title, page), (_, model) in zip(sections[1:], cases):  # the contents give each case's page
        assert f"{model['title']}\nPASS\n{page + 1}" in front or re.search(
            rf"{re.escape(model['title'])}\s+PASS\s+{page + 1}\b", front
        ), front
    levels = [item for item in reader.outline if isinstance(item, list)]
    assert levels and any(getattr(sub, "title", "") == "Verdicts" for group in levels for sub in group)


def test_pdf_is_no_larger_than_it_needs_to_be(report_run):
    """The figures' PNG data embedded as they are (one image object per figure shown), no more."""
    path = report_run.written["pdf"]
    reader = pypdf.PdfReader(path)
    images = {id(v.get_object()) for p in reader.pages for v in (p["/Resources"].get("/XObject") or {}).values()}
    figures = sum(
        p.stat().st_size for p in report_run.root.rglob("*.png") if p.name != "singularity.png" or "open" in str(p)
    )
    assert len(images) >= 1
    assert path.stat().st_size < 1.3 * figures + 400_000


def test_weasyprint_imported_the_ordinary_way_when_a_library_needs_the_search(tmp_path, monkeypatch, capsys):
    """A library found only by ``ctypes.util.find_library``: weasyprint imported again with it, quietly."""
    import sys

    from reports.pdf import import_weasyprint

    fake = tmp_path / "weasyprint"
    fake.mkdir()
    (fake / "__init__.py").write_text(
        "import ctypes.util\n"
        "if ctypes.util.find_library('c') is None:\n"
        "    print('WeasyPrint could not import some external libraries')\n"
        "    raise OSError('cannot load library')\n"
        "FOUND = True\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in [m for m in sys.modules if m == "weasyprint" or m.startswith("weasyprint.")]:
        monkeypatch.delitem(sys.modules, name)
    try:
        module = import_weasyprint()
        assert module.FOUND and module.__file__.startswith(str(fake))
        assert "could not import" not in capsys.readouterr().out
    finally:
        sys.modules.pop("weasyprint", None)  # the fake (the real one, imported before, is put back)


def test_pdf_parts_printed_as_the_cases_are_written_make_the_same_pdf(report_run, tmp_path, monkeypatch):
    """gflat paper prints each scenario's pages in a worker (reports.html.pdf_part): the PDF put together from
    them is the one printed at the end, and nothing but the front matter is printed again."""
    import shutil

    import reports.pdf
    from reports.html import pdf_part, render_run

    from .conftest import DATE, SCENARIO

    root = tmp_path / "paper"
    shutil.copytree(report_run.root, root)
    folders = [f"{SCENARIO}/open", f"{SCENARIO}/closed"]
    part = pdf_part(root, folders)
    prints = []
    real = reports.pdf._print
    monkeypatch.setattr(reports.pdf, "_print", lambda html, base: prints.append(html) or real(html, base))
    written = render_run(root, date=DATE, printed=[(folders, *part)])
    assert len(prints) == 1 and "Contents" in prints[0]  # the front matter only
    ours, theirs = pypdf.PdfReader(written["pdf"]), pypdf.PdfReader(report_run.written["pdf"])
    assert _top_level(ours) == _top_level(theirs)
    assert [p.extract_text() for p in ours.pages] == [p.extract_text() for p in theirs.pages]
    prints.clear()
    render_run(root, date=DATE, printed=[(folders, part[0] + " ", part[1])])  # another document: printed again
    assert len(prints) == 2
