"""HTML validation reports rendered with jinja2 from saved case models (``report.json``).

:func:`render_run` renders a run folder (a plain folder: a command renders into its staging folder,
:class:`harness.rundir.RunDir`, before the run is put in place): ``index.html`` (a PASS/FAIL table of
every case with links), one ``report.html`` per case folder, optionally a
self-contained ``report.html`` at the top (every case, images embedded as data
URIs: one file to mail) and ``report.pdf`` (printed by Typst from a JSON view of
the same models, formatted by the same helpers: :func:`pdf_view`,
:mod:`reports.pdf`).  The models
are read back from disk (:func:`reports.model.load_case_models`), so rendering
at the end of a run and ``gflat report DIR`` later give the same bytes apart
from the render date.
"""

from __future__ import annotations

import base64
import contextlib
import datetime
import functools
import json
import math
from pathlib import Path

from gna.errors import InputError, describe
from harness.progress import stage
from harness.recorded import confined, file_problem, href

from .model import REPORT_JSON, load_case_models, read_json_object, write_text

#: Page of each case, in its case folder; the run's index and single-file report at the top.
CASE_PAGE, INDEX_PAGE, SINGLE_PAGE, PDF_FILE = "case.html", "index.html", "report.html", "report.pdf"

#: What rendering writes (never listed among a case's data files: a re-rendering must give the same page).
RENDERED = frozenset((CASE_PAGE, INDEX_PAGE, SINGLE_PAGE, PDF_FILE))

#: Column headings of the difference and convergence tables ("[unit]": in the row's unit, its ``unit`` column).
HEADERS = {
    "t": "t [s]",
    "variable": "variable",
    "unit": "unit",
    "max_abs": "max |diff| [unit]",
    "t_max": "at t [s]",
    "rms": "RMS [unit]",
    "delta_pct": "\u03b4 [%]*",
    "scale": "\u03b4 scale [unit]*",
    "ref_max": "max |ref| [unit]",
    "atol": "atol [unit]",
    "rtol": "rtol [-]",
    "tolerance": "tolerance [unit]",
    "passed": "result",
}

#: Columns of a difference table in the row's unit: converted with it (radians shown as degrees).
IN_ROW_UNIT = ("max_abs", "rms", "scale", "ref_max", "atol", "tolerance")


def _in_row_unit(column: str) -> bool:
    return column.split("|", 1)[0] in IN_ROW_UNIT


#: Columns of the tables printed as text (left-aligned).
TEXT_COLUMNS = frozenset(("variable", "unit"))


def side_by_side(tables: list, key: str) -> dict:
    """Difference tables of the same variables as one table, each one's max |diff| and result side by side
    (the PDF's form: half the rows to print).

    Parameters
    ----------
    tables : list of dict
        Tables of a model (``columns``, ``rows``; the same variables in the same order), each with ``key``.
    key : str
        What tells them apart (``"window"``, ``"engine"``), named in their columns' headings.

    Returns
    -------
    dict
        ``columns`` (``variable``, ``unit``, ``max_abs|<name>``, ``passed|<name>`` (tables with a verdict)
        ... and ``tolerance`` when every table has the same), ``rows``.
    """
    if not tables:
        return {"columns": [], "rows": []}
    cols = tables[0]["columns"]
    i_var, i_unit = cols.index("variable"), cols.index("unit")
    names = [str(t[key]) for t in tables]
    rows_of = [{r[t["columns"].index("variable")]: r for r in t["rows"]} for t in tables]
    tol = [
        [r[t["columns"].index("tolerance")] for r in t["rows"]] if "tolerance" in t["columns"] else None for t in tables
    ]
    same_tol = all(x == tol[0] for x in tol) and tol[0] is not None
    judged = [any(r[t["columns"].index("passed")] is not None for r in t["rows"]) for t in tables]
    columns = ["variable", "unit"]
    for n, j in zip(names, judged):
        columns += [f"max_abs|{n}"] + ([f"passed|{n}"] if j else [])
    columns += ["tolerance"] if same_tol else []
    rows = []
    for r in tables[0]["rows"]:
        var = r[i_var]
        row = [var, r[i_unit]]
        for t, by, j in zip(tables, rows_of, judged):
            other = by.get(var)
            c = t["columns"]
            cells = [None, None] if other is None else [other[c.index("max_abs")], other[c.index("passed")]]
            row += cells if j else cells[:1]
        if same_tol:
            row.append(r[cols.index("tolerance")])
        rows.append(row)
    return {"columns": columns, "rows": rows}


