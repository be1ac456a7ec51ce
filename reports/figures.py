"""Figures of engine runs: states, applied controls, differences to the reference engine.

Fed by result objects only (mappings label -> :class:`gna.simulate.SimulationResult`,
a reference DataFrame); no pyplot, hence no global figure state.  Angles are
drawn in degrees, everything else in SI units (:data:`gna.trajectory.UNITS`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.errors import writing
from gna.trajectory import UNITS
from harness.metrics import DEFAULT_VARIABLES, differences, resolve_tolerances


def plot_scale(name: str) -> tuple[float, str]:
    """Factor and unit a variable is drawn in: radians as degrees, the rest in SI units.

    Parameters
    ----------
    name : str
        Column name (:data:`gna.trajectory.UNITS`).

    Returns
    -------
    (float, str)
        Multiplier from the SI value, and the unit drawn.
    """
    unit = UNITS.get(name, "")
    if unit == "rad":
        return math.degrees(1.0), "deg"
    if unit == "rad/s":
        return math.degrees(1.0), "deg/s"
    return 1.0, unit


def _draw_runs(ax, results: Mapping, name: str) -> None:
    """One variable of every run on one axis: the reference engine solid, the others dashed."""
    k, unit = plot_scale(name)
    for i, (lab, res) in enumerate(results.items()):
        ax.plot(res.df.index, res.df[name] * k, lw=1.2, ls="-" if i == 0 else "--", label=lab)
    ax.set_ylabel(f"{name} [{unit}]")
    ax.grid(alpha=0.3)


#: Fixed margins of the figure grids [in]: room for the y tick labels and label (left, between columns), the
#: x tick labels and label (bottom), the title (top).  Fixed margins cost nothing at drawing time, where
#: matplotlib's constrained layout measured every axis twice (about 40 % of a figure's drawing time).
MARGINS_IN = {"left": 0.95, "right": 0.2, "bottom": 0.6, "top": 0.55, "wspace": 1.0, "hspace": 0.3}


def grid_margins(fig) -> None:
    """Place a figure's grid of axes with the fixed margins :data:`MARGINS_IN`.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        A figure whose axes come from one ``fig.subplots(nrows, ncols)`` grid.
    """
    w, h = fig.get_size_inches()
    nrows, ncols = fig.axes[0].get_subplotspec().get_gridspec().get_geometry()
    m = MARGINS_IN
    ax_w = (w - m["left"] - m["right"] - (ncols - 1) * m["wspace"]) / ncols
    ax_h = (h - m["bottom"] - m["top"] - (nrows - 1) * m["hspace"]) / nrows
    fig.subplots_adjust(
        left=m["left"] / w,
        right=1 - m["right"] / w,
        bottom=m["bottom"] / h,
        top=1 - m["top"] / h,
        wspace=m["wspace"] / ax_w,
        hspace=m["hspace"] / ax_h,
    )


def save_figure(fig, out, name: str, dpi: int = 110) -> Path:
    """Save a figure as ``name`` in the folder ``out`` (made when missing).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    out : str or Path
        Output folder.
    name : str
        File name; its suffix sets the format.
    dpi : int
        Resolution.

    Returns
    -------
    Path
        The file written.
    """
    fmt = Path(name).suffix.lstrip(".") or None
    path = Path(out) / name
    with writing(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=dpi, format=fmt)
    return path


def write_figures(
    results: Mapping, out_dir, *, reference: pd.DataFrame | None = None, title: str = "", tolerances=None
) -> list[Path]:
    """States and controls of every engine (and the reference), and the differences to the first engine.

    Parameters
    ----------
    results : mapping label -> SimulationResult
        Runs on a common output grid; the first is the reference engine.
    out_dir : str or Path
        Folder the PNG files are written to (created if needed).
    reference : DataFrame, optional
        Planned states indexed by ``t`` [s], drawn dotted (e.g. the plan's).
    title : str
        Prefix of the figure titles.
    tolerances : None, float or mapping
        Drawn as lines on the difference plots (see
        :func:`harness.metrics.resolve_tolerances`).

    Returns
    -------
    list of Path
        ``states.png``, ``controls.png`` and (with two runs or more) ``differences.png``.
    """
    from matplotlib.figure import Figure  # no pyplot: no global state

    out = out_dir
    labels = list(results)
    paths = []

    fig = Figure(figsize=(13, 11), layout=None)
    axs = fig.subplots(4, 3, sharex=True)
    for ax, name in zip(axs.ravel(), STATE_NAMES):
        if reference is not None and name in reference.columns:
            ax.plot(reference.index, reference[name] * plot_scale(name)[0], "k:", lw=2.0, label="plan")
        _draw_runs(ax, results, name)
    for ax in axs[-1]:
        ax.set_xlabel("t [s]")
    axs[0, 0].legend(fontsize=8)
    fig.suptitle(f"{title}: states")
    grid_margins(fig)
    paths.append(save_figure(fig, out, "states.png"))

    fig = Figure(figsize=(13, 7), layout=None)
    axs = fig.subplots(2, 3, sharex=True)
    for ax, name in zip(axs.ravel(), CONTROL_NAMES):
        _draw_runs(ax, results, name)
    axs.ravel()[-1].axis("off")
    for ax in axs[-1]:
        ax.set_xlabel("t [s]")
    axs[0, 0].legend(fontsize=8)
    fig.suptitle(f"{title}: applied controls")
    grid_margins(fig)
    paths.append(save_figure(fig, out, "controls.png"))

    if len(labels) > 1:
        tol = resolve_tolerances(tolerances, DEFAULT_VARIABLES)
        fig = Figure(figsize=(13, 12), layout=None)
        axs = fig.subplots(5, 3, sharex=True)
        ref = results[labels[0]]
        names = DEFAULT_VARIABLES
        for ax, name in zip(axs.ravel(), names):
            for lab in labels[1:]:
                d = differences(ref, results[lab], name)
                ax.semilogy(d.index, np.maximum(np.abs(d.to_numpy()), 1e-16), lw=1.0, label=f"{lab} - {labels[0]}")
            if name in tol:
                ax.axhline(tol[name], color="r", ls=":", lw=1.0, label="tolerance")
            ax.set_ylabel(f"|d {name}| [{UNITS.get(name, '')}]")
            ax.grid(alpha=0.3, which="both")
        for ax in axs.ravel()[len(names) :]:
            ax.axis("off")
        axs[0, 0].legend(fontsize=8)
        for ax in axs[-1]:
            ax.set_xlabel("t [s]")
        fig.suptitle(f"{title}: differences to {labels[0]}")
        grid_margins(fig)
        paths.append(save_figure(fig, out, "differences.png"))
    return paths
