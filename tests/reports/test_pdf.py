"""The PDF report (printed by Typst) read back: contents with each case's page, page numbers, one section
(bookmark) per case with its PASS/FAIL, text extractable, figures in it (a scenario's plan figures once),
internal links that resolve; a hostile report.json prints as text and reads nothing outside the run."""

from __future__ import annotations

import json
import re
import shutil

import pytest

from gna.errors import InputError
from reports.html import render_run
from reports.model import load_case_models

pypdf = pytest.importorskip("pypdf")

SECRET = "the contents of a private key, never to leave this machine"


def _top_level(reader):
    return [
        (item.title, reader.get_destination_page_number(item)) for item in reader.outline if not isinstance(item, list)
    ]


def _images_drawn(page) -> int:
    """Image XObjects painted by the page's content stream."""
    xobjects = page["/Resources"].get("/XObject")
    images = {
        k
        for k, v in (xobjects.get_object() if xobjects else {}).items()
        if v.get_object().get("/Subtype") == "/Image" and v.get_object()["/Width"] > 0
    }
    drawn = re.findall(r"(/\S+)\s+Do\b", page.get_contents().get_data().decode("latin-1"))
    return sum(name in images for name in drawn)


def _text(reader) -> str:
    return "\n".join(p.extract_text() for p in reader.pages)


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
        assert first < end  # each case on pages of its own
        pages = reader.pages[first:end]
        text = "\n".join(p.extract_text() for p in pages)
        assert title in text  # extractable text, verdict included
        assert "Differences between engines" in text and model["scenario"]["aircraft"]["name"] in text
        # the scenario's later case refers to the first for the plan's figure (the same plan)
        shared = model["scenario"]["name"] in seen
        seen.add(model["scenario"]["name"])
        figures = [f["file"] for f in model["figures"] if not (shared and f["file"] == "singularity.png")]
        for fig in figures:
            assert f"{fig}:" in text  # each figure's caption ...
        assert sum(_images_drawn(p) for p in pages) == len(figures)  # ... and its image
        assert ("the same plan" in text) == shared
        assert ("Convergence table" in text) == (not shared)
        assert text.count("* \u03b4 = 100 max |diff| / scale") == 1  # the footnote once per case
        assert "deg/s" in text and "[rad]" not in text  # angles in degrees, rates in deg/s
    n = len(reader.pages)
    for k, page in enumerate(reader.pages, start=1):  # numbered k / n at the foot
        assert page.extract_text().rstrip().endswith(f"{k} / {n}")
    front = reader.pages[0].extract_text()
    assert "2 of 2 case(s) pass" in front and "Contents" in front and "Summary" in front
    for (_title, page), (_, model) in zip(sections[1:], cases):  # the contents give each case's page
        assert re.search(rf"{re.escape(model['title'])}\s+PASS\s+{page + 1}\b", front), front
    levels = [item for item in reader.outline if isinstance(item, list)]
    assert levels and any(getattr(sub, "title", "") == "Verdicts" for group in levels for sub in group)


def test_pdf_links_go_to_the_cases(report_run):
    """The contents' and the summary's links are internal links to each case's heading (its page)."""
    reader = pypdf.PdfReader(report_run.written["pdf"])
    sections = dict(_top_level(reader))
    cases = [f"{m['title']}: {'PASS' if m['passed'] else 'FAIL'}" for _, m in load_case_models(report_run.root)]
    targets = []
    for annot in reader.pages[0].get("/Annots") or []:
        a = annot.get_object()
        if a.get("/Subtype") != "/Link":
            continue
        dest = a.get("/Dest")
        if dest is None and "/A" in a:
            dest = a["/A"].get_object().get("/D")
        assert dest is not None, a  # no external link on the front page
        if isinstance(dest, str) or hasattr(dest, "original_bytes"):  # a named destination
            dest = reader.named_destinations[str(dest)]
            targets.append(reader.get_destination_page_number(dest))
        else:
            targets.append(reader.get_page_number(dest[0].get_object()))
    for title in cases:  # each case linked from the contents and the summary
        assert targets.count(sections[title]) >= 2, (title, targets)


def test_pdf_is_no_larger_than_it_needs_to_be(report_run):
    """One image object per figure shown, its data about the PNG's size."""
    path = report_run.written["pdf"]
    reader = pypdf.PdfReader(path)
    images = {
        v.get_object().indirect_reference.idnum if v.get_object().indirect_reference else id(v)
        for p in reader.pages
        for v in (p["/Resources"].get("/XObject") or {}).values()
    }
    figures = sum(
        p.stat().st_size for p in report_run.root.rglob("*.png") if p.name != "singularity.png" or "open" in str(p)
    )
    assert len(images) >= 1
    assert path.stat().st_size < 1.3 * figures + 400_000


@pytest.fixture
def copied(report_run, tmp_path):
    """A copy of the fixture's run (a plain folder: rendered with render_run), and a secret outside it."""
    secret = tmp_path / "home" / ".ssh" / "id_rsa.png"
    secret.parent.mkdir(parents=True)
    secret.write_text(SECRET)
    root = tmp_path / "mail" / "paper"
    shutil.copytree(report_run.root, root)
    return root, secret


HOSTILE = '#read("/etc/passwd") *bold* #panic("boom") $x^2$ <lbl> @ref #image("/etc/hostname") ] } ) //'


