"""PDF reports printed by Typst: a static template (``templates/report.typ``) given the report as JSON data.

The run's validation report (:func:`run_view`) and a campaign's (:func:`campaign_view`) are built here as
plain JSON views: headings, paragraphs, tables of already formatted cells (the HTML pages' formatting,
:mod:`reports.html`: the same numbers), figures.  Nothing of a saved model is ever spliced into Typst markup:
the template reads the view with ``json(bytes(sys.inputs.data))`` and shows its strings as text.  The figures
are the run's own PNG files, each checked here to be a regular file inside the run, given as paths relative
to it; Typst's ``root`` is the run, so it reads nothing outside it, and it uses its embedded fonts only (the
PDF is the same on every machine).

In the run's report each case starts a new page under a level-1 heading (a PDF bookmark) that carries its
PASS/FAIL, its sections level-2 bookmarks; the contents give each case's page, every page is numbered
``k / N`` at its foot.
"""

from __future__ import annotations

import datetime
import json
import math
import struct
from pathlib import Path

from gna.errors import InputError, writing

#: The Typst template of every PDF report (in ``reports/templates``).
TEMPLATE = "report.typ"

#: Text width of an A4 page with the template's margins [mm], and the height a figure may take [mm] (a figure is
#: at most its size at 96 pixels per inch, as a browser shows it).
TEXT_WIDTH_MM, FIGURE_HEIGHT_MM = 184.0, 215.0

#: Most pixels of a figure printed (Typst decodes every figure; gflat's have about 1e6).
MAX_FIGURE_PIXELS = 25_000_000

#: Degrees per radian (the HTML templates' factor: the same digits).
DEG = 57.29577951308232


def _s(text, style: str | None = None, **extra) -> dict | str:
    """A span of text of the view, styled (``b``, ``i``, ``pass``, ``fail``, ``small``, ``code``, ``badge-*``,
    ``link`` with ``to``)."""
    return {"t": str(text), "s": style, **extra} if style else str(text)


def _badge(ok) -> dict:
    return _s("PASS" if ok else "FAIL", "badge-pass" if ok else "badge-fail")


def _state(state: str):
    return {
        "pass": _s("PASS", "badge-pass"),
        "fail": _s("FAIL", "badge-fail"),
        "recorded": _s("FAIL (recorded)", "badge-recorded"),
    }.get(state, "\u2013")


def _verdict_word(ok) -> str:
    return "PASS" if ok else "FAIL"


def _heading(level: int, text, *, label: str | None = None, new_page: bool = False) -> dict:
    b = {"kind": "heading", "level": level, "text": text}
    if label is not None:
        b["label"] = label
    if new_page:
        b["break"] = True
    return b


def _par(*spans, size: str | None = None) -> dict:
    b = {"kind": "par", "spans": list(spans)}
    if size:
        b["size"] = size
    return b


#: Font sizes of the tables [pt] (the template's ``sizes``), smallest last.
TABLE_PT = {"normal": 8.5, "small": 7.5, "tiny": 6.8}

#: Text width of a landscape A4 page [mm]; a cell's padding either side [pt]; an average character [em]
#: of the template's font (Libertinus Serif: digits 0.5 em, a bold heading's letters a little more).
LANDSCAPE_WIDTH_MM, CELL_PAD_PT, CHAR_EM = 271.0, 3.0, 0.56


def _plain(span) -> str:
    if isinstance(span, list):
        return "".join(_plain(x) for x in span)
    if isinstance(span, dict):
        return span.get("t", "")
    return str(span)


def _least_width_pt(columns, rows, size: str) -> float:
    """The narrowest a table can be laid out [pt]: each column as wide as its longest word (Typst breaks lines
    at spaces, never inside a number)."""
    em = TABLE_PT[size] * CHAR_EM
    total = 0.0
    for i, c in enumerate(columns):
        words = [w for cell in [c] + [r[i] for r in rows if i < len(r)] for w in _plain(cell).split()]
        total += max((len(w) for w in words), default=0) * em + 2 * CELL_PAD_PT
    return total


