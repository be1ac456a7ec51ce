"""The three verdicts of a case: the plan is flyable, the feedback tracks it, the engines agree.

* ``flyable``: the plan's controls within the aircraft's limits and its states within the model's domain
  of validity (:mod:`gna.limits`, the limits the planner's warnings check), on the grid of
  :meth:`planners.plan.Plan.limit_frame` (step ``min(0.01 s, node step / 8)``, controls from the plan's
  control function), each violation with its worst value, its time and the fraction of the span;
* ``tracking`` (closed loop only; ``pass`` None open loop): every engine's largest distance to the flat
  outputs after the settle time within the scenario's tolerance (``[compare] tracking_tolerance``,
  ``settle_time``), and the time any command spent saturated;
* ``engines_agree``: every run complete and every engine within the tolerances of the reference
  (the difference tables).

A scenario may record violations it keeps (``[verdicts] known``, :class:`planners.scenario.KnownViolation`):
they stay in the verdicts, marked ``known`` with their reason, and only stop failing the exit status
(:func:`judge`).  Nothing here flies or writes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

from ..metrics import max_position_error

#: The verdicts, in the order they are shown.
VERDICT_NAMES: tuple[str, ...] = ("flyable", "tracking", "engines_agree")

#: The states summarised in the engine differences (angles).
_ANGLES: tuple[str, ...] = ("gamma", "chi", "alpha", "beta", "mu")


def _finite(v) -> float | None:
    return float(v) if v is not None and math.isfinite(v) else None


def _reasons(known: Sequence) -> dict:
    return {k.name: k.reason for k in known}


def flyable_verdict(plan, known: Sequence = (), aircraft=None) -> dict:
    """Whether the plan's controls and states stay within the aircraft's limits.

    Parameters
    ----------
    plan : planners.plan.Plan
        A feasible plan; its last iterate is judged.
    known : sequence of planners.scenario.KnownViolation
        The scenario's recorded violations.
    aircraft : gna.aircraft.Aircraft, optional
        Whose limits (default the plan's).

    Returns
    -------
    dict
        ``pass`` (no violation, recorded or not), ``violations`` (records of
        :meth:`gna.limits.Violation.to_dict`: ``name``, ``limit``, ``worst``,
        ``time``, ``fraction``, ... in SI/rad, plus ``known`` and ``reason``),
        ``iterate`` (J), ``grid_step_s``, ``recorded_not_seen`` (limits the
        scenario records that the plan does not violate).
    """
    from gna.limits import LIMIT_NAMES

    reasons = _reasons(known)
    frame = plan.limit_frame(plan.J, aircraft)
    violations = plan.limit_violations(plan.J, aircraft)
    records = [dict(v.to_dict(), known=v.name in reasons, reason=reasons.get(v.name)) for v in violations]
    seen = {v.name for v in violations}
    t = frame.index.to_numpy(dtype=float)
    return {
        "pass": not violations,
        "violations": records,
        "iterate": plan.J,
        "grid_step_s": float(t[1] - t[0]) if t.size > 1 else 0.0,
        "recorded_not_seen": [n for n in reasons if n in LIMIT_NAMES and n not in seen],
    }


def infeasible_flyable(why: str) -> dict:
    """The flyable verdict of a path with no plan (Newton failure, domain, singularity).

    Parameters
    ----------
    why : str
        The planner's first failure.

    Returns
    -------
    dict
        ``pass`` False, ``infeasible`` True, ``reason``, no violations.
    """
    return {"pass": False, "infeasible": True, "reason": why, "violations": [], "recorded_not_seen": []}


def tracking_verdict(
    runs: Mapping,
    reference: Callable,
    span: tuple[float, float],
    tolerance_m: float,
    settle_s: float,
    saturated_s: Mapping | None,
    clipped: bool = True,
) -> dict:
    """Whether the feedback holds every engine on the flat outputs after the settle time.

    Parameters
    ----------
    runs : mapping
        Engine label -> closed-loop SimulationResult.
    reference : callable
        ``t -> state`` of the plan (its x, y, z are the flat outputs).
    span : (t0, t1)
        The plan's span [s]; the measure starts at ``min(t0 + settle_s, t1)`` (a span shorter than the
        settle time is judged at its end).
    tolerance_m : float
        Largest distance allowed after the settle time [m].
    settle_s : float
        Time from t0 before the measure starts [s].
    saturated_s : mapping or None
        Engine label -> ``{"any": s, ...}`` (:func:`harness.validation.closed.saturated_seconds`):
        the time commanded beyond a limit; None open loop.
    clipped : bool
        Whether the controller clipped its commands at the limits (scenario ``[tracking] saturate``); when
        not, the runs flew the commands beyond them and the line says so.

    Returns
    -------
    dict
        ``pass`` (None open loop: nothing to judge), ``tolerance_m``,
        ``settle_s``, ``engines`` (label -> ``status``,
        ``max_error_after_settle_m`` (None when not finite or the run ended
        before), ``saturated_s``, ``pass``), ``max_error_after_settle_m``
        and ``saturated_s`` (the largest over the engines), ``clipped``.
    """
    if saturated_s is None:
        return {"pass": None, "applies": False, "reason": "open loop: no feedback to judge"}
    engines = {}
    start = min(float(span[0]) + settle_s, float(span[1]))
    for label, res in runs.items():
        err = _finite(max_position_error(res, reference, (start - 1e-9, None)))
        sat = float(saturated_s.get(label, {}).get("any", 0.0))
        ok = res.status == "completed" and err is not None and err <= tolerance_m
        engines[label] = {"status": res.status, "max_error_after_settle_m": err, "saturated_s": sat, "pass": ok}
    errs = [e["max_error_after_settle_m"] for e in engines.values()]
    return {
        "pass": all(e["pass"] for e in engines.values()),
        "applies": True,
        "tolerance_m": tolerance_m,
        "settle_s": settle_s,
        "from_s": start,
        "engines": engines,
        "max_error_after_settle_m": None if None in errs else max(errs, default=None),
        "saturated_s": max((e["saturated_s"] for e in engines.values()), default=0.0),
        "clipped": bool(clipped),
    }


def engines_agree_verdict(runs: Mapping, tables: Mapping) -> dict:
    """Whether every run completed and every engine agrees with the reference within the tolerances.

    Parameters
    ----------
    runs : mapping
        Engine label -> SimulationResult, the reference first.
    tables : mapping
        Engine label (all but the reference) -> window -> DifferenceTable.

    Returns
    -------
    dict
        ``pass``, ``incomplete`` (labels of the runs that ended early),
        ``differences`` (engine -> ``max_position_m``, ``max_angle_rad`` over
        the whole span, ``pass``, ``failing``: variables beyond their tolerance
        with the window).
    """
    diffs = {}
    for label, per in tables.items():
        whole = per.get("whole span") or next(iter(per.values()))
        diffs[label] = {
            "max_position_m": _finite(whole.row("position").max_abs),
            "max_angle_rad": _finite(max(whole.row(v).max_abs for v in _ANGLES)),
            "pass": bool(all(t.passed for t in per.values())),
            "failing": sorted({f"{r.variable} ({w})" for w, t in per.items() for r in t.failures()}),
        }
    incomplete = [label for label, r in runs.items() if r.status != "completed"]
    return {
        "pass": not incomplete and all(d["pass"] for d in diffs.values()),
        "incomplete": incomplete,
        "differences": diffs,
    }


def judge(verdicts: Mapping, known: Sequence = ()) -> dict:
    """What fails the exit status: each failed verdict (or flyable violation) the scenario does not record.

    Parameters
    ----------
    verdicts : mapping
        ``flyable``, ``tracking``, ``engines_agree`` (as the functions above; a missing one is not judged).
    known : sequence of planners.scenario.KnownViolation

    Returns
    -------
    dict
        ``pass`` (nothing unrecorded failed), ``unrecorded`` (``"flyable: dl"``, ``"tracking"``, ...),
        ``recorded`` (the failures the scenario records, with their reasons).
    """
    reasons = _reasons(known)
    unrecorded, recorded = [], []
    fly = verdicts.get("flyable")
    if fly is not None and fly["pass"] is False:
        if fly.get("infeasible"):
            unrecorded.append("flyable: no plan")
        for v in fly["violations"]:
            (recorded if v["name"] in reasons else unrecorded).append(f"flyable: {v['name']}")
    for name in ("tracking", "engines_agree"):
        v = verdicts.get(name)
        if v is not None and v["pass"] is False:
            (recorded if name in reasons else unrecorded).append(name)
    return {
        "pass": not unrecorded,
        "unrecorded": unrecorded,
        "recorded": [{"failure": f, "reason": reasons[f.split(": ")[-1]]} for f in dict.fromkeys(recorded)],
    }


#: Causes of a campaign sample, in the order a failure is explained (the first that applies); ``error``: the
#: sample did not run to its end (an exception, or past its time budget).
CAUSES: tuple[str, ...] = ("pass", "infeasible", "unflyable", "controller failure", "engines disagree", "error")


def cause(verdicts: Mapping, known: Sequence = ()) -> str:
    """The one cause of a sample's outcome (:data:`CAUSES`).

    ``pass`` when nothing unrecorded fails (:func:`judge`); otherwise, the
    plan before the controller: ``infeasible`` (no plan of the path for that
    aircraft), ``unflyable`` (a plan outside a limit the scenario does not
    record), ``controller failure`` (the tracking verdict fails), ``engines
    disagree``.

    Parameters
    ----------
    verdicts : mapping
        ``flyable``, ``tracking``, ``engines_agree``.
    known : sequence of planners.scenario.KnownViolation

    Returns
    -------
    str
    """
    failed = judge(verdicts, known)["unrecorded"]
    if not failed:
        return "pass"
    if verdicts.get("flyable", {}).get("infeasible"):
        return "infeasible"
    if any(f.startswith("flyable") for f in failed):
        return "unflyable"
    if "tracking" in failed:
        return "controller failure"
    return "engines disagree"


def verdict_lines(verdicts: Mapping, judged: Mapping | None = None) -> list[str]:
    """The verdicts as printed lines (``gflat compare``, ``gflat paper``): one per verdict, then each violation.

    Parameters
    ----------
    verdicts : mapping
        ``flyable``, ``tracking``, ``engines_agree``.
    judged : mapping, optional
        :func:`judge` of them (which failures the scenario records).

    Returns
    -------
    list of str
    """

    def word(ok):
        return "n/a" if ok is None else ("PASS" if ok else "FAIL")

    fly, trk, agr = (verdicts[k] for k in VERDICT_NAMES)
    lines = []
    if fly.get("infeasible"):
        lines.append(f"flyable: FAIL (no plan: {fly['reason']})")
    else:
        n = len(fly["violations"])
        known = sum(v["known"] for v in fly["violations"])
        extra = f" ({n} violation(s), {known} recorded by the scenario)" if n else ""
        lines.append(f"flyable: {word(fly['pass'])}{extra}")

    def shown(x, unit):
        return f"{math.degrees(x):.2f} deg" if unit == "rad" else f"{x:.4g} {unit}".rstrip(" -")

    for v in fly["violations"]:
        lines.append(
            f"  {v['name']}: worst {shown(v['worst'], v['unit'])} at t = {v['time']:.4g} s against "
            f"{shown(v['limit'], v['unit'])}, "
            f"{100 * v['fraction']:.0f} % of the span" + (f"; recorded: {v['reason']}" if v["known"] else "")
        )
    if trk["pass"] is None:
        lines.append(f"tracking: n/a ({trk['reason']})")
    else:
        err = trk["max_error_after_settle_m"]
        beyond = trk["saturated_s"]
        if not beyond:
            commands = "commands within their limits"
        elif trk.get("clipped", True):
            commands = f"commands clipped at their limits {beyond:.2f} s"
        else:  # the flight used what the aircraft cannot give: said, not hidden behind the PASS
            commands = f"commands beyond their limits {beyond:.2f} s, flown unclipped ([tracking] saturate = false)"
        lines.append(
            f"tracking: {word(trk['pass'])} (largest distance to the flat outputs after {trk['settle_s']:g} s "
            f"{'n/a' if err is None else f'{err:.3g} m'} against {trk['tolerance_m']:g} m; {commands})"
        )
    bad = [f"{k}: {', '.join(d['failing'])}" for k, d in agr["differences"].items() if d["failing"]]
    detail = "; ".join(([f"runs ended early: {', '.join(agr['incomplete'])}"] if agr["incomplete"] else []) + bad)
    lines.append(f"engines_agree: {word(agr['pass'])}" + (f" ({detail})" if detail else ""))
    if judged is not None and judged["unrecorded"]:
        lines.append(f"failing (not recorded by the scenario): {', '.join(judged['unrecorded'])}")
    return lines
