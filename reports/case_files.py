"""A validation case's output folder: figures, the difference report, the JSON summary."""

from __future__ import annotations

import json
from pathlib import Path

from .figures import write_figures
from .model import write_case_report
from .tracking import write_tracking_figure


def case_title(result) -> str:
    """Heading of a case's figures, e.g. ``"gtm-forward-slip (J = 4), open loop"``.

    Parameters
    ----------
    result : harness.validation.CaseResult
        A case's result.

    Returns
    -------
    str
        Scenario name, J and loop kind.
    """
    return f"{result.plan.name} (J = {result.plan.J}), {result.case.loop} loop"


def write_case(result, out_dir: str | Path) -> dict[str, Path | list[Path]]:
    """Write a case's figures, ``differences.txt``, ``summary.json`` and ``report.json`` to ``out_dir``.

    Parameters
    ----------
    result : harness.validation.CaseResult
        A case's result (runs, tables, plan, provenance).
    out_dir : str or Path
        Folder, created if needed.

    Returns
    -------
    dict
        ``"figures"`` -> list of Path, ``"differences"``, ``"summary"`` and ``"report"``
        (the report model, :func:`reports.model.write_case_report`) -> Path.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = write_figures(result.runs, out, reference=result.reference_frame(), title=case_title(result),
                            tolerances=result.case.tolerance_spec)
    if result.closed_loop is not None:
        figures.append(write_tracking_figure(result, out))
    diff = out / "differences.txt"
    diff.write_text(result.report_text() + "\n", encoding="utf-8")
    summary = dict(result.summary(figures), provenance=result.provenance)
    if result.closed_loop is not None:
        summary.update(loop="closed", verdict=result.verdict(), saturated_s=result.saturated_s(),
                       feedforward_iterate=result.closed_loop.feedforward_iterate)
    js = out / "summary.json"
    js.write_text(json.dumps(summary, indent=2, default=float))
    return {"figures": figures, "differences": diff, "summary": js, "report": write_case_report(result, out)}