def header(name: str) -> str:
    """The heading of a table column, with its unit (``"J=3"`` of a convergence table: ``"J = 3 [unit]"``).

    Parameters
    ----------
    name : str
        Column name of a model's table.

    Returns
    -------
    str
    """
    if name.startswith("J=") and name[2:].isdigit():
        return f"J = {name[2:]} [unit]"
    if "|" in name:
        base, which = name.split("|", 1)
        return f"{HEADERS.get(base, base)}, {which}"
    return HEADERS.get(name, name)


def shown_unit(unit: str) -> tuple[float, str]:
    """Factor and unit a value in the SI ``unit`` is shown in: radians as degrees, rad/s as deg/s.

    Parameters
    ----------
    unit : str
        SI unit (``"rad"``, ``"rad/s"``, ``"m"``, ...).

    Returns
    -------
    (float, str)
    """
    if unit == "rad":
        return math.degrees(1.0), "deg"
    if unit == "rad/s":
        return math.degrees(1.0), "deg/s"
    return 1.0, unit or "-"


def _times(value, k: float):
    return value * k if isinstance(value, (int, float)) and not isinstance(value, bool) else value


#: Columns of a difference table in the PDF (the HTML page shows every column).
COMPACT_COLUMNS = ("variable", "unit", "max_abs", "t_max", "delta_pct", "tolerance", "passed")


def shown_table(table: dict, compact: bool = False) -> dict:
    """A model's table as a reader sees it: angles in degrees and rates in deg/s, a unit on every row.

    A difference table (with a ``unit`` column) has its :data:`IN_ROW_UNIT` columns converted; a
    convergence table (``t``, ``variable``, ``J=k``...) gains the ``unit`` column, its values converted.

    Parameters
    ----------
    table : dict
        ``{"columns": [...], "rows": [[...], ...]}`` (:func:`reports.model.case_model`).
    compact : bool
        Keep only the :data:`COMPACT_COLUMNS` of a difference table (the PDF's).

    Returns
    -------
    dict
        A new table (the model is not changed).
    """
    from gna.trajectory import UNITS

    cols = list(table["columns"])
    rows = []
    if compact and "unit" in cols and not any("|" in c for c in cols):
        keep = [i for i, c in enumerate(cols) if c in COMPACT_COLUMNS]
        table = dict(table, columns=[cols[i] for i in keep], rows=[[r[i] for i in keep] for r in table["rows"]])
        cols = list(table["columns"])
    if "unit" in cols:
        u = cols.index("unit")
        conv = [i for i, c in enumerate(cols) if _in_row_unit(c)]
        for row in table["rows"]:
            k, unit = shown_unit(row[u])
            row = list(row)
            row[u] = unit
            for i in conv:
                row[i] = _times(row[i], k)
            rows.append(row)
        return dict(table, columns=cols, rows=rows)
    if "variable" in cols:
        v = cols.index("variable")
        values = [i for i, c in enumerate(cols) if c.startswith("J=")]
        for row in table["rows"]:
            k, unit = shown_unit(UNITS.get(row[v], ""))
            row = [_times(x, k) if i in values else x for i, x in enumerate(row)]
            rows.append(row[: v + 1] + [unit] + row[v + 1 :])
        return dict(table, columns=cols[: v + 1] + ["unit"] + cols[v + 1 :], rows=rows)
    return table


#: Units of the comparison settings (SI; the tolerances take their variable's unit).
SETTING_UNITS = {"dt_out": "s", "jsbsim_dt": "s", "tracking_tolerance": "m", "settle_time": "s"}


