"""Figures of the validation report beyond the case folder's: the singularity monitor along the flat plan.

Fed by result objects only (the case's plan); drawn on the process's reused
figure (:func:`reports.figures.sheet`), in SI units with the unit on every
axis, as in :mod:`reports.figures`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gna.limits import control_ranges

from .figures import label, sheet, span_limits, time_axis

#: File name of the figure this module draws.
SINGULARITY_PNG = "singularity.png"

#: Units of the singularity monitor's columns; the determinant's is a product of SI units (only its zeros and
#: sign changes matter).
SINGULARITY_UNITS = {"V_cos_gamma": "m/s", "cos_beta": "-"}


def control_limits(aircraft) -> dict[str, tuple[float, float]]:
    """Range of every bounded control (:func:`gna.limits.control_ranges`, the one definition of the limits).

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        Its ``envelope.control_limits`` [rad] and ``propulsion`` (``max_thrust`` [N], ``count``).

    Returns
    -------
    dict
        Control name -> (lower, upper) in SI units: thrust ``0 .. max_thrust``, ``|eta| <= 1`` with two
        engines, the surfaces.
    """
    return control_ranges(aircraft)


def write_singularity_figure(plan, out_dir: str | Path) -> Path | None:
    """The singularity monitor along the flat plan: the flat output's determinant, V cos(gamma), cos(beta).

    Parameters
    ----------
    plan : planners.plan.Plan
        A plan whose ``singularities`` report is set (paper eqs. cond_beta, stalling_cond, cond_F).
    out_dir : str or Path
        Folder (made when missing).

    Returns
    -------
    Path or None
        ``singularity.png``; None when the plan carries no monitor.
    """
    sing = plan.singularities
    if sing is None:
        return None
    tab = sing.table
    cols = list(tab.columns)[:3]
    s = sheet()
    axes = s.panels(1, 3, f"{plan.name}: singularity monitor along the flat plan (zero = singular)")
    t = np.asarray(tab.index, dtype=float)
    for ax, col in zip(axes, cols):
        y = np.real(tab[col].to_numpy())
        unit = SINGULARITY_UNITS.get(col, "SI")
        ax.plot(t, y, "o-", ms=2.5, lw=1.0)
        ax.axhline(0.0, color="r", lw=0.8, ls=":")
        ax.set_ylim(*span_limits([y, [0.0]], unit))
        ax.set_ylabel(label(col, unit))
        time_axis(ax, float(t[0]), float(t[-1]), s)
    for ax in axes[len(cols) :]:
        ax.axis("off")
    return s.save(out_dir, SINGULARITY_PNG)