def test_hostile_strings_of_a_report_json_print_as_text(copied):
    """Scenario names, descriptions, warnings and TOML go to Typst as data: shown literally, never run."""
    from .conftest import SCENARIO

    root, _ = copied
    p = root / SCENARIO / "open" / "report.json"
    model = json.loads(p.read_text())
    model["scenario"]["description"] = HOSTILE
    model["scenario"]["toml"] = HOSTILE + "\n" + model["scenario"]["toml"]
    model["warnings"] = [HOSTILE]
    model["title"] = "roll #panic() *x*"
    model["id"] = json.loads((root / SCENARIO / "closed" / "report.json").read_text())["id"]  # two cases, one id
    p.write_text(json.dumps(model))
    written = render_run(root, date="2000-01-01T00:00:00+00:00")
    reader = pypdf.PdfReader(written["pdf"])
    text = re.sub(r"\s+", " ", _text(reader))
    assert text.count('#read("/etc/passwd") *bold* #panic("boom")') >= 3, text[:3000]
    sections = _top_level(reader)
    assert len(sections) == 3 and sections[1][0] == "roll #panic() *x*: PASS" and sections[1][1] < sections[2][1]
    assert "root:" not in text


def test_a_figure_linked_out_of_the_run_is_never_printed(copied):
    """A figure that is a link (to a file outside the run) is refused in one line, no PDF written; the printer
    itself reads only regular PNG files inside the run."""
    from reports.pdf import run_file

    from .conftest import SCENARIO

    root, secret = copied
    fig = root / SCENARIO / "open" / "states.png"
    fig.unlink()
    fig.symlink_to(secret)
    (root / "report.pdf").unlink()
    with pytest.raises(InputError, match="states.png"):
        render_run(root, pdf=True)
    assert not (root / "report.pdf").exists()
    with pytest.raises(InputError, match="not a regular file inside the run"):
        run_file(root, fig, "the figure")
    with pytest.raises(InputError, match="not a regular file inside the run"):
        run_file(root, secret, "the figure")
    (root / "x.png").write_text("not a PNG")
    with pytest.raises(InputError, match="x.png: not a PNG file"):
        run_file(root, root / "x.png", "the figure")
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", 100_000, 100_000, 8, 2, 0, 0, 0)  # a header is all it takes to claim the size
    chunk = struct.pack(">I", 13) + b"IHDR" + ihdr + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    (root / "bomb.png").write_bytes(b"\x89PNG\r\n\x1a\n" + chunk)
    with pytest.raises(InputError, match="bomb.png: 100000 x 100000 pixels, above the bound"):
        run_file(root, root / "bomb.png", "the figure")


def test_typst_reads_nothing_outside_its_root(copied):
    """A view naming a file outside the run (what the view never does) fails in one line naming the PDF."""
    from reports.pdf import write_pdf

    root, secret = copied
    rel = "/" + "/".join([".."] * len(root.parts)) + str(secret)
    view = {"title": "t", "date": "x", "blocks": [{"kind": "figure", "path": rel, "caption": "c", "width": 1.0}]}
    out = root / "hostile.pdf"
    with pytest.raises(InputError) as err:
        write_pdf(view, root, out)
    msg = str(err.value)
    assert msg.startswith(f"cannot write {out}: Typst could not print it (") and "\n" not in msg
    assert not out.exists() and SECRET not in msg


def test_a_table_too_wide_for_the_page_is_printed_smaller_or_on_a_landscape_page(tmp_path):
    """A table's narrowest layout (its longest words, numbers never broken) decides its font size, and a table
    too wide even in the smallest goes on a landscape page of its own; the text after it back in portrait."""
    from reports import pdf

    cols = ["t [s]", "variable", "unit"] + [f"J = {j} [unit]" for j in range(13)]
    narrow = pdf._table(cols[:5], [["0", "alpha", "deg", "1.5", "2.5"]], "llrrr")
    tiny = pdf._table(cols[:12], [["0", "alpha", "deg"] + ["-27.6439412"] * 9] * 4, "llr" + "r" * 9, size="small")
    wide = pdf._table(cols, [["0", "alpha", "deg"] + ["-27.6439412"] * 13] * 4, "llr" + "r" * 13, size="small")
    assert "size" not in narrow and "landscape" not in narrow
    assert tiny["size"] == "tiny" and "landscape" not in tiny
    assert wide.get("landscape") is True
    view = {"title": "t", "date": "2000-01-01T00:00:00+00:00", "blocks": [pdf._par("before"), wide, pdf._par("after")]}
    reader = pypdf.PdfReader(pdf.write_pdf(view, tmp_path, tmp_path / "wide.pdf"))
    shapes = [(float(p.mediabox.width) > float(p.mediabox.height), p.extract_text()) for p in reader.pages]
    assert [s for s, _ in shapes] == [False, True, False]
    assert "before" in shapes[0][1] and "J = 12 [unit]" in shapes[1][1] and "after" in shapes[2][1]


def test_the_pdf_depends_on_the_models_and_the_render_date_only(copied, report_run):
    """Typst's embedded fonts and the render date as the PDF's own: the same run rendered again on the same
    date gives the same bytes (another machine too: no system font is used)."""
    from .conftest import DATE

    root, _ = copied
    first = render_run(root, date=DATE)["pdf"].read_bytes()
    assert render_run(root, date=DATE)["pdf"].read_bytes() == first
    assert first == report_run.written["pdf"].read_bytes()  # the fixture's, rendered in its own folder
