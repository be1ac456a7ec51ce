"""The paper's four-curve figures of a closed-loop case (section "Examples").

For each scenario the paper draws, against time, the flat plan J = 0 (red),
the integration with the tracking feedback (dark blue), the generalized plan
(green) and the integration of the generalized controls without feedback
(cyan); the surfaces are drawn with their feedback part, ``delta + d(delta)``.
The paper's dark-blue run flies the flat plan's (J = 0) controls as
feedforward: it starts on the flat plan and converges to the generalized one.
When the case's own closed loop uses another iterate (by default the last),
that run is drawn too (navy, dotted).
Fed by a :class:`harness.validation.CaseResult` of a closed-loop case; no pyplot.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harness.metrics import position_error

from .figures import grid_margins, plot_scale, save_figure

#: Variables drawn, in panel order (the paper's figures show the angles and the surfaces).
TRACKING_VARIABLES: tuple[str, ...] = ("V", "alpha", "beta", "mu", "F", "dl", "dm", "dn")

#: The paper's colours.
COLOURS = {"flat": "red", "closed": "darkblue", "generalized": "green", "open": "cyan", "closed_last": "navy"}


def write_tracking_figure(result, out_dir: str | Path, name: str = "tracking.png") -> Path:
    """Draw the four curves of a closed-loop case and the position error against the flat outputs.

    Parameters
    ----------
    result : harness.validation.CaseResult
        A closed-loop case's result (``closed_loop`` and ``open_loop`` set).
    out_dir : str or Path
        Folder (made when missing).
    name : str
        File name of the PNG.

    Returns
    -------
    Path
        The figure written.

    Raises
    ------
    ValueError
        When the result is not a closed-loop one.
    """
    from matplotlib.figure import Figure

    if result.closed_loop is None or result.open_loop is None:
        raise ValueError("the four-curve figure needs a closed-loop case result")
    plan = result.plan
    closed = result.runs[result.reference_engine]
    dark_blue = result.flat_closed_loop if result.flat_closed_loop is not None else closed
    j = result.closed_loop.feedforward_iterate
    t = np.asarray(closed.df.index, dtype=float)
    flat = plan.to_dataframe(t, j=0)
    gen = plan.to_dataframe(t, j=plan.J)
    opened = result.open_loop.df
    fig = Figure(figsize=(13, 11), layout=None)
    axs = fig.subplots(3, 3, sharex=True)
    for ax, var in zip(axs.ravel(), TRACKING_VARIABLES):
        k, unit = plot_scale(var)
        ax.plot(flat.index, flat[var] * k, color=COLOURS["flat"], lw=1.2, label="flat plan J = 0")
        ax.plot(
            opened.index,
            opened[var] * k,
            color=COLOURS["open"],
            lw=1.0,
            ls="--",
            label="open loop, generalized controls",
        )
        surf = " (delta + d delta)" if var in ("F", "dl", "dm", "dn") else ""
        ax.plot(
            dark_blue.df.index,
            dark_blue.df[var] * k,
            color=COLOURS["closed"],
            lw=1.2,
            label="closed loop, feedforward J = 0" + surf,
        )
        if dark_blue is not closed:
            ax.plot(
                closed.df.index,
                closed.df[var] * k,
                color=COLOURS["closed_last"],
                lw=1.0,
                ls=":",
                label=f"closed loop, feedforward j = {j}" + surf,
            )
        # drawn last, thin and translucent: it lies under the closed loop when the tracking is good
        ax.plot(
            gen.index,
            gen[var] * k,
            color=COLOURS["generalized"],
            lw=2.5,
            alpha=0.55,
            ls=(0, (4, 3)),
            label=f"generalized plan J = {plan.J}",
        )
        ax.set_ylabel(f"{var} [{unit}]")
        ax.grid(alpha=0.3)
    ax = axs.ravel()[-1]
    curves = [(dark_blue, COLOURS["closed"], "closed loop, J = 0 feedforward", "-")]
    if dark_blue is not closed:
        curves.append((closed, COLOURS["closed_last"], f"closed loop, j = {j} feedforward", ":"))
    curves.append((result.open_loop, COLOURS["open"], "open loop", "--"))
    for run, colour, label, ls in curves:
        err = position_error(run, lambda tt: plan.state(tt, plan.J))
        ax.semilogy(err.index, np.maximum(err.to_numpy(), 1e-9), color=colour, lw=1.2, ls=ls, label=label)
    ax.set_ylabel("|position - flat outputs| [m]")
    ax.grid(alpha=0.3, which="both")
    for a in axs[-1]:
        a.set_xlabel("t [s]")
    axs[0, 0].legend(fontsize=7)
    ax.legend(fontsize=7)
    fig.suptitle(
        f"{plan.name}: closed loop with the tracking feedback (engine {result.reference_engine}) "
        f"against the flat (J = 0) and generalized (J = {plan.J}) plans"
    )
    grid_margins(fig)
    return save_figure(fig, out_dir, name)