def _table(columns, rows, align, *, widths=None, size: str = "normal", header: bool = True) -> dict:
    """A table block; a table too wide for the page at ``size`` printed smaller, or on a landscape page."""
    b = {"kind": "table", "columns": list(columns), "rows": [list(r) for r in rows], "align": list(align)}
    if widths is not None:
        b["widths"] = list(widths)
    portrait, landscape = (mm / 25.4 * 72 for mm in (TEXT_WIDTH_MM, LANDSCAPE_WIDTH_MM))
    if _least_width_pt(b["columns"], b["rows"], size) > portrait:
        fits = [z for z in ("small", "tiny") if _least_width_pt(b["columns"], b["rows"], z) <= portrait]
        if fits:
            size = fits[0]
        else:  # on a landscape page, in the largest size that fits there (else the smallest)
            b["landscape"] = True
            b.pop("widths", None)
            size = next((z for z in (size, "tiny") if _least_width_pt(b["columns"], b["rows"], z) <= landscape), "tiny")
    if size != "normal":
        b["size"] = size
    if not header:
        b["header"] = False
    return b


def _keyvalue(pairs, size: str = "normal") -> dict:
    return _table(
        ["", ""], [[_s(k, "b"), v] for k, v in pairs], ["l", "l"], widths=["22%", "1fr"], size=size, header=False
    )


def png_size(path: Path) -> tuple[int, int] | None:
    """Width and height [px] of a PNG file, from its header.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    (int, int) or None
        None when it is no PNG file (or cannot be read).
    """
    try:
        with open(path, "rb") as f:
            head = f.read(24)
    except OSError:
        return None
    if len(head) < 24 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    w, h = struct.unpack(">II", head[16:24])
    return (w, h) if w > 0 and h > 0 else None


def run_file(root: Path, path: Path, what: str) -> str:
    """The path Typst reads a figure at: relative to the run (``/...``), once it is a regular file inside it.

    Parameters
    ----------
    root : Path
        The run's folder (Typst's root).
    path : Path
        The figure.
    what : str
        Who names it, for the message.

    Returns
    -------
    str

    Raises
    ------
    InputError
        A link, a file outside the run once resolved, no PNG file, or one of more than
        :data:`MAX_FIGURE_PIXELS` pixels.
    """
    from .html import _run_file

    base = Path(root).resolve()
    p = Path(path)
    if not _run_file(base, p):  # the pages' rule for a file of the run
        raise InputError(f"{what} {p.name}: not a regular file inside the run {root} (never printed)")
    size = png_size(p)
    if size is None:
        raise InputError(f"{what} {p.name}: not a PNG file")
    if size[0] * size[1] > MAX_FIGURE_PIXELS:  # a small file can hold a huge image, all decoded to print it
        raise InputError(
            f"{what} {p.name}: {size[0]} x {size[1]} pixels, above the bound of {MAX_FIGURE_PIXELS:.0e} "
            f"(a gflat figure has about 1e6)"
        )
    return "/" + p.resolve().relative_to(base).as_posix()


def _figure(root: Path, path: Path, caption, what: str) -> dict:
    rel = run_file(root, path, what)
    w, h = png_size(path)
    # at most its size at 96 pixels per inch (a browser's), the text's width, and FIGURE_HEIGHT_MM tall
    width = min(TEXT_WIDTH_MM, w * 25.4 / 96, FIGURE_HEIGHT_MM * w / h) / TEXT_WIDTH_MM
    return {"kind": "figure", "path": rel, "caption": caption, "width": round(width, 4)}


# --- the run's report --------------------------------------------------------------------------------------