def quantity(value, unit: str) -> str:
    """A value in the SI ``unit`` as shown (:func:`shown_unit`), its unit after it.

    Parameters
    ----------
    value : object
    unit : str

    Returns
    -------
    str
    """
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return text(value)
    k, shown = shown_unit(unit)
    return f"{fmt(value * k)} {shown}".rstrip(" -")


def setting(value, name: str) -> str:
    """A comparison setting as prose, with its unit: tolerances per variable (angles in degrees), windows
    and steps in seconds, relative tolerances dimensionless.

    Parameters
    ----------
    value : object
        The setting (:meth:`harness.validation.CompareSettings.to_dict`).
    name : str
        Its key.

    Returns
    -------
    str
    """
    from gna.trajectory import UNITS

    if name == "tolerances" and isinstance(value, dict):
        return "; ".join(f"{k} {quantity(v, UNITS.get(k, ''))}" for k, v in value.items()) or "-"
    if name == "rtol" and isinstance(value, dict):
        return "; ".join(f"{k} {fmt(v)}" for k, v in value.items()) or "none"
    if name == "windows" and isinstance(value, dict):
        return "; ".join(f"{k}: {quantity(v, 's')}" for k, v in value.items()) or "-"
    if name in SETTING_UNITS:
        return quantity(value, SETTING_UNITS[name])
    return text(value)


def text(value) -> str:
    """A setting as prose, never a Python repr: mappings ``key value, ...``, sequences joined, yes/no.

    Parameters
    ----------
    value : object

    Returns
    -------
    str
    """
    if isinstance(value, dict):
        return "; ".join(f"{str(k).replace('_', ' ')} {text(v)}" for k, v in value.items()) or "-"
    if isinstance(value, (list, tuple)):
        return ", ".join(text(v) for v in value) or "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    return fmt(value)


#: Sub-folder of a scenario holding its plan's files (linked from the case pages when present).
PLAN_FOLDER = "plan"


def fmt(value, spec: str | None = None) -> str:
    """Format a value: numbers to four significant digits, booleans as on/off, None as a dash.

    Parameters
    ----------
    value : object
        The cell (floats, ints, bools, None, strings such as ``"nan"``).
    spec : str, optional
        A format spec for numbers instead of the default.

    Returns
    -------
    str
    """
    if value is None:
        return "-"
    if isinstance(value, bool):  # a setting, not a verdict (see :func:`cell`)
        return "on" if value else "off"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if spec:
            return format(value, spec)
        a = abs(value)
        return f"{value:.4g}" if value == 0 or (1e-3 <= a < 1e5 and math.isfinite(a)) else f"{value:.3e}"
    return str(value)


def cell(value, column: str, spec: str | None = None) -> str:
    """Format a cell of a difference or convergence table.

    The ``passed`` column is a verdict (pass/FAIL); ``delta_pct`` is undefined
    (``null`` in ``report.json``; ``"nan"`` in reports saved before) where its
    scale is zero at the comparison's resolution (a dash,
    :func:`harness.metrics.percent_scale`); other cells as :func:`fmt`.

    Parameters
    ----------
    value : object
        The cell.
    column : str
        Its column name.
    spec : str, optional
        A format spec for numbers.

    Returns
    -------
    str
    """
    column = column.split("|", 1)[0]
    if isinstance(value, bool):
        return "pass" if value else "FAIL"
    if column == "delta_pct" and (
        value is None or value in ("nan", "inf", "-inf") or (isinstance(value, float) and not math.isfinite(value))
    ):
        return "\u2013"
    return fmt(value, spec)


#: The verdict columns of the index and the case pages: verdict -> heading.
VERDICT_HEADINGS = {"flyable": "flyable", "tracking": "tracking", "engines_agree": "engines agree"}


def _shown(value, unit: str) -> str:
    if value is None:
        return "-"
    if unit == "rad":
        a = math.degrees(value)
        return f"{a:.2f}\u00b0" if abs(a) >= 0.01 or a == 0 else f"{fmt(a)}\u00b0"
    return f"{fmt(value)} {unit}".rstrip(" -")


