"""A validation case's output folder: figures, trajectories, the difference report, the JSON summary."""

from __future__ import annotations

from pathlib import Path

from harness.artefacts import write_artefacts
from harness.progress import stage

from .figures import write_figures
from .model import write_case_report
from .tracking import write_tracking_figure

#: Figure files of a case folder (``tracking.png`` closed loop only, ``differences.png`` with two engines or more;
#: the report adds ``singularity.png``, :mod:`reports.model`).
FIGURES: tuple[str, ...] = ("states.png", "controls.png", "differences.png", "tracking.png")


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


def write_case(
    result,
    out_dir: str | Path,
    *,
    csv: bool = False,
    plan: bool = True,
    manifest: bool = True,
    command_line: list | None = None,
    progress=None,
) -> dict[str, Path | list[Path]]:
    """Write a case's figures and data (:func:`harness.artefacts.write_artefacts`) to a folder.

    Parameters
    ----------
    result : harness.validation.CaseResult
        A case's result (runs, tables, plan, provenance).
    out_dir : str or Path
        Folder (made with its parents when missing).
    csv : bool
        Also write the trajectories as CSV.
    plan : bool
        Write the plan of every iterate under ``plan/``.
    manifest : bool
        Write ``manifest.json`` in the folder.
    command_line : list of str, optional
        The command recorded in the manifest (default ``sys.argv``).
    progress : harness.progress.Progress, optional
        Each figure drawn is a stage (:func:`reports.figures.write_figures`), and the case's files and report.

    Returns
    -------
    dict
        ``"figures"``, ``"trajectories"``, ``"plan"`` -> list of Path;
        ``"differences"``, ``"summary"``, ``"report"`` (the report model,
        :func:`reports.model.write_case_report`) and (with ``manifest``) ``"manifest"`` -> Path.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tol = result.settings.tolerances if result.settings is not None else result.case.tolerance_spec
    figures = write_figures(
        result.runs,
        out,
        reference=result.reference_frame(),
        title=case_title(result),
        tolerances=tol,
        aircraft=result.plan.aircraft,
        progress=progress,
    )
    title = case_title(result)
    if result.closed_loop is not None:
        with stage(progress, f"drawing tracking.png of {title}"):
            figures.append(write_tracking_figure(result, out))
    with stage(progress, f"writing the trajectories and tables of {title}"):
        files = write_artefacts(
            result,
            out,
            csv=csv,
            plan=plan,
            manifest=manifest,
            figures=[p.name for p in figures],
            command_line=command_line,
        )
    with stage(progress, f"writing the report model of {title}"):
        report = write_case_report(result, out, figures=[p.name for p in figures])
    written: dict[str, Path | list[Path]] = {
        "figures": figures,
        "trajectories": files["trajectories"],
        "plan": files["plan"],
        "differences": files["differences"][0],
        "summary": files["summary"][0],
        "report": report,
    }
    if "manifest" in files:
        written["manifest"] = files["manifest"][0]
    return written
