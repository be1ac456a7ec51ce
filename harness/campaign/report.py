"""The campaign report: a JSON summary, figures, an HTML page and a PDF, in ``DIR/report``.

:func:`campaign_summary` reads the store (pass rate per case, distributions of
the tracking error, saturation time and engine differences, the worst cases,
and the Spearman rank correlation of the reference engine's tracking error with
every dispersed parameter); :func:`write_report` writes ``summary.json``, the
figures (PNG, and all of them in ``report.pdf``) and renders the page with
:func:`render_campaign`, the hook through which the reports package's HTML/PDF
rendering takes over when it offers a campaign page.
"""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np

from .store import CampaignStore

__all__ = ["campaign_summary", "write_report", "render_campaign"]

#: Worst cases listed per case label.
N_WORST = 5


def _ranks(v: np.ndarray) -> np.ndarray:
    order = np.argsort(v, kind="mergesort")
    r = np.empty(len(v))
    r[order] = np.arange(len(v))
    for val in np.unique(v):           # average ranks of ties
        tie = v == val
        if tie.sum() > 1:
            r[tie] = r[tie].mean()
    return r


def _spearman(x: np.ndarray, y: np.ndarray) -> float | None:
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 3 or np.ptp(x[ok]) == 0 or np.ptp(y[ok]) == 0:
        return None
    rho = np.corrcoef(_ranks(x[ok]), _ranks(y[ok]))[0, 1]
    return float(rho) if math.isfinite(rho) else None


def _stats(values) -> dict:
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return {"n": 0}
    return {"n": int(v.size), "min": float(v.min()), "median": float(np.median(v)), "p90": float(np.quantile(v, 0.9)),
            "max": float(v.max())}


def campaign_summary(folder: str | Path) -> dict:
    """Summary of a campaign folder.

    Parameters
    ----------
    folder : str or Path
        A campaign folder (:class:`harness.campaign.store.CampaignStore`).

    Returns
    -------
    dict
        ``campaign`` (name, seed), ``counts`` (cases, done, failed, pending),
        ``groups``: per case label and dispersion, ``n``, ``passed``,
        ``pass_rate``, ``status`` (engine -> run status -> count),
        ``tracking_error_m`` / ``saturated_s`` (engine -> min, median, p90,
        max), ``engine_difference_m`` (engine -> stats of the position
        difference from the reference), ``worst`` (the cases of largest
        reference tracking error), ``correlations`` (``[parameter, rho]``
        pairs: Spearman rho with the reference engine's tracking error,
        largest magnitude first);
        ``failed`` (case id -> first line of the error).
    """
    st = CampaignStore(folder)
    try:
        meta, counts, rows = st.meta(), st.counts(), st.rows()
    finally:
        st.close()
    groups: dict[str, list] = {}
    for r in rows:
        if r["status"] == "done":
            groups.setdefault(f"{r['label']}.{r['dispersion']}", []).append(r)
    out_groups = {}
    for key, rs in groups.items():
        engines = rs[0]["params"]["engines"]
        ref = engines[0]
        g = {"scenario": rs[0]["params"]["scenario"], "loop": rs[0]["params"]["loop"], "engines": engines,
             "n": len(rs), "passed": sum(bool(r["pass"]) for r in rs)}
        g["pass_rate"] = g["passed"] / g["n"]
        g["status"] = {e: {} for e in engines}
        for r in rs:
            for e, run in r["metrics"]["runs"].items():
                g["status"][e][run["status"]] = g["status"][e].get(run["status"], 0) + 1
        g["tracking_error_m"] = {e: _stats(r["metrics"]["runs"][e]["max_position_error_m"] for r in rs)
                                 for e in engines}
        g["saturated_s"] = {e: _stats(r["metrics"]["runs"][e]["saturated_s"] for r in rs) for e in engines}
        g["engine_difference_m"] = {e: _stats(r["metrics"]["differences"][e]["max_position_m"] for r in rs)
                                    for e in engines[1:]}
        err = np.array([r["metrics"]["runs"][ref]["max_position_error_m"] or np.nan for r in rs], dtype=float)
        order = np.argsort(np.where(np.isfinite(err), -err, np.inf))[:N_WORST]
        g["worst"] = [{"case_id": rs[i]["case_id"], "seed": rs[i]["seed"], "pass": bool(rs[i]["pass"]),
                       "tracking_error_m": None if not math.isfinite(err[i]) else float(err[i]),
                       "status": {e: run["status"] for e, run in rs[i]["metrics"]["runs"].items()}} for i in order]
        params = sorted({k for r in rs for k in (r["draw"] or {})})
        corr = {}
        for p in params:
            x = np.array([(r["draw"] or {}).get(p, np.nan) for r in rs], dtype=float)
            rho = _spearman(x, err)
            if rho is not None:
                corr[p] = rho
        g["correlations"] = [[p, rho] for p, rho in sorted(corr.items(), key=lambda kv: -abs(kv[1]))]
        out_groups[key] = g
    failed = {r["case_id"]: (r["error"] or "").splitlines()[0] for r in rows if r["status"] == "failed"}
    return {"campaign": meta.get("campaign"), "counts": counts, "groups": out_groups, "failed": failed}