def _records(given: dict, spec: str | None = None, compact: bool = False, size: str = "small") -> dict:
    """A difference or convergence table as the HTML's ``records`` macro shows it."""
    from .html import TEXT_COLUMNS, cell, header, shown_table

    table = shown_table(given, compact)
    cols = table["columns"]
    rows = [
        [_s(cell(v, c, spec), "fail") if v is False else cell(v, c, spec) for v, c in zip(row, cols)]
        for row in table["rows"]
    ]
    return _table([header(c) for c in cols], rows, ["l" if c in TEXT_COLUMNS else "r" for c in cols], size=size)


def _verdict_span(t: dict):
    if t["informative"]:
        return "informative"
    return _s(_verdict_word(t["passed"]), "pass" if t["passed"] else "fail")


def _difference_table(t: dict, compact: bool) -> list:
    from .html import fmt

    title = [
        f"{t['labels'][1]} \u2212 {t['labels'][0]}, {t['window']}: t in [{fmt(t['span'][0])}, {fmt(t['span'][1])}] s, "
        f"{t['samples']} samples \u2014 ",
        "informative (no tolerances)" if t["informative"] else _verdict_span(t),
    ]
    out = [_heading(3, title), _records(t, None, compact)]
    if t["notes"]:
        out.append(_par(_s(f"{len(t['notes'])} note(s) on this table: see Warnings.", "fail")))
    return out


def _side_by_side_table(ts: list, key: str) -> list:
    from .html import fmt, side_by_side

    if not ts:
        return []
    title = [
        f"{ts[0]['labels'][1] if key == 'window' else 'each engine'} \u2212 "
        f"{ts[0]['labels'][0] if key == 'window' else 'the plan'}: "
    ]
    for i, t in enumerate(ts):
        title += [
            f"{t[key]} (t in [{fmt(t['span'][0])}, {fmt(t['span'][1])}] s, {t['samples']} samples) \u2014 ",
            _verdict_span(t),
        ]
        if i < len(ts) - 1:
            title.append("; ")
    out = [_heading(3, title), _records(side_by_side(ts, key))]
    out += [
        _par(_s(f"{len(t['notes'])} note(s) on the {t[key]} table: see Warnings.", "fail")) for t in ts if t["notes"]
    ]
    return out


def _bound(value, unit: str) -> str:
    from .html import fmt

    if unit == "rad":
        return f"{fmt(value * DEG, '.2f')}\u00b0"
    return f"{fmt(value)} {unit if unit != '-' else ''}".rstrip()


def _verdicts_section(m: dict) -> list:
    from .html import fmt, verdict_cells

    verdict = m.get("verdict")
    v = verdict.get("verdicts") if isinstance(verdict, dict) else None
    out = [_heading(2, "Verdicts")]
    if v is None:
        return out + [
            _par("No verdicts in this report (saved before they existed): render it again with gflat compare/paper.")
        ]
    out.append(
        _table(
            ["verdict", "result", "worst"],
            [[c["heading"], _state(c["state"]), c["worst"]] for c in verdict_cells(m)],
            "lll",
            widths=["18%", "16%", "1fr"],
        )
    )
    fl = v["flyable"]
    out.append(
        _par(
            f"flyable: the plan (iterate {fl.get('iterate', 'J')}) within the aircraft\u2019s limits, checked every "
            f"{fmt(fl['grid_step_s']) if 'grid_step_s' in fl else '-'} s; tracking: closed loop, every engine\u2019s "
            "largest distance to the flat outputs after the settle time against the tolerance; engines agree: every "
            "run complete and within the tolerances of the reference."
        )
    )
    if fl.get("violations"):
        rows = [
            [
                x["name"],
                _bound(x["limit"], x["unit"]),
                _bound(x["worst"], x["unit"]) if x["known"] else _s(_bound(x["worst"], x["unit"]), "fail"),
                fmt(x["time"]),
                fmt(100 * x["fraction"], ".0f"),
                fmt(x["first"]),
                fmt(x["last"]),
                f"yes: {x['reason']}" if x["known"] else "no",
            ]
            for x in fl["violations"]
        ]
        out.append(
            _table(
                ["limit", "bound", "worst", "at t [s]", "share of the span [%]", "from [s]", "to [s]"]
                + ["recorded by the scenario"],
                rows,
                "lrrrrrrl",
                widths=["10%", "auto", "auto", "auto", "8%", "auto", "auto", "1fr"],
                size="small",
            )
        )
    if fl.get("infeasible"):
        out.append(_par(_s(f"No plan of the path: {fl['reason']}", "fail")))
    tr = v["tracking"]
    if "engines" in tr:
        clipped = " (flown unclipped: saturate = false)" if tr.get("clipped") is False else " (clipped)"
        rows = [
            [
                e,
                t["status"],
                fmt(t["max_error_after_settle_m"]),
                fmt(tr["tolerance_m"]),
                fmt(t["saturated_s"]),
                _badge(t["pass"]),
            ]
            for e, t in tr["engines"].items()
        ]
        out.append(
            _table(
                ["engine", "run", f"distance after {fmt(tr['settle_s'])} s [m]", "tolerance [m]"]
                + [f"commanded beyond limits [s]{clipped}", "tracking"],
                rows,
                "llrrrl",
            )
        )
    return out


