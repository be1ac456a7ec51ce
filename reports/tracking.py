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

from .figures import label, log_limits, plot_scale, sheet, span_limits, time_axis

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
    s = sheet()
    axes = s.panels(
        3,
        3,
        f"{plan.name}: closed loop with the tracking feedback (engine {result.reference_engine}) "
        f"against the flat (J = 0) and generalized (J = {plan.J}) plans",
    )
    t0, t1 = float(t[0]), float(t[-1])
    handles = {}
    for ax, var in zip(axes, TRACKING_VARIABLES):
        k, unit = plot_scale(var)
        surf = " (delta + d delta)" if var in ("F", "dl", "dm", "dn") else ""
        curves = [
            (flat, {"color": COLOURS["flat"], "lw": 1.2}, "flat plan J = 0"),
            (opened, {"color": COLOURS["open"], "lw": 1.0, "ls": "--"}, "open loop, generalized controls"),
            (dark_blue.df, {"color": COLOURS["closed"], "lw": 1.2}, "closed loop, feedforward J = 0" + surf),
        ]
        if dark_blue is not closed:
            curves.append(
                (
                    closed.df,
                    {"color": COLOURS["closed_last"], "lw": 1.0, "ls": ":"},
                    f"closed loop, feedforward j = {j}" + surf,
                )
            )
        # drawn last, thin and translucent: it lies under the closed loop when the tracking is good
        curves.append(
            (
                gen,
                {"color": COLOURS["generalized"], "lw": 2.5, "alpha": 0.55, "ls": (0, (4, 3))},
                f"generalized plan J = {plan.J}",
            )
        )
        drawn = []
        for df, style, lab in curves:
            y = df[var].to_numpy(float) * k
            (handles[lab.replace(surf, "")],) = s.line(ax, np.asarray(df.index, dtype=float), y, label=lab, **style)
            drawn.append(y)
        ax.set_ylim(*span_limits(drawn, unit))
        ax.set_ylabel(label(var, unit))
        time_axis(ax, t0, t1, s)
    ax = axes[-1]
    s.log(ax)
    errors = [(dark_blue, COLOURS["closed"], "-")]
    if dark_blue is not closed:
        errors.append((closed, COLOURS["closed_last"], ":"))
    errors.append((result.open_loop, COLOURS["open"], "--"))
    drawn = []
    for run, colour, ls in errors:
        err = position_error(run, gen)
        y = np.maximum(err.to_numpy(float), 1e-9)
        s.line(ax, np.asarray(err.index, dtype=float), y, color=colour, lw=1.2, ls=ls)
        drawn.append(y)
    ax.set_ylim(*log_limits(drawn, 1e-9))
    ax.set_ylabel(label("|position - flat outputs|", "m"))
    time_axis(ax, t0, t1, s)
    s.legend(list(handles.values()), list(handles), ncol=3)
    return s.save(out_dir, name)