def _figures(folder: Path, summary: dict, rows: list, outdir: Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages
    paths = []
    groups = summary["groups"]
    by_group: dict[str, list] = {}
    for r in rows:
        if r["status"] == "done":
            by_group.setdefault(f"{r['label']}.{r['dispersion']}", []).append(r)
    figs = []
    fig, ax = plt.subplots(figsize=(7, 3.2))
    keys = list(groups)
    ax.bar(range(len(keys)), [100 * groups[k]["pass_rate"] for k in keys], color="#3a7")
    ax.set_xticks(range(len(keys)), keys, rotation=15, fontsize=8)
    ax.set_ylabel("pass rate [%]")
    ax.set_ylim(0, 100)
    ax.set_title("Cases passing (runs complete, engines within tolerances)")
    figs.append(("pass_rate.png", fig))
    for metric, title, unit in (("max_position_error_m", "Largest distance to the flat outputs", "m"),
                                ("saturated_s", "Time with a control commanded beyond its limits", "s")):
        fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * max(len(keys), 1), 3), squeeze=False)
        for ax, k in zip(axes[0], keys):
            for e in groups[k]["engines"]:
                v = [r["metrics"]["runs"][e][metric] for r in by_group[k]]
                v = [x for x in v if x is not None and math.isfinite(x)]
                if v:
                    ax.hist(v, bins=min(20, max(3, len(v))), alpha=0.6, label=e,
                            log=metric == "max_position_error_m" and max(v) > 100 * (min(v) + 1e-12))
            ax.set_title(k, fontsize=8)
            ax.set_xlabel(f"[{unit}]")
            ax.legend(fontsize=7)
        fig.suptitle(title, fontsize=9)
        fig.tight_layout()
        figs.append((f"{metric}.png", fig))
    fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * max(len(keys), 1), 3), squeeze=False)
    for ax, k in zip(axes[0], keys):
        for e in groups[k]["engines"][1:]:
            v = [r["metrics"]["differences"][e]["max_position_m"] for r in by_group[k]]
            v = [x for x in v if x is not None and math.isfinite(x) and x > 0]
            if v:
                ax.hist(np.log10(v), bins=min(20, max(3, len(v))), alpha=0.7, label=f"{e} - {groups[k]['engines'][0]}")
        ax.set_title(k, fontsize=8)
        ax.set_xlabel("log10 max position difference [m]")
        ax.legend(fontsize=7)
    fig.suptitle("Engine differences", fontsize=9)
    fig.tight_layout()
    figs.append(("engine_differences.png", fig))
    fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * max(len(keys), 1), 3.2), squeeze=False)
    for ax, k in zip(axes[0], keys):
        top = groups[k]["correlations"][:8]
        ax.barh([p for p, _ in top][::-1], [v for _, v in top][::-1], color="#48c")
        ax.set_xlim(-1, 1)
        ax.set_title(k, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("Spearman rho with the tracking error")
    fig.suptitle("Which dispersed parameter the error follows", fontsize=9)
    fig.tight_layout()
    figs.append(("correlations.png", fig))
    with PdfPages(outdir / "report.pdf") as pdf:
        for name, fig in figs:
            fig.savefig(outdir / name, dpi=110)
            pdf.savefig(fig)
            plt.close(fig)
            paths.append(outdir / name)
    paths.append(outdir / "report.pdf")
    return paths


def _worst_row(w: dict) -> str:
    e = html.escape
    err = "-" if w["tracking_error_m"] is None else f"{w['tracking_error_m']:.3g}"
    runs = ", ".join(f"{k}: {v}" for k, v in w["status"].items())
    return (f'<tr><td><a href="../cases/{e(w["case_id"])}/">{e(w["case_id"])}</a></td><td>{w["seed"]}</td>'
            f"<td>{err}</td><td>{e(runs)}</td><td>{'pass' if w['pass'] else 'FAIL'}</td></tr>")


def render_campaign(folder: str | Path, summary: dict | None = None) -> Path:
    """Render the campaign page ``DIR/report/index.html`` (figures beside it, worst cases linked).

    The hook for the reports package: a self-contained page written here until
    :mod:`reports.html` offers a campaign template.

    Parameters
    ----------
    folder : str or Path
        The campaign folder (its ``report/`` holds the figures of :func:`write_report`).
    summary : dict, optional
        :func:`campaign_summary` (computed when not given).

    Returns
    -------
    Path
        The page written.
    """
    folder = Path(folder)
    s = summary if summary is not None else campaign_summary(folder)
    e = html.escape
    c = s["counts"]
    camp = s.get("campaign") or {}
    parts = [f"<h1>Campaign {e(str(camp.get('name', folder.name)))}</h1>",
             f"<p>seed {e(str(camp.get('seed')))}: {c['cases']} cases, {c['done']} done, {c['failed']} failed, "
             f"{c['pending']} pending.</p>"]
    for img, alt in (("pass_rate.png", "pass rate per case"), ("max_position_error_m.png", "tracking error"),
                     ("saturated_s.png", "saturation time"), ("engine_differences.png", "engine differences"),
                     ("correlations.png", "correlations with the dispersed parameters")):
        if (folder / "report" / img).exists():
            parts.append(f'<figure><img src="{img}" alt="{e(alt)}"><figcaption>{e(alt)}</figcaption></figure>')
    for key, g in s["groups"].items():
        parts.append(f"<h2>{e(key)}</h2><p>{e(g['scenario'])}, {e(g['loop'])} loop, engines "
                     f"{e(', '.join(g['engines']))}: {g['passed']} of {g['n']} pass "
                     f"({100 * g['pass_rate']:.0f} %).</p>")
        rows = "".join(_worst_row(w) for w in g["worst"])
        parts.append("<table><caption>Worst cases (largest distance to the flat outputs)</caption><tr><th>case</th>"
                     "<th>seed</th><th>error [m]</th><th>runs</th><th>verdict</th></tr>" + rows + "</table>")
        corr = "".join(f"<tr><td>{e(p)}</td><td>{v:+.2f}</td></tr>" for p, v in g["correlations"][:5])
        parts.append("<table><caption>Spearman rank correlation with the tracking error</caption>"
                     "<tr><th>parameter</th><th>rho</th></tr>" + corr + "</table>")
    if s["failed"]:
        parts.append("<h2>Failed cases</h2><ul>" + "".join(f"<li>{e(k)}: {e(v)}</li>" for k, v in s["failed"].items())
                     + "</ul>")
    style = ("body{font-family:sans-serif;max-width:70em;margin:2em auto}img{max-width:100%}"
             "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:2px 8px}")
    page = (f"<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>Campaign "
            f"{e(str(camp.get('name', '')))}</title><style>{style}</style></head><body>{''.join(parts)}"
            f"<p><a href=\"report.pdf\">PDF</a> - <a href=\"summary.json\">summary.json</a></p></body></html>")
    path = folder / "report" / "index.html"
    path.write_text(page, encoding="utf-8")
    return path


def write_report(folder: str | Path) -> list[Path]:
    """Write ``summary.json``, the figures, ``report.pdf`` and ``index.html`` into ``DIR/report``.

    Parameters
    ----------
    folder : str or Path
        A campaign folder.

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(folder)
    outdir = folder / "report"
    outdir.mkdir(exist_ok=True)
    summary = campaign_summary(folder)
    st = CampaignStore(folder)
    try:
        rows = st.rows()
    finally:
        st.close()
    (outdir / "summary.json").write_text(json.dumps(summary, indent=2, sort_keys=True), encoding="utf-8")
    paths = [outdir / "summary.json"]
    if summary["groups"]:
        paths += _figures(folder, summary, rows, outdir)
    paths.append(render_campaign(folder, summary))
    return paths