def _case_blocks(c: dict, label: str, shared_label: str | None) -> list:
    """One case of the run's PDF: the HTML's ``case_body`` (compact, no data files) under its level-1 heading."""
    from .html import fmt, setting, text

    m = c["model"]
    root = c["root"]
    shared = c.get("same_plan_as")
    out = [_heading(1, f"{m['title']}: {_verdict_word(m['passed'])}", label=label, new_page=True)]
    failures = (m.get("verdict") or {}).get("failures") if isinstance(m.get("verdict"), dict) else None
    settings = m["settings"]
    step = (
        f", JSBSim step {fmt(settings['jsbsim_dt'])} s"
        if "jsbsim_dt" in settings and settings["jsbsim_dt"] is not None
        else ""
    )
    out.append(
        _par(
            "Verdict: ",
            _badge(m["passed"]),
            f" ({', '.join(failures)})" if failures else "",
            f" \u2014 engines {', '.join(m['engines'])} (reference {m['reference_engine']}), {m['loop']} loop, "
            f"output grid {fmt(settings['dt_out'])} s{step}.",
        )
    )
    out += _verdicts_section(m)
    sc = m["scenario"]
    out.append(_heading(2, "Scenario"))
    pairs = [
        ("name", sc["name"]),
        ("description", " ".join(str(sc["description"]).split())),  # prose, as the HTML shows it
        ("aircraft", f"{sc['aircraft']['id']}: {sc['aircraft']['name']}"),
        ("span", f"t = {fmt(sc['span_s'][0])} .. {fmt(sc['span_s'][1])} s, nodes every {fmt(sc['node_step_s'])} s"),
    ] + [(f"flat output {k}", _s(v, "code")) for k, v in sc["flat_outputs"].items()]
    out.append(_keyvalue(pairs))
    if shared:
        title = _s(shared["title"], "link", to=shared_label) if shared_label else shared["title"]
        out.append(
            _par("Scenario file, plan convergence and singularity monitor: those of ", title, " (the same plan).")
        )
    elif sc.get("toml"):
        out += [_par(_s(f"Scenario file {sc['file']}", "b")), {"kind": "code", "text": str(sc["toml"])}]
    plan = m["plan"]
    out.append(_heading(2, "Plan"))
    out.append(
        _table(
            [""] * 6,
            [
                [_s("J", "b"), fmt(plan["J"]), _s("nodes", "b"), fmt(plan["nodes"]), _s("flat output", "b")]
                + [fmt(plan["flat_output"])],
                [_s("orders per iterate", "b"), ", ".join(fmt(o) for o in plan["orders"]), _s("feasible", "b")]
                + [text(plan["feasible"]), _s("worst Newton residual [SI]", "b"), fmt(plan["worst_newton_residual"])],
            ],
            "lrlrlr",
            header=False,
        )
    )
    if not shared:
        out.append(
            _par(
                "Convergence table: the value at t of each iterate J, in the row\u2019s unit (angles in degrees, "
                "rates in deg/s)."
            )
        )
        out.append(_records(plan["convergence"], ".8g"))
    if plan.get("singularity"):
        s = plan["singularity"]
        out.append(_par(f"Singularity monitor: condition {s['condition']}{'' if s['warnings'] else ', no warning'}."))
    out.append(_heading(2, "Runs"))
    rows = []
    for lbl, r in m["runs"].items():
        status = f"{r['status']}{': ' + str(r['message']) if r.get('message') else ''}"
        rs = r["settings"]
        how = (
            f"dt = {fmt(rs['dt'])} s, integrators: {text(rs['integrators'])}"
            if rs.get("dt") is not None
            else f"{text(rs['method'])}, rtol = {fmt(rs['rtol'])}, atol = {fmt(rs['atol'])}"
        )
        rows.append([lbl, status if r["status"] == "completed" else _s(status, "fail"), fmt(r["t_end"]), how])
    out.append(_table(["engine", "status", "t end [s]", "settings"], rows, "llrl", widths=["12%", "14%", "9%", "1fr"]))
    cl = m.get("closed_loop")
    if cl:
        if cl["design"] == "paper":
            design = " pole magnitudes " + ", ".join(f"({text(row)})" for row in cl["lambdas"]) + ";"
        else:
            design = " time-varying LQR (Bryson weights);"
        sat = "; ".join(f"{lbl} {fmt(s['any'])} s" for lbl, s in cl["saturated_s"].items())
        out.append(
            _par(
                f"Closed loop, tracking design {cl['design']}: feedforward and reference from iterate "
                f"j = {cl['feedforward_iterate']};{design} controls beyond their limits: {sat}."
            )
        )
    out.append(_heading(2, "Warnings"))
    out.append({"kind": "list", "items": [str(w) for w in m["warnings"]]} if m["warnings"] else _par("None."))
    out.append(_heading(2, "Figures"))
    for f in m["figures"]:
        if shared and f["file"] == "singularity.png":
            continue
        out.append(
            _figure(
                root, c["figures"][f["file"]], f"{f['file']}: {f['caption']}", f"{c['report_json']} names the figure"
            )
        )
    out.append(_heading(2, "Differences between engines"))
    out.append(
        _par(
            "Each window\u2019s largest difference side by side; the case\u2019s HTML page and report.json hold every "
            "column (time of the maximum, RMS, \u03b4, scales, atol, rtol)."
        )
    )
    tables = m["tables"]
    for e in dict.fromkeys(t["engine"] for t in tables["engines"]):
        out += _side_by_side_table([t for t in tables["engines"] if t["engine"] == e], "window")
    if tables.get("self_convergence"):
        out.append(_heading(2, "JSBSim self-convergence (its step against half of it)"))
        for t in tables["self_convergence"]:
            out += _difference_table(t, True)
    out.append(_heading(2, "Differences against the plan"))
    out += _side_by_side_table(tables["plan"], "engine")
    out.append(_par(DELTA_NOTE, size="small"))
    out.append(_heading(2, "Comparison settings"))
    out.append(_keyvalue([(k.replace("_", " "), setting(v, k)) for k, v in m["settings"].items()]))
    out.append(_heading(2, "Provenance"))
    out.append(_keyvalue([(k.replace("_", " "), text(v)) for k, v in m["provenance"].items()]))
    return out


