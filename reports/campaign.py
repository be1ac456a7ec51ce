"""The campaign report page (HTML by jinja2, its PDF by Typst) from a campaign's summary, in the run reports' style.

:func:`render_campaign` writes ``DIR/report/index.html`` (pass rate, the
figures of :func:`harness.campaign.report.write_report`, per case group the
distributions, the worst cases linked to their pages, what the error follows),
one page per listed case under ``DIR/report/cases/`` (metrics, parameters,
dispersed values, links to the trajectories) and ``report.pdf``.
"""

from __future__ import annotations

from pathlib import Path

from harness.recorded import safe_name

from .html import _environment, render_date
from .model import write_text

__all__ = ["render_campaign", "FIGURES"]

#: Figures of a campaign report, with their captions, in page order.
FIGURES: tuple[tuple[str, str], ...] = (
    ("pass_rate.png", "Samples per cause in each case group"),
    ("max_position_error_m.png", "Largest distance to the flat outputs"),
    ("saturated_s.png", "Time with a control commanded beyond its limits"),
    ("engine_differences.png", "Engine differences"),
    ("correlations.png", "Which dispersed parameter the error follows"),
)


def render_campaign(
    folder: str | Path,
    summary: dict,
    rows: list,
    *,
    target: str | Path | None = None,
    pdf: bool = True,
    date: str | None = None,
) -> dict:
    """Render the campaign page, the pages of its worst and failed cases, and the PDF.

    Parameters
    ----------
    folder : str or Path
        The campaign folder.
    summary : dict
        :func:`harness.campaign.report.campaign_summary`.
    rows : list of dict
        The stored cases (:meth:`harness.campaign.store.CampaignStore.rows`).
    target : str or Path, optional
        The report folder holding the figures, where the pages go (default ``folder/report``; ``gflat campaign
        report`` gives its staging folder, put in place of ``report/`` whole); it sits in ``folder``.
    pdf : bool
        Also write ``report.pdf``, printed by Typst (:func:`reports.pdf.campaign_view`,
        :func:`reports.pdf.write_pdf`).
    date : str, optional
        Render date (default now, UTC).

    Returns
    -------
    dict
        ``"index"``, ``"pages"`` (list) and ``"pdf"`` when written -> Path.
    """
    folder = Path(folder)
    out = Path(target) if target is not None else folder / "report"
    date = date or render_date()
    env = _environment()
    pending = summary["counts"]["pending"]
    incomplete = f"{pending} case(s) of the campaign not run yet" if pending else None
    by_id = {r["case_id"]: r for r in rows}
    listed = {w["case_id"]: key for key, g in summary["groups"].items() for w in g["worst"]}
    listed.update({cid: "failed" for cid in summary["failed"]})
    pages = []
    for cid, group in listed.items():
        page = out / "cases" / f"{safe_name(cid, 'case id')}.html"  # a page never written outside the report
        page.parent.mkdir(parents=True, exist_ok=True)
        html = env.get_template("campaign_case.html").render(
            c=by_id[cid], group=group, date=date, data_dir=f"../../cases/{cid}", incomplete=incomplete
        )
        write_text(page, html)
        pages.append(page)
    groups = []
    for key, g in summary["groups"].items():
        worst = [dict(w, href=f"cases/{w['case_id']}.html") for w in g["worst"]]
        groups.append(dict(g, key=key, worst=worst))
    camp = summary.get("campaign") or {}
    n_done = summary["counts"]["done"]
    context = dict(
        name=camp.get("name", folder.name),
        seed=camp.get("seed"),
        description=summary.get("description", ""),
        counts=summary["counts"],
        n_done=n_done,
        n_pass=sum(g["passed"] for g in groups),
        groups=groups,
        failed=summary["failed"],
        date=date,
        pdf=pdf,
        incomplete=incomplete,
        figures=[{"src": f, "alt": alt} for f, alt in FIGURES if (out / f).exists()],
    )
    index = out / "index.html"
    write_text(index, env.get_template("campaign.html").render(**context))
    result = {"index": index, "pages": pages}
    if pdf:
        from .pdf import campaign_view, write_pdf

        result["pdf"] = write_pdf(campaign_view(context, out), out, out / "report.pdf")
    return result
