"""The campaign report's data: a JSON summary and figures, in ``DIR/report``.

:func:`campaign_summary` reads the store (pass rate per case, distributions of
the tracking error, saturation time and engine differences, the worst cases,
and the Spearman rank correlation of the reference engine's tracking error with
every dispersed parameter); :func:`write_report` writes ``summary.json`` and the
figures (PNG).  The page and its PDF are rendered by :func:`reports.campaign.render_campaign`
(``gflat campaign report`` does both).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from gna.errors import writing

from ..validation.verdicts import CAUSES, VERDICT_NAMES
from .store import CampaignStore

__all__ = ["campaign_summary", "first_line", "write_report"]

#: Worst cases listed per case label.
N_WORST = 5


def first_line(error) -> str:
    """The first line of a failed case's stored error (a placeholder when none was stored).

    Parameters
    ----------
    error : str or None

    Returns
    -------
    str
    """
    lines = str(error or "").strip().splitlines()
    return lines[0] if lines else "(no error recorded)"


def _ranks(v: np.ndarray) -> np.ndarray:
    order = np.argsort(v, kind="mergesort")
    r = np.empty(len(v))
    r[order] = np.arange(len(v))
    for val in np.unique(v):  # average ranks of ties
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
    return {
        "n": int(v.size),
        "min": float(v.min()),
        "median": float(np.median(v)),
        "p90": float(np.quantile(v, 0.9)),
        "max": float(v.max()),
    }


def _verdict_rates(rs: list, name: str) -> dict:
    """Per verdict: samples judged, passing, failing, failing but recorded by the scenario, the pass rate."""
    out = {"n": 0, "pass": 0, "fail": 0, "recorded": 0}
    for r in rs:
        v = (r["metrics"].get("verdicts") or {}).get(name)
        if v is None or v.get("pass") is None:
            continue
        out["n"] += 1
        if v["pass"]:
            out["pass"] += 1
            continue
        out["fail"] += 1
        failures = r["metrics"].get("failures") or []
        if not any(f == name or f.startswith(f"{name}:") for f in failures):
            out["recorded"] += 1
    out["pass_rate"] = out["pass"] / out["n"] if out["n"] else None
    return out


def campaign_summary(folder: str | Path) -> dict:
    """Summary of a campaign folder.

    Parameters
    ----------
    folder : str or Path
        A campaign folder (:class:`harness.campaign.store.CampaignStore`).

    Returns
    -------
    dict
        ``campaign`` (name, seed), ``description``, ``counts`` (cases, done, failed, pending),
        ``groups``: per case label and dispersion, ``n``, ``passed`` (no
        verdict failing that the scenario does not record),
        ``pass_rate``, ``verdicts`` (``flyable``, ``tracking``,
        ``engines_agree`` -> ``n`` judged, ``pass``, ``fail``, ``recorded``
        (failing, recorded by the scenario), ``pass_rate``), ``causes``
        (:data:`harness.validation.verdicts.CAUSES` -> count, failed samples
        as ``error``), ``status`` (engine -> run status -> count),
        ``tracking_error_m`` / ``saturated_s`` (engine -> min, median, p90,
        max), ``engine_difference_m`` (engine -> stats of the position
        difference from the reference), ``worst`` (the cases of largest
        reference tracking error), ``correlations`` (``[parameter, rho]``
        pairs: Spearman rho with the reference engine's tracking error,
        largest magnitude first);
        ``failed`` (case id -> first line of the error).
    """
    st = CampaignStore(folder, readonly=True)
    try:
        meta, counts, rows = st.meta(), st.counts(), st.rows()
    finally:
        st.close()
    groups: dict[str, list] = {}
    errors: dict[str, int] = {}
    for r in rows:
        key = f"{r['label']}.{r['dispersion']}"
        if r["status"] == "done":
            groups.setdefault(key, []).append(r)
        elif r["status"] == "failed":
            errors[key] = errors.get(key, 0) + 1
    out_groups = {}
    for key, rs in groups.items():
        engines = rs[0]["params"]["engines"]
        ref = engines[0]
        g = {
            "scenario": rs[0]["params"]["scenario"],
            "loop": rs[0]["params"]["loop"],
            "engines": engines,
            "n": len(rs),
            "passed": sum(bool(r["pass"]) for r in rs),
        }
        g["pass_rate"] = g["passed"] / g["n"]
        g["verdicts"] = {name: _verdict_rates(rs, name) for name in VERDICT_NAMES}
        g["causes"] = {c: 0 for c in CAUSES}
        for r in rs:
            c = r["metrics"].get("cause") or "unjudged"  # a store written before the verdicts
            g["causes"][c] = g["causes"].get(c, 0) + 1
        g["causes"]["error"] += errors.get(key, 0)
        g["status"] = {e: {} for e in engines}
        for r in rs:
            for e, run in r["metrics"]["runs"].items():
                g["status"][e][run["status"]] = g["status"][e].get(run["status"], 0) + 1
        g["tracking_error_m"] = {
            e: _stats(r["metrics"]["runs"][e]["max_position_error_m"] for r in rs) for e in engines
        }
        g["saturated_s"] = {e: _stats(r["metrics"]["runs"][e]["saturated_s"] for r in rs) for e in engines}
        g["engine_difference_m"] = {
            e: _stats(r["metrics"]["differences"][e]["max_position_m"] for r in rs) for e in engines[1:]
        }
        err = np.array([r["metrics"]["runs"][ref]["max_position_error_m"] or np.nan for r in rs], dtype=float)
        order = np.argsort(np.where(np.isfinite(err), -err, np.inf))[:N_WORST]
        g["worst"] = [
            {
                "case_id": rs[i]["case_id"],
                "seed": rs[i]["seed"],
                "pass": bool(rs[i]["pass"]),
                "cause": rs[i]["metrics"].get("cause"),
                "tracking_error_m": None if not math.isfinite(err[i]) else float(err[i]),
                "status": {e: run["status"] for e, run in rs[i]["metrics"]["runs"].items()},
            }
            for i in order
        ]
        params = sorted({k for r in rs for k in (r["draw"] or {})})
        corr = {}
        for p in params:
            x = np.array([(r["draw"] or {}).get(p, np.nan) for r in rs], dtype=float)
            rho = _spearman(x, err)
            if rho is not None:
                corr[p] = rho
        g["correlations"] = [[p, rho] for p, rho in sorted(corr.items(), key=lambda kv: -abs(kv[1]))]
        out_groups[key] = g
    failed = {r["case_id"]: first_line(r["error"]) for r in rows if r["status"] == "failed"}
    return {
        "campaign": meta.get("campaign"),
        "description": (meta.get("definition") or {}).get("description", ""),
        "counts": counts,
        "groups": out_groups,
        "failed": failed,
    }


def _figures(folder: Path, summary: dict, rows: list, outdir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    groups = summary["groups"]
    by_group: dict[str, list] = {}
    for r in rows:
        if r["status"] == "done":
            by_group.setdefault(f"{r['label']}.{r['dispersion']}", []).append(r)
    figs = []
    fig, ax = plt.subplots(figsize=(7, 3.2))
    keys = list(groups)
    colours = {
        "pass": "#3a7",
        "infeasible": "#888",
        "unflyable": "#c80",
        "controller failure": "#c33",
        "engines disagree": "#84c",
        "error": "#333",
        "unjudged": "#ccc",
    }
    bottom = np.zeros(len(keys))
    for c in dict.fromkeys(list(CAUSES) + [c for k in keys for c in groups[k]["causes"]]):
        n = np.array([groups[k]["causes"].get(c, 0) for k in keys], dtype=float)
        if n.any():
            ax.bar(range(len(keys)), n, bottom=bottom, color=colours.get(c, "#999"), label=c)
            bottom += n
    ax.set_xticks(range(len(keys)), keys, rotation=15, fontsize=8)
    ax.set_ylabel("samples")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.set_title("Samples per cause", fontsize=9)
    fig.tight_layout()
    figs.append(("pass_rate.png", fig))
    for metric, title, unit in (
        ("max_position_error_m", "Largest distance to the flat outputs", "m"),
        ("saturated_s", "Time with a control commanded beyond its limits", "s"),
    ):
        fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * max(len(keys), 1), 3), squeeze=False)
        for ax, k in zip(axes[0], keys):
            vals = {
                e: [
                    x
                    for x in (r["metrics"]["runs"][e][metric] for r in by_group[k])
                    if x is not None and math.isfinite(x)
                ]
                for e in groups[k]["engines"]
            }
            flat = [x for v in vals.values() for x in v]
            # A diverged run (1e20 m) hides the rest on a linear axis: decades then.
            logx = metric == "max_position_error_m" and flat and min(flat) > 0 and max(flat) > 100 * min(flat)
            for e, v in vals.items():
                if v:
                    ax.hist(np.log10(v) if logx else v, bins=min(20, max(3, len(v))), alpha=0.6, label=e)
            ax.set_title(k, fontsize=8)
            ax.set_xlabel(f"log10 [{unit}]" if logx else f"[{unit}]")
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
    for name, fig in figs:
        with writing(outdir / name):
            fig.savefig(outdir / name, dpi=110)
        plt.close(fig)
        paths.append(outdir / name)
    return paths


def write_report(folder: str | Path, target: str | Path | None = None) -> tuple[dict, list, list[Path]]:
    """Write ``summary.json`` and the figures into ``DIR/report`` (or ``target``).

    Parameters
    ----------
    folder : str or Path
        A campaign folder.
    target : str or Path, optional
        The report folder (default ``folder/report``; ``gflat campaign report`` gives its staging folder,
        :class:`harness.rundir.RunDir`).

    Returns
    -------
    (dict, list of dict, list of Path)
        The summary (:func:`campaign_summary`), the stored cases, the files written.
    """
    folder = Path(folder)
    outdir = Path(target) if target is not None else folder / "report"
    outdir.mkdir(parents=True, exist_ok=True)
    summary = campaign_summary(folder)
    st = CampaignStore(folder, readonly=True)
    try:
        rows = st.rows()
    finally:
        st.close()
    with writing(outdir / "summary.json"):
        (outdir / "summary.json").write_text(json.dumps(summary, indent=2, sort_keys=True), encoding="utf-8")
    paths = [outdir / "summary.json"]
    if summary["groups"]:
        paths += _figures(folder, summary, rows, outdir)
    return summary, rows, paths
