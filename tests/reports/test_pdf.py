"""The PDF report read back: one section (bookmark) per case with its PASS/FAIL, text extractable, figures in it."""

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
    for (title, first), end, (_, model) in zip(sections[1:], starts[1:], cases):
        pages = reader.pages[first:end]
        text = "\n".join(p.extract_text() for p in pages)
        assert title in text  # extractable text, verdict included
        assert "Differences between engines" in text and model["scenario"]["aircraft"]["name"] in text
        for fig in model["figures"]:
            assert fig["file"] in text  # each figure's caption ...
        assert sum(_images_drawn(p) for p in pages) == len(model["figures"])  # ... and its image
    summary = reader.pages[0].extract_text()
    assert "2 of 2 case(s) pass" in summary