def verdict_cells(model: dict) -> list[dict]:
    """Each verdict of a case model as a cell: its state and its worst figure.

    Parameters
    ----------
    model : dict
        A case model (:func:`reports.model.case_model`); a model saved before the verdicts gives dashes.

    Returns
    -------
    list of dict
        In :data:`VERDICT_HEADINGS` order: ``name``, ``heading``, ``state`` (``"pass"``, ``"fail"``,
        ``"recorded"``: failing, recorded by the scenario, or ``"n/a"``), ``worst`` (the worst
        violation, the largest tracking error after the settle time, the largest engine difference).
    """
    verdict = model.get("verdict") or {}
    verdicts = verdict.get("verdicts") or {}
    failures = verdict.get("failures") or []
    out = []
    for name, heading in VERDICT_HEADINGS.items():
        v = verdicts.get(name)
        if v is None or v.get("pass") is None:
            out.append(
                {"name": name, "heading": heading, "state": "n/a", "worst": ""}
            )  # not judged: the state's dash alone
            continue
        failing = any(f == name or f.startswith(name + ":") for f in failures)
        state = "pass" if v["pass"] else ("fail" if failing else "recorded")
        if name == "flyable":
            if v.get("infeasible"):
                worst = "no plan"
            else:
                viol = v.get("violations") or []
                worst = (
                    "; ".join(f"{x['name']} {_shown(x['worst'], x['unit'])} at t = {fmt(x['time'])} s" for x in viol)
                    or "within limits"
                )
        elif name == "tracking":
            worst = f"{_shown(v.get('max_error_after_settle_m'), 'm')} after {fmt(v.get('settle_s'))} s"
        else:
            d = v.get("differences") or {}
            many = len(d) > 1
            worst = (
                "; ".join(
                    f"{e + ': ' if many else ''}position {_shown(x.get('max_position_m'), 'm')}, "
                    f"angle {_shown(x.get('max_angle_rad'), 'rad')}"
                    for e, x in d.items()
                )
                or "-"
            )
            if v.get("incomplete"):
                worst = f"runs ended early: {', '.join(v['incomplete'])}; {worst}"
        out.append({"name": name, "heading": heading, "state": state, "worst": worst})
    return out