#: The δ footnote under a case's difference tables (once per case).
DELTA_NOTE = (
    "[unit]: in the row\u2019s unit (angles in degrees, rates in deg/s). * \u03b4 = 100 max |diff| / scale over "
    "the window [%]; scale = max |ref| for quantities with a physical zero (speed, \u03b3, \u03b1, \u03b2, \u03bc, "
    "rates, controls, forces), and the reference\u2019s excursion max \u2212 min over the window for x, y, z and "
    "\u03c7, whose zero is a datum (the NED origin, north; for position, the largest distance between two points "
    "of the reference\u2019s path): the same manoeuvre gives the same \u03b4 wherever and whichever way it is "
    "flown. Undefined (\u2013) where the scale is at most the floor of its kind of quantity (0.01 m, 0.001 m/s, "
    "0.0001 rad = 0.0057 deg, 0.001 rad/s = 0.057 deg/s: the cross-engine tolerances; 0.001 N, 0.0001 N m), i.e. "
    "zero at the comparison\u2019s resolution."
)


def run_view(cases: list, common: dict) -> dict:
    """The run's PDF report as the template's JSON view.

    Parameters
    ----------
    cases : list of dict
        The cases in run order: ``model`` (:func:`reports.model.case_model`), ``root`` (the run's folder),
        ``figures`` (figure file -> its path, confined to the run), ``report_json`` (for messages) and, for a
        scenario's later cases, ``same_plan_as`` (the first case's ``id``, ``title`` and ``index`` in
        ``cases``).
    common : dict
        ``date``, ``manifest`` (or None), ``n_pass``, ``n``, ``incomplete`` (or None).

    Returns
    -------
    dict
        ``title``, ``date``, ``blocks`` (see ``templates/report.typ``).

    Raises
    ------
    InputError
        A figure not a regular PNG file inside the run.
    KeyError, TypeError, ValueError, IndexError, AttributeError
        A damaged model (the caller names its ``report.json``).
    """
    from .html import fmt, verdict_cells

    labels = [f"case-{i}" for i in range(len(cases))]  # the view's own: two cases of one id stay two
    n_pass, n = common["n_pass"], common["n"]
    blocks = []
    if common.get("incomplete"):
        blocks.append({"kind": "notice", "spans": [f"incomplete run: {common['incomplete']}"]})
    blocks.append(_heading(1, "gflat validation report", label="top"))
    blocks.append(
        _par(
            _badge(n_pass == n),
            f" {n_pass} of {n} case(s) pass: no verdict fails that the scenario does not record. Three verdicts per "
            "case: ",
            _s("flyable", "i"),
            " (the plan\u2019s controls and states within the aircraft\u2019s limits), ",
            _s("tracking", "i"),
            " (closed loop: the feedback holds the flat outputs after the settle time), ",
            _s("engines agree", "i"),
            " (each plan flown on every engine from the same initial state, each engine within the tolerances of the "
            f"reference). Angles in degrees, rates in deg/s, everything else in SI units. Rendered {common['date']}.",
        )
    )
    manifest = common.get("manifest")
    blocks.append(_heading(2, "Contents"))
    rows = [
        {"label": label, "title": str(c["model"]["title"]), "passed": bool(c["model"]["passed"])}
        for c, label in zip(cases, labels)
    ]
    if manifest:  # in the front matter, before the cases: listed first, the contents in page order
        rows.insert(0, {"label": "manifest", "title": "Manifest", "passed": None})
    blocks.append({"kind": "contents", "rows": rows})
    blocks.append(_heading(2, "Summary"))
    rows = []
    for c, label in zip(cases, labels):
        m = c["model"]
        row = [_s(m["scenario"]["name"], "link", to=label), m["scenario"]["aircraft"]["id"], m["loop"]]
        row += [fmt(m["plan"]["J"]), ", ".join(m["engines"])]
        row += [[_state(v["state"]), {"t": "", "s": "br"}, _s(v["worst"], "small")] for v in verdict_cells(m)]
        rows.append(row + [_badge(m["passed"])])
    blocks.append(
        _table(
            ["scenario", "aircraft", "loop", "J", "engines", "flyable", "tracking", "engines agree", "result"],
            rows,
            "lllrlllll",
            widths=["17%", "auto", "auto", "auto", "auto", "1fr", "1fr", "1fr", "auto"],
            size="small",
        )
    )
    if manifest:
        blocks.append(_heading(2, "Manifest", label="manifest"))
        pairs = []
        # the manifest's entries the report shows, in order (a local: a module-level string naming one of our
        # packages reads as a lazy import to tests/test_architecture.py)
        for k in ("gflat", "jsbsim", "numpy", "scipy", "python", "git_commit", "date_utc", "command_line"):
            if k in manifest:
                v = manifest[k]
                pairs.append((k, " ".join(str(x) for x in v) if isinstance(v, (list, tuple)) else fmt(v)))
        blocks.append(_keyvalue(pairs))
    for c, label in zip(cases, labels):
        shared = c.get("same_plan_as")
        blocks += _case_blocks(c, label, labels[shared["index"]] if shared and "index" in shared else None)
    return {"title": f"gflat validation report: {n_pass}/{n} cases pass", "date": common["date"], "blocks": blocks}


