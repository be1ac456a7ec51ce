"""The validity box of the aerodynamic data checked on a case's plan and flights (:class:`gna.limits.ValidityWarnings`).

A command makes one :class:`~gna.limits.ValidityWarnings` and hands it every plan and flight it makes:
:func:`check_plan`, :func:`check_run`, :func:`check_result`.  Each quantity of each aircraft's box is warned
of once per command, with the worst value of the first trajectory that leaves it; nothing changes a verdict.
"""

from __future__ import annotations

import numpy as np

from gna.limits import VALIDITY_COLUMNS, ValidityWarnings, fine_step

__all__ = ["ValidityWarnings", "check_plan", "check_run", "check_result"]


def check_plan(warnings: ValidityWarnings, plan) -> list[str]:
    """Warn of the validity box left by a plan's last iterate (on the grid its limits are checked on).

    Parameters
    ----------
    warnings : gna.limits.ValidityWarnings
        The command's.
    plan : planners.plan.Plan
        An infeasible plan is not checked (its values are no solution).

    Returns
    -------
    list of str
        The warnings given now.
    """
    if not plan.feasible:
        return []
    step = fine_step(float(np.min(np.diff(plan.t_nodes))))
    frame = plan.to_dataframe(step=step, variables=VALIDITY_COLUMNS)
    return warnings.check(plan.aircraft, frame, f"plan of {plan.name}, j = {plan.J}")


def check_run(warnings: ValidityWarnings, aircraft, run, what: str) -> list[str]:
    """Warn of the validity box left by a flight.

    Parameters
    ----------
    warnings : gna.limits.ValidityWarnings
    aircraft : gna.aircraft.Aircraft
        The aircraft flown.
    run : gna.trajectory.SimulationResult
        Its trajectory (``df``, indexed by time).
    what : str
        What the flight is (``"jsbsim flight of gtm-forward-slip, open loop"``).

    Returns
    -------
    list of str
    """
    df = getattr(run, "df", None)
    if df is None or not set(VALIDITY_COLUMNS) <= set(df.columns) or len(df) == 0:
        return []
    return warnings.check(aircraft, df[list(VALIDITY_COLUMNS)], what)


def check_result(warnings: ValidityWarnings, result) -> list[str]:
    """Warn of the validity box left by a case's plan, then by each of its flights.

    Parameters
    ----------
    warnings : gna.limits.ValidityWarnings
    result : harness.validation.CaseResult

    Returns
    -------
    list of str
    """
    out = check_plan(warnings, result.plan)
    for label, run in result.runs.items():
        out += check_run(
            warnings, result.plan.aircraft, run, f"{label} flight of {result.plan.name}, {result.case.loop} loop"
        )
    return out