@functools.cache
def _environment():
    """This process's jinja2 environment of the report templates (made on first use; a forked worker inherits
    its parent's, with the templates it compiled: :func:`prepare`)."""
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("reports", "templates"),
        autoescape=jinja2.select_autoescape(("html",)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["fmt"] = fmt
    env.filters["cell"] = cell
    env.filters["header"] = header
    env.filters["shown_table"] = shown_table
    env.filters["text"] = text
    env.filters["setting"] = setting
    env.filters["quantity"] = quantity
    env.filters["deg"] = lambda rad: fmt(None if rad is None else math.degrees(rad))
    env.tests["text_column"] = lambda name: name in TEXT_COLUMNS
    env.filters["verdict"] = lambda ok: "PASS" if ok else "FAIL"
    env.filters["verdict_cells"] = verdict_cells
    env.filters["tojson_pretty"] = lambda obj: json.dumps(obj, indent=2, sort_keys=False)
    return env


def prepare() -> None:
    """Compile every HTML report template in this process (forked workers inherit them compiled).

    Each page rendered then costs its rendering only: :mod:`harness.commands.paper` calls it, with
    :func:`reports.figures.prepare`, while the first flights fly.
    """
    env = _environment()
    for name in env.list_templates(extensions=("html", "css")):
        env.get_template(name)


def _data_uri(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _figures(case_dir: Path, model: dict) -> list[Path]:
    """The figure files a case's model names, each confined to the run (:func:`harness.recorded.confined`)."""
    where = case_dir / REPORT_JSON
    out = []
    for f in model["figures"]:
        if not isinstance(f, dict) or not isinstance(f.get("file"), str):
            raise InputError(f"{where}: a figure entry {f!r} is not {{'file': NAME.png, 'caption': TEXT}}")
        path = confined(case_dir, f["file"], f"{where} names the figure")
        if not f["file"].endswith(".png"):
            raise InputError(f"{where}: a figure entry {f!r} is not {{'file': NAME.png, 'caption': TEXT}}")
        problem = file_problem(path)
        if problem is not None:
            raise InputError(f"{where}: its figure {f['file']} is {problem}")
        out.append(path)
    return out


def _run_file(root: Path, p: Path) -> bool:
    """``p`` is a regular file of the run, not a link (a link, even inside the run, is no file the run wrote)."""
    return not p.is_symlink() and p.is_file() and p.resolve().is_relative_to(root.resolve())


def _case_view(root: Path, folder: Path, model: dict, page_dir: Path, embed: bool) -> dict:
    """What a template needs of one case beyond its model: image sources, links, the data files (every path
    confined to the run ``root``, every link relative: :mod:`harness.recorded`)."""
    case_dir = root / folder
    src = {
        f["file"]: (_data_uri(p) if embed else href(p, page_dir))
        for f, p in zip(model["figures"], _figures(case_dir, model))
    }
    files = sorted(
        p
        for p in case_dir.iterdir()
        if _run_file(root, p) and not p.name.startswith(".") and p.suffix != ".png" and p.name not in RENDERED
    )
    # the plan beside the case (gflat paper: <scenario>/plan) or inside it (gflat compare), never outside the run
    plan_dir = next(
        (
            d
            for d in (case_dir / PLAN_FOLDER, case_dir.parent / PLAN_FOLDER)
            if d.is_dir() and not d.is_symlink() and d.resolve().is_relative_to(root.resolve())
        ),
        None,
    )
    plan_files = (
        sorted(p for p in plan_dir.iterdir() if _run_file(root, p) and not p.name.startswith(".")) if plan_dir else []
    )
    return {
        "model": model,
        "folder": folder.as_posix() or ".",
        "img": src,
        "page": href(case_dir / CASE_PAGE, page_dir),
        "files": [{"name": p.name, "href": href(p, page_dir)} for p in files],
        "plan_files": [{"name": f"{PLAN_FOLDER}/{p.name}", "href": href(p, page_dir)} for p in plan_files],
    }


#: Keys of a run's manifest the pages leave out: the folder's own bookkeeping (its files' checksums include the
#: pages), so that a page rendered before the run's commit and one rendered again later are the same.
UNSHOWN = ("tool", "command", "run_id", "files", "rendered_utc")


def _manifest(root: Path, given: dict | None):
    """What the pages show of the run's manifest: ``given``, else ``root/manifest.json`` (when there)."""
    p = root / "manifest.json"
    if given is None:
        if not p.is_file():
            return None
        given = read_json_object(p, "a gflat run manifest")
    if not isinstance(given.get("cases", []), list):
        raise InputError(f"{p}: not a gflat run manifest ('cases' is not a list)")
    shown = {k: v for k, v in given.items() if k not in UNSHOWN}
    if isinstance(shown.get("execution"), dict) and "cpu_s" in shown["execution"]:
        # measured after the pages are rendered: never on them, so that rendering them again gives the same
        shown["execution"] = {k: v for k, v in shown["execution"].items() if k != "cpu_s"}
    return shown


def _run_order(cases: list, manifest) -> list:
    """The cases in the order the run flew them (the manifest's ``cases``), the others after, as found."""
    flown = [
        (c.get("scenario"), c.get("loop"))
        for c in (manifest or {}).get("cases", [])
        if isinstance(c, dict) and isinstance(c.get("scenario"), str) and isinstance(c.get("loop"), str)
    ]
    rank = {key: i for i, key in reversed(list(enumerate(flown)))}
    return sorted(cases, key=lambda c: rank.get((c[1]["scenario"]["name"], c[1]["loop"]), len(rank)))


def render_date() -> str:
    """The current UTC time as the reports print it (ISO 8601, seconds).

    Returns
    -------
    str
    """
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def _run_context(root: Path, date: str | None, manifest: dict | None = None):
    """The run's case models in run order and what every page shows: date, manifest, counts."""
    cases = load_case_models(root)
    if not cases:
        raise InputError(
            f"no {REPORT_JSON} under {root}: not the output folder of a gflat run "
            f"(gflat paper --out DIR, gflat compare --out DIR)"
        )
    manifest = _manifest(root, manifest)
    cases = _run_order(cases, manifest)
    return cases, {
        "date": date or render_date(),
        "manifest": manifest,
        "n_pass": sum(m["passed"] for _, m in cases),
        "n": len(cases),
        "incomplete": None,
    }


def render_documents(
    run_dir: str | Path, *, date: str | None = None, embed: bool = False, manifest: dict | None = None
) -> dict[Path, str]:
    """The HTML documents of a run folder, as text (nothing written).

    Parameters
    ----------
    run_dir : str or Path
        A run folder holding ``report.json`` files (:func:`reports.model.write_case_report`).
    date : str, optional
        Render date printed on every page (default now, UTC).
    embed : bool
        Also render the single-file report (every case, images as data URIs).
    manifest : dict, optional
        The run's manifest the pages show (default ``run_dir/manifest.json``, when there; its
        :data:`UNSHOWN` keys are left out).

    Returns
    -------
    dict
        Path of each document -> its HTML: the index, every case page and, with
        ``embed``, the single-file report at the top of the run folder.

    Raises
    ------
    InputError
        No ``report.json`` under ``run_dir``.
    """
    root = Path(run_dir)
    cases, common = _run_context(root, date, manifest)
    env = _environment()
    docs = {}
    for folder, model in cases:  # every case's model through its own page first: a damaged one is named
        page_dir = root / folder
        with _model_errors(root, [folder]):
            view = _case_view(root, folder, model, page_dir, False)
            docs[page_dir / CASE_PAGE] = env.get_template("case.html").render(
                case=view, index=href(root / INDEX_PAGE, page_dir), **common
            )
    with _model_errors(root, [f for f, _ in cases]):
        index_views = [_case_view(root, f, m, root, False) for f, m in cases]
        docs = {root / INDEX_PAGE: _render(env.get_template("index.html"), root, index_views, common), **docs}
        if embed:
            views = [_case_view(root, f, m, root, True) for f, m in cases]
            docs[root / SINGLE_PAGE] = _render(env.get_template("single.html"), root, views, common)
    return docs


#: What a template or a view raises on a ``report.json`` whose inner structure is not a gflat report model's
#: (a key missing, a value of another type, a table row too short): named in one line, never a traceback.
def _model_error_types() -> tuple:
    import jinja2

    return (jinja2.TemplateError, KeyError, IndexError, TypeError, ValueError, AttributeError)


@contextlib.contextmanager
def _model_errors(root: Path, folders: list):
    """Turn an error of a damaged saved model met while rendering into one :class:`InputError` line naming its
    ``report.json`` (one case), or the run's (several: the culprit is not known)."""
    try:
        yield
    except InputError:
        raise
    except _model_error_types() as exc:
        where = (
            f"{Path(root) / folders[0] / REPORT_JSON}"
            if len(folders) == 1
            else f"a {REPORT_JSON} of the {len(folders)} cases under {root}"
        )
        raise InputError(
            f"{where}: not a gflat report model (cannot render it: {type(exc).__name__}: {describe(exc)}); "
            f"render it again with gflat compare/paper"
        ) from None


def _render(template, root: Path, views: list, common: dict, **extra) -> str:
    """``template`` rendered with ``cases=views``; on a damaged model, the case that fails alone is named."""
    try:
        return template.render(cases=views, **common, **extra)
    except _model_error_types():
        for v in views:
            with _model_errors(root, [Path(v["folder"])]):
                template.render(cases=[v], **common, **extra)
        raise


def _pdf_cases(root: Path, cases: list) -> list:
    """The cases of the PDF (in run order) as :func:`reports.pdf.run_view` takes them: a scenario's later cases
    print its plan once, "as in the first case" (``same_plan_as``)."""
    out, first = [], {}
    for folder, m in cases:
        case_dir = root / folder
        with _model_errors(root, [folder]):
            figures = dict(zip((f["file"] for f in m["figures"]), _figures(case_dir, m)))
            c = {"model": m, "root": root, "figures": figures, "report_json": str(case_dir / REPORT_JSON)}
            key = (m["scenario"]["name"], m["plan"]["J"], m["scenario"].get("toml"))
        if key in first:
            c["same_plan_as"] = first[key]
        else:
            first[key] = {"id": m["id"], "title": m["title"], "index": len(out)}
        out.append(c)
    return out


def pdf_view(run_dir: str | Path, *, date: str | None = None, manifest: dict | None = None) -> dict:
    """The run's PDF report as the JSON view its Typst template prints (:func:`reports.pdf.run_view`): title,
    contents with each case's page, summary, manifest, then each case on a new page.

    Parameters
    ----------
    run_dir : str or Path
        A run folder holding ``report.json`` files.
    date : str, optional
        Render date (default now, UTC).
    manifest : dict, optional
        As :func:`render_documents`.

    Returns
    -------
    dict
        The view (JSON data only: its strings are shown as text, its figures are paths inside ``run_dir``).

    Raises
    ------
    InputError
        No ``report.json`` under ``run_dir``, a damaged one (named), a figure that is no regular PNG file of
        the run.
    """
    from .pdf import run_view

    root = Path(run_dir)
    cases, common = _run_context(root, date, manifest)
    views = _pdf_cases(root, cases)
    try:
        with _model_errors(root, [f for f, _ in cases]):
            return run_view(views, common)
    except InputError:
        for folder, m in cases:  # the case that fails alone named
            with _model_errors(root, [folder]):
                run_view(_pdf_cases(root, [(folder, m)]), dict(common, n=1, n_pass=int(bool(m["passed"]))))
        raise


def render_run(
    run_dir: str | Path,
    *,
    self_contained: bool = False,
    pdf: bool = True,
    date: str | None = None,
    manifest: dict | None = None,
    progress=None,
) -> dict[str, Path]:
    """Render a run folder's reports: ``index.html``, a page per case, optionally the single file and the PDF.

    Parameters
    ----------
    run_dir : str or Path
        A run folder holding ``report.json`` files.
    self_contained : bool
        Also write the single-file ``report.html`` (images embedded) at the top of ``run_dir``.
    pdf : bool
        Also write ``report.pdf``, printed by Typst in this process (:func:`pdf_view`,
        :func:`reports.pdf.write_pdf`).
    date : str, optional
        Render date printed on every page (default now, UTC).
    manifest : dict, optional
        The run's manifest the pages show (:func:`render_documents`; a command renders before its commit writes
        ``manifest.json``).
    progress : harness.progress.Progress, optional
        The HTML pages and the PDF are stages.

    Returns
    -------
    dict
        ``"index"``, ``"pages"`` (list), and ``"single"``/``"pdf"`` when written -> Path.

    Raises
    ------
    InputError
        No ``report.json`` under ``run_dir``, a damaged one, a figure outside the run, or a PDF Typst could not
        print (one line).
    """
    root = Path(run_dir)
    date = date or render_date()
    with stage(progress, "writing the HTML pages"):
        docs = render_documents(root, date=date, embed=self_contained, manifest=manifest)
        for path, text in docs.items():
            write_text(path, text)
    out = {"index": root / INDEX_PAGE, "pages": [p for p in docs if p.name == CASE_PAGE]}
    if self_contained:
        out["single"] = root / SINGLE_PAGE
    if pdf:
        from .pdf import write_pdf

        with stage(progress, f"writing {PDF_FILE}"):
            out["pdf"] = write_pdf(pdf_view(root, date=date, manifest=manifest), root, root / PDF_FILE)
    return out