# --- a campaign's report -----------------------------------------------------------------------------------


def campaign_view(context: dict, root: Path) -> dict:
    """A campaign's PDF report as the template's JSON view (the campaign page's content:
    :func:`reports.campaign.render_campaign`).

    Parameters
    ----------
    context : dict
        What the campaign page is rendered with (``name``, ``seed``, ``description``, ``counts``, ``n_done``,
        ``n_pass``, ``groups``, ``failed``, ``date``, ``incomplete``, ``figures``).
    root : Path
        The report's folder, holding the figures (Typst's root).

    Returns
    -------
    dict
        ``title``, ``date``, ``blocks``.
    """
    from .html import fmt

    counts = context["counts"]
    blocks = []
    if context.get("incomplete"):
        blocks.append({"kind": "notice", "spans": [f"incomplete run: {context['incomplete']}"]})
    blocks.append(_heading(1, f"Campaign {context['name']}"))
    blocks.append(
        _par(
            _badge(context["n_pass"] == context["n_done"] and counts["failed"] == 0),
            f" {context['n_pass']} of {context['n_done']} case(s) done pass (no verdict fails that the scenario does "
            "not record: the path planned for the sample\u2019s aircraft is flyable, the feedback holds the flat "
            f"outputs, the engines agree). Campaign seed {context['seed']}; {counts['cases']} cases: "
            f"{counts['done']} done, {counts['failed']} failed, {counts['pending']} pending.",
        )
    )
    if context.get("description"):
        blocks.append(_par(str(context["description"])))
    for f in context["figures"]:
        blocks.append(_figure(root, root / f["src"], f["alt"], "the campaign report's figure"))
    for g in context["groups"]:
        blocks.append(_heading(2, str(g["key"])))
        blocks.append(
            _par(
                f"{g['scenario']}, {g['loop']} loop, engines {', '.join(g['engines'])}: {g['passed']} of {g['n']} "
                f"pass ({fmt(100 * g['pass_rate'], '.0f')} %)."
            )
        )
        rows = [
            [
                name,
                fmt(v["n"]),
                fmt(v["pass"]),
                _s(fmt(v["fail"]), "fail") if v["fail"] > v["recorded"] else fmt(v["fail"]),
                fmt(v["recorded"]),
                f"{fmt(100 * v['pass_rate'], '.0f')} %" if v["pass_rate"] is not None else "\u2014",
            ]
            for name, v in g["verdicts"].items()
        ]
        blocks.append(
            _table(
                ["verdict", "judged", "pass", "fail", "of which recorded by the scenario", "pass rate"], rows, "lrrrrr"
            )
        )
        causes = list(g["causes"].items())
        blocks.append(
            _table(
                [str(c) for c, _ in causes],
                [[_s(fmt(k), "fail") if k and c != "pass" else fmt(k) for c, k in causes]],
                "r" * len(causes),
            )
        )
        rows = []
        for e in g["engines"]:
            te, sat = g["tracking_error_m"][e], g["saturated_s"][e]
            diff = fmt(g["engine_difference_m"][e]["max"]) if e in g["engine_difference_m"] else "\u2014"
            status = ", ".join(f"{s} {k}" for s, k in g["status"][e].items())
            rows.append([e, status, fmt(te["median"]), fmt(te["p90"]), fmt(te["max"]), fmt(sat["median"])])
            rows[-1] += [fmt(sat["max"]), diff]
        blocks.append(
            _table(
                ["engine", "run status", "distance to the flat outputs: median [m]", "p90 [m]", "max [m]"]
                + ["saturated: median [s]", "max [s]", f"difference from {g['engines'][0]}: max [m]"],
                rows,
                "llrrrrrr",
                size="small",
            )
        )
        blocks.append(_heading(3, "Worst cases"))
        rows = [
            [
                str(w["case_id"]),
                fmt(w["seed"]),
                fmt(w["tracking_error_m"]),
                ", ".join(f"{e}: {s}" for e, s in w["status"].items()),
                str(w["cause"] or "-"),
                _badge(w["pass"]),
            ]
            for w in g["worst"]
        ]
        blocks.append(
            _table(
                ["case", "seed", "distance to the flat outputs [m]", "runs", "cause", "verdict"],
                rows,
                "lrrlll",
                size="small",
            )
        )
        blocks.append(_heading(3, "What the error follows"))
        blocks.append(
            _table(
                ["dispersed parameter", f"Spearman \u03c1 with the {g['engines'][0]} distance to the flat outputs"],
                [[str(p), fmt(rho, "+.2f")] for p, rho in g["correlations"][:8]],
                "lr",
            )
        )
    if context.get("failed"):
        blocks.append(_heading(2, "Failed cases"))
        blocks.append({"kind": "list", "items": [f"{k}: {v}" for k, v in context["failed"].items()]})
    blocks.append(_par(f"Rendered {context['date']}.", size="small"))
    return {"title": f"gflat campaign {context['name']}", "date": context["date"], "blocks": blocks}


