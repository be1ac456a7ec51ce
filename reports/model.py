"""The report model of a validation case: a JSON-serialisable dict built from result objects.

:func:`case_model` gathers what a report page shows -- the scenario (its TOML
text), the plan summary and convergence table, the singularity monitor, run
status and settings, difference tables against the reference engine and
against the plan, warnings, the verdict, provenance, and the figures of the
case folder -- from a :class:`harness.validation.CaseResult`, never by flying
anything again.  :func:`write_case_report` draws the report's own figures
(:mod:`reports.report_figures`) and saves the model as ``report.json`` in the
case folder, from which :mod:`reports.html` renders, now or later.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from gna.errors import InputError, describe, writing
from harness.artefacts import json_safe as _json_safe
from harness.artefacts import read_manifest
from planners.scenario import load_scenario

from .figures import recorded_axes
from .report_figures import control_limits, write_singularity_figure

#: Version of the model's layout (bumped when keys change meaning).
SCHEMA = 1

#: File name of a case's saved model.
REPORT_JSON = "report.json"

#: Keys a saved model must have (with their types) for the pages to render.
MODEL_KEYS = {
    "schema": int,
    "title": str,
    "id": str,
    "loop": str,
    "engines": list,
    "passed": bool,
    "settings": dict,
    "scenario": dict,
    "plan": dict,
    "runs": dict,
    "tables": dict,
    "figures": list,
    "warnings": list,
    "provenance": dict,
}

#: Most figures a saved model may name (a case draws at most :data:`FIGURES`' few): a received ``report.json``
#: naming thousands would make pages of tens of megabytes.
MAX_FIGURES = 64

#: Largest ``report.json`` or ``manifest.json`` read back [bytes] (a case's model is some tens of kilobytes).
MAX_JSON_BYTES = 64 * 1024 * 1024

#: Figures a case page shows, in order: file name -> caption (those present in the case folder).
FIGURES: dict[str, str] = {
    "tracking.png": "The paper's four curves: flat plan J = 0 (red), closed loop (dark blue; the controls with "
    "their feedback part), generalized plan (green), generalized controls open loop (cyan); bottom right, the "
    "distance to the flat outputs.",
    "states.png": "Ground track (north up, equal scales), altitude h = -z, distance to the plan and the states of "
    "every engine; the plan dotted.",
    "controls.png": "Applied controls (each engine's thrust, eta, surfaces); the plan dotted, the aircraft's "
    "limits dash-dotted in red.",
    "differences.png": "Absolute differences to the reference engine (log scale), the tolerances dotted in red.",
    "singularity.png": "Singularity monitor along the flat plan: a zero or a sign change is a singularity.",
}


def json_safe(obj):
    """A copy of ``obj`` for a report model: :func:`harness.artefacts.json_safe` (NaN and infinities as null).

    Parameters
    ----------
    obj : object
        Nested dicts, lists, tuples, numpy scalars and arrays, paths, dataclasses.

    Returns
    -------
    object
        Plain JSON types; a non-finite float (an undefined ``delta_pct``, a
        diverged run's difference) becomes ``None`` (``null``), as in
        ``summary.json`` and ``--json`` outputs.
    """
    return _json_safe(obj)


def _records(frame) -> dict:
    """A DataFrame as ``{"columns": [...], "rows": [[...], ...]}`` (index first)."""
    flat = frame.reset_index()
    return {"columns": [str(c) for c in flat.columns], "rows": json_safe(flat.to_numpy(dtype=object).tolist())}


def _table(tab, engine: str, window: str) -> dict:
    return {
        "engine": engine,
        "window": window,
        "labels": list(tab.labels),
        "span": list(tab.window),
        "samples": tab.samples,
        "notes": list(tab.notes),
        "passed": tab.passed,
        "informative": all(r.tolerance is None for r in tab.rows),
        **_records(tab.to_frame()),
    }


def _scenario_section(result, scenario) -> dict:
    text = Path(scenario.path).read_text(encoding="utf-8") if scenario.path else ""
    plan = result.plan
    return {
        "name": scenario.name,
        "description": scenario.description.strip(),
        "aircraft": {"id": plan.aircraft.id, "name": plan.aircraft.name},
        "flat_outputs": {str(k): str(v) for k, v in scenario.raw.get("flat_outputs", {}).items()},
        "span_s": [plan.t0, plan.t1],
        "node_step_s": scenario.step,
        "file": Path(scenario.path).name if scenario.path else None,
        "toml": text,
    }


def _plan_section(result, scenario) -> dict:
    plan = result.plan
    times, variables = scenario.report_times or [plan.t0], scenario.report_variables or ("F", "dl", "dm", "dn")
    sing = plan.singularities
    return {
        "J": plan.J,
        "nodes": len(plan.t_nodes),
        "flat_output": plan.problem.zeta.kind,
        "orders": [it.order for it in plan.iterates],
        "feasible": plan.feasible,
        "worst_newton_residual": plan.worst_newton_residual(),
        "timings_s": dict(plan.timings),
        "planning_time_s": result.planning_time_s,
        "warnings": list(plan.warnings),
        "convergence": _records(plan.convergence_table(variables, times)),
        "singularity": None if sing is None else {"condition": sing.condition, "warnings": list(sing.warnings)},
    }


def _runs_section(result) -> dict:
    out = {}
    for label, res in result.runs.items():
        settings = json_safe(res.settings)
        if isinstance(settings.get("extra"), dict):
            settings["extra"].pop("wall_time_s", None)  # machine load, not a setting
        out[label] = {
            "status": res.status,
            "message": res.message,
            "t_end": res.t_end,
            "warnings": list(res.warnings),
            "settings": settings,
        }
    return out


_PLAN_PREFIX = re.compile(r"^plan \(j = (\d+)\): ")


def _plan_source(text: str, J: int) -> str:
    m = _PLAN_PREFIX.match(text)
    return f"plan (iterate j = {m.group(1) if m else J})"


def _plan_text(text: str) -> str:
    return _PLAN_PREFIX.sub("", text, count=1)


def merged_warnings(said) -> list[str]:
    """Warnings as a reader reads them: each text once, after every source that gave it.

    Parameters
    ----------
    said : sequence of (str, str)
        (source, text) pairs in order (the plan, each engine, each difference table).

    Returns
    -------
    list of str
        ``"<source>, <source>: <text>"`` in the order each text first appears.
    """
    sources: dict[str, list[str]] = {}
    for source, text in said:
        who = sources.setdefault(text, [])
        if source not in who:
            who.append(source)
    return [f"{', '.join(who)}: {text}" for text, who in sources.items()]


def case_model(result, figures=(), *, scenario=None) -> dict:
    """The report model of one validation case.

    Parameters
    ----------
    result : harness.validation.CaseResult
        The case's plan, runs, difference tables and provenance.
    figures : sequence of str or dict
        The figures in the case folder, shown in the order of :data:`FIGURES`: file names, or entries
        ``{"file": NAME, "axes": [LABEL, ...]}`` with the label (``"name [unit]"``) of each of their axes.
    scenario : planners.scenario.Scenario, optional
        The loaded scenario (its file text, flat outputs, report times); loaded
        again from ``result.case.scenario`` when not given (parsing only).

    Returns
    -------
    dict
        JSON-serialisable (:func:`json_safe`): ``schema``, ``title``, ``loop``,
        ``engines``, ``reference_engine``, ``passed``, ``verdict``, ``settings``
        (tolerances, windows, output grid, JSBSim step and where each came
        from), ``scenario``, ``plan``, ``runs``, ``tables`` (between engines,
        against the plan, JSBSim self-convergence),
        ``limits``, ``closed_loop``, ``warnings``, ``figures``, ``provenance``.
    """
    plan, case = result.plan, result.case
    if scenario is None:
        scenario = getattr(result, "scenario", None) or load_scenario(case.scenario, J=case.J)
    verdict = result.verdict()
    tables = [_table(t, eng, w) for eng, per in result.tables.items() for w, t in per.items()]
    vs_plan = [_table(t, eng, "whole span") for eng, t in result.vs_plan.items()]
    self_conv = [
        _table(t, eng, w) for eng, per in getattr(result, "self_convergence", {}).items() for w, t in per.items()
    ]
    settings = (
        result.settings.to_dict()
        if getattr(result, "settings", None) is not None
        else {"tolerances": case.tolerance_spec, "windows": case.window_spec, "dt_out": case.dt_out}
    )
    said = [(_plan_source(w, plan.J), _plan_text(w)) for w in plan.warnings]
    for label, res in result.runs.items():
        if res.status != "completed":
            said.append((label, f"run {res.status}{(': ' + res.message) if res.message else ''}"))
        said += [(label, w) for w in res.warnings]
    said += [(f"{t['labels'][1]} - {t['labels'][0]} ({t['window']})", n) for t in tables for n in t["notes"]]
    warnings = merged_warnings(said)
    closed = None
    if result.closed_loop is not None:
        ctl = result.closed_loop.controller
        closed = {
            "design": getattr(ctl, "design", "paper"),
            "feedforward_iterate": result.closed_loop.feedforward_iterate,
            "lambdas": [list(x) for x in getattr(ctl, "lambdas", ())],
            "saturated_s": result.saturated_s(),
        }
    given = {}
    for f in figures:
        entry = f if isinstance(f, dict) else {"file": str(f)}
        given[str(entry["file"])] = list(entry.get("axes") or [])
    shown = [{"file": f, "caption": c, "axes": given[f]} for f, c in FIGURES.items() if f in given]
    model = {
        "schema": SCHEMA,
        "title": f"{plan.name} (J = {plan.J}), {case.loop} loop",
        "id": f"{plan.name}-{case.loop}",
        "loop": case.loop,
        "engines": list(result.runs),
        "reference_engine": result.reference_engine,
        "passed": bool(verdict["pass"]),
        "verdict": verdict,
        "settings": settings,
        "scenario": _scenario_section(result, scenario),
        "plan": _plan_section(result, scenario),
        "runs": _runs_section(result),
        "tables": {"engines": tables, "plan": vs_plan, "self_convergence": self_conv},
        "limits": control_limits(plan.aircraft),
        "closed_loop": closed,
        "warnings": warnings,
        "figures": shown,
        "provenance": dict(result.provenance),
    }
    return json_safe(model)


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` (UTF-8, ``\\n`` line ends), its folder made.

    Parameters
    ----------
    path : str or Path
        Destination.
    text : str
        Content.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    with writing(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8", newline="\n")
    return path


def write_case_report(result, out, *, figures=(), scenario=None) -> Path:
    """Draw the report's figures into a case folder and save the case's model as ``report.json``.

    Parameters
    ----------
    result : harness.validation.CaseResult
        The case's result.
    out : str or Path
        The case folder (created if needed).
    figures : sequence of str
        File names of the figures already in the folder (:func:`reports.case_files.write_case`).
    scenario : planners.scenario.Scenario, optional
        See :func:`case_model`.

    Returns
    -------
    Path
        The ``report.json`` written.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    drawn = write_singularity_figure(result.plan, out)
    names = list(map(str, figures)) + ([drawn.name] if drawn is not None else [])
    entries = [{"file": n, "axes": recorded_axes(out / n) or []} for n in names]
    text = json.dumps(case_model(result, entries, scenario=scenario), indent=1, allow_nan=False) + "\n"
    return write_text(out / REPORT_JSON, text)


def _no_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def read_json_object(path: str | Path, what: str) -> dict:
    """Read a JSON object a run saved (``report.json``, ``manifest.json``), refusing anything else in one line.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What it should be, for the message (``"a gflat report model"``).

    Returns
    -------
    dict

    Raises
    ------
    InputError
        ``<path>: not <what> (<cause>)``: unreadable, invalid or truncated JSON, a ``NaN`` or ``Infinity``
        (not JSON), or a JSON value that is not an object.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_JSON_BYTES:
            raise InputError(f"{path}: not {what} ({size} bytes, above the bound of {MAX_JSON_BYTES} bytes)")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read it: {describe(exc)}") from None
    try:
        obj = json.loads(text, parse_constant=_no_constant)
    except ValueError as exc:
        cause = f"invalid JSON: {exc}" if not str(exc).endswith("not a JSON number") else str(exc)
        raise InputError(f"{path}: not {what} ({cause})") from None
    except RecursionError:
        raise InputError(f"{path}: not {what} (invalid JSON: nested too deeply)") from None
    if not isinstance(obj, dict):
        kind = {list: "array", str: "string", bool: "boolean", type(None): "null"}.get(type(obj), "number")
        raise InputError(f"{path}: not {what} (a JSON {kind}, not an object)")
    return obj


def run_files(root: str | Path, name: str) -> list[Path]:
    """The files called ``name`` under a run folder; when its ``manifest.json`` lists the run's files, only those.

    Parameters
    ----------
    root : str or Path
        A run folder (or a staging folder being written).
    name : str
        File name (``"report.json"``).

    Returns
    -------
    list of Path
        In a stable order (sorted); symbolic links are not followed.
    """
    root = Path(root)
    listed = _listed(root)
    found = []
    for here, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not os.path.islink(os.path.join(here, d)))
        p = Path(here) / name
        if name in files and not p.is_symlink() and (listed is None or p.relative_to(root).as_posix() in listed):
            found.append(p)
    return found


def _listed(root: Path) -> set | None:
    """The files a gflat run's ``manifest.json`` in ``root`` lists (None: no such manifest)."""
    data = read_manifest(root)
    if data is None or not isinstance(data.get("files"), list):
        return None
    return {f["path"] for f in data["files"] if isinstance(f, dict) and isinstance(f.get("path"), str)}


def load_case_model(path: str | Path) -> dict:
    """One saved case model, checked as :func:`load_case_models` checks each.

    Parameters
    ----------
    path : str or Path
        A case's ``report.json``.

    Returns
    -------
    dict

    Raises
    ------
    InputError
        As :func:`load_case_models`.
    """
    p = Path(path)
    model = read_json_object(p, "a gflat report model")
    bad = [k for k, t in MODEL_KEYS.items() if not isinstance(model.get(k), t)]
    if "scenario" not in bad and not isinstance(model["scenario"].get("name"), str):
        bad.append("scenario.name")  # the run's pages order and name the cases by it
    if not bad and len(model["figures"]) > MAX_FIGURES:
        raise InputError(
            f"{p}: not a gflat report model ({len(model['figures'])} figures, above the bound of {MAX_FIGURES}); "
            f"render it again with gflat compare/paper"
        )
    if bad:
        raise InputError(
            f"{p}: not a gflat report model (missing or wrong type: {', '.join(bad)}); "
            f"render it again with gflat compare/paper"
        )
    return model


def load_case_models(run_dir: str | Path) -> list[tuple[Path, dict]]:
    """The saved case models under a run folder, in a stable order (scenario folder, then open before closed).

    Parameters
    ----------
    run_dir : str or Path
        A run's output folder (``gflat paper --out``, ``gflat compare --out``).

    Returns
    -------
    list of (Path, dict)
        Case folder relative to ``run_dir``, and its model.

    Raises
    ------
    InputError
        A ``report.json`` that cannot be read, is not a JSON object (:func:`read_json_object`) or lacks a key
        the pages need (naming the file and the cause).  Only the files the run's manifest lists are read
        (:func:`run_files`).
    """
    root = Path(run_dir)
    found = [(p.parent.relative_to(root), load_case_model(p)) for p in run_files(root, REPORT_JSON)]
    order = {"open": 0, "closed": 1}
    found.sort(key=lambda item: (item[0].parent.as_posix(), order.get(item[1].get("loop"), 2), item[0].as_posix()))
    return found
