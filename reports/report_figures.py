"""Figures of the validation report beyond the case folder's: singularity monitor, limits, signed differences.

Fed by result objects only (:class:`harness.validation.CaseResult` and its plan);
no pyplot, hence no global figure state.  Angles are drawn in degrees, the rest
in SI units, as in :mod:`reports.figures`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gna.eom import CONTROL_NAMES
from gna.limits import control_ranges
from harness.metrics import differences

from .figures import grid_margins, plot_scale, save_figure

#: Variables of the signed-difference figure: the position components, then the other states.
SIGNED_VARIABLES: tuple[str, ...] = ("x", "y", "z", "V", "gamma", "chi", "alpha", "beta", "mu", "p", "q", "r")

#: File names of the figures this module draws.
SINGULARITY_PNG, CONTROLS_LIMITS_PNG, SIGNED_DIFFERENCES_PNG = (
    "singularity.png",
    "controls-limits.png",
    "signed-differences.png",
)


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
    from matplotlib.figure import Figure

    sing = plan.singularities
    if sing is None:
        return None
    tab = sing.table
    fig = Figure(figsize=(12, 3.6), layout=None)
    axs = fig.subplots(1, len(tab.columns), sharex=True)
    units = {"V_cos_gamma": "m/s", "cos_beta": "-"}
    for ax, col in zip(np.atleast_1d(axs), tab.columns):
        ax.plot(tab.index, tab[col], "o-", ms=2.5, lw=1.0)
        ax.axhline(0.0, color="r", lw=0.8, ls=":")
        ax.set_ylabel(f"{col} [{units.get(col, '-')}]")
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{plan.name}: singularity monitor along the flat plan (zero = singular)")
    grid_margins(fig)
    return save_figure(fig, out_dir, SINGULARITY_PNG, dpi=90)


def write_controls_limits_figure(result, out_dir: str | Path) -> Path:
    """Applied controls of every engine with the plan's and the aircraft's limits drawn.

    Parameters
    ----------
    result : harness.validation.CaseResult
        The case's runs (reference engine solid, others dashed) and plan.
    out_dir : str or Path
        Folder (made when missing).

    Returns
    -------
    Path
        ``controls-limits.png``.
    """
    from matplotlib.figure import Figure

    ref = result.reference_frame()
    limits = control_limits(result.plan.aircraft)
    fig = Figure(figsize=(12, 6.5), layout=None)
    axs = fig.subplots(2, 3, sharex=True)
    for ax, name in zip(axs.ravel(), CONTROL_NAMES):
        k, unit = plot_scale(name)
        ax.plot(ref.index, ref[name] * k, "k:", lw=2.0, label=f"plan J = {result.plan.J}")
        for i, (lab, res) in enumerate(result.runs.items()):
            ax.plot(res.df.index, res.df[name] * k, lw=1.2, ls="-" if i == 0 else "--", label=lab)
        for i, bound in enumerate(limits.get(name, ())):
            ax.axhline(bound * k, color="r", lw=1.0, ls="-.", label="limit" if i == 0 else None)
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(alpha=0.3)
    axs.ravel()[-1].axis("off")
    for ax in axs[-1]:
        ax.set_xlabel("t [s]")
    axs[0, 0].legend(fontsize=7)
    fig.suptitle(f"{result.plan.name} ({result.case.loop} loop): applied controls and their limits")
    grid_margins(fig)
    return save_figure(fig, out_dir, CONTROLS_LIMITS_PNG, dpi=90)


def write_signed_differences_figure(result, out_dir: str | Path) -> Path | None:
    """Signed differences of every engine to the reference, in the units of the state plots (deg for angles).

    Parameters
    ----------
    result : harness.validation.CaseResult
        The case's runs; the first is the reference.
    out_dir : str or Path
        Folder (made when missing).

    Returns
    -------
    Path or None
        ``signed-differences.png``; None with a single engine.
    """
    from matplotlib.figure import Figure

    labels = list(result.runs)
    if len(labels) < 2:
        return None
    ref = result.runs[labels[0]]
    fig = Figure(figsize=(12, 9), layout=None)
    axs = fig.subplots(4, 3, sharex=True)
    for ax, name in zip(axs.ravel(), SIGNED_VARIABLES):
        k, unit = plot_scale(name)
        for lab in labels[1:]:
            d = differences(ref, result.runs[lab], name)
            ax.plot(d.index, d.to_numpy() * k, lw=1.0, label=f"{lab} - {labels[0]}")
        ax.set_ylabel(f"d {name} [{unit}]")
        ax.grid(alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("t [s]")
    axs[0, 0].legend(fontsize=7)
    fig.suptitle(f"{result.plan.name} ({result.case.loop} loop): signed differences to {labels[0]}")
    grid_margins(fig)
    return save_figure(fig, out_dir, SIGNED_DIFFERENCES_PNG, dpi=90)