# --- printing ----------------------------------------------------------------------------------------------


def _timestamp(date) -> int | None:
    """The render date as Unix seconds (the PDF's own date: the same date gives the same bytes)."""
    try:
        return math.floor(datetime.datetime.fromisoformat(str(date)).timestamp())
    except (TypeError, ValueError, OverflowError):
        return None


def print_pdf(view: dict, root: str | Path, path: str | Path) -> bytes:
    """Print a view to PDF with Typst (its embedded fonts only; files read only under ``root``).

    Parameters
    ----------
    view : dict
        :func:`run_view` or :func:`campaign_view`.
    root : str or Path
        The folder the view's figure paths are relative to; Typst reads nothing outside it.
    path : str or Path
        The PDF it is for (named in an error).

    Returns
    -------
    bytes
        The PDF.

    Raises
    ------
    InputError
        Typst could not print it (one line naming ``path`` and the cause).
    """
    try:
        import typst
    except ImportError as exc:  # a broken installation: named, never a traceback
        raise InputError(
            f"cannot write {path}: the typst package cannot be imported ({exc}): pip install typst"
        ) from None

    source = (Path(__file__).parent / "templates" / TEMPLATE).read_bytes()
    data = json.dumps(view, allow_nan=False, ensure_ascii=False)
    try:
        return typst.compile(
            source,
            root=str(Path(root).resolve()),
            sys_inputs={"data": data},
            ignore_system_fonts=True,
            pdf_tags=False,
            timestamp=_timestamp(view.get("date")),
        )
    except typst.TypstError as exc:
        cause = " ".join(str(exc).split()) or type(exc).__name__
        raise InputError(f"cannot write {path}: Typst could not print it ({cause})") from None


def write_pdf(view: dict, root: str | Path, path: str | Path) -> Path:
    """Print a view to PDF (:func:`print_pdf`) and write it.

    Parameters
    ----------
    view : dict
        :func:`run_view` or :func:`campaign_view`.
    root : str or Path
        The folder the view's figure paths are relative to (the run's, the campaign report's).
    path : str or Path
        The PDF to write; its folder must exist.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        Typst could not print it, or the file cannot be written.
    """
    path = Path(path)
    data = print_pdf(view, root, path)
    with writing(path):
        path.write_bytes(data)
    return path
