"""Metrics of sets of runs: tables against the reference engine per window, deviation from the plan.

:func:`engine_tables` tabulates every run of a set against the first, per time
window (first 10 s, whole span); :func:`position_error` and
:func:`max_position_error` measure how far a flown trajectory is from the
planned flat outputs (x, y, z).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

from gna.errors import InputError
from gna.trajectory import POSITION

from .tables import DEFAULT_WINDOWS, DifferenceTable, _frame_of, difference_table


def window_span(t_span: tuple[float, float], duration: float | None) -> tuple[float, float | None]:
    """The time window of a named duration, clipped to the run's span.

    Parameters
    ----------
    t_span : (t0, t1)
        The run's span [s].
    duration : float or None
        Window length from ``t0`` [s]; ``None``: the whole span.

    Returns
    -------
    (float, float or None)
        ``(t0, t_hi)`` with ``t_hi = min(t0 + duration, t1)``, or ``(t0, None)``
        for the whole span (what :func:`difference_table` takes as ``window``).
    """
    t0 = float(t_span[0])
    return t0, None if duration is None else min(t0 + float(duration), float(t_span[1]))


def engine_tables(
    runs: Mapping,
    t_span: tuple[float, float],
    tolerances=None,
    windows: Mapping[str, float | None] | None = None,
    *,
    rtol=None,
) -> dict[str, dict[str, DifferenceTable]]:
    """Difference tables of every run against the first, per time window.

    Parameters
    ----------
    runs : mapping label -> SimulationResult or DataFrame
        Trajectories on the same output grid; the first is the reference.
    t_span : (t0, t1)
        Span flown [s].
    tolerances : None, float or mapping
        See :func:`difference_table`.
    windows : mapping name -> duration [s] or None, optional
        Default :data:`DEFAULT_WINDOWS`; see :func:`window_span`.
    rtol : None, float or mapping
        Relative tolerances, see :func:`difference_table`.

    Returns
    -------
    dict
        Label of every run but the first -> {window name -> DifferenceTable}.

    Raises
    ------
    InputError
        As :func:`difference_table`.
    """
    labels = list(runs)
    windows = DEFAULT_WINDOWS if windows is None else windows
    ref = labels[0] if labels else None
    return {
        other: {
            name: difference_table(
                runs[ref], runs[other], tolerances, window=window_span(t_span, dur), labels=(ref, other), rtol=rtol
            )
            for name, dur in windows.items()
        }
        for other in labels[1:]
    }


def position_error(trajectory, reference, window: tuple[float | None, float | None] | None = None) -> pd.Series:
    """Distance between a flown trajectory's position and a reference position (the flat outputs).

    Parameters
    ----------
    trajectory : DataFrame or SimulationResult
        Flown trajectory indexed by time ``t`` [s], with NED positions
        ``x, y, z`` [m].
    reference : callable or DataFrame
        The planned flat outputs: a callable ``t -> array`` whose first three
        rows are ``x, y, z`` [m] at the times ``t`` (shape (>=3, N) for N
        times; e.g. ``plan.state``), evaluated exactly at the trajectory's
        times; or a DataFrame indexed by ``t`` with columns ``x, y, z``,
        interpolated linearly onto them.
    window : (t_lo, t_hi), optional
        Time window [s] (``None`` ends: the trajectory's span).

    Returns
    -------
    pandas.Series
        ``|(x, y, z) - (x, y, z)_ref|`` [m] indexed by the trajectory's times
        in the window (NaN where the trajectory is NaN).

    Raises
    ------
    InputError
        A trajectory or reference of the wrong kind or shape, or times outside
        the reference DataFrame's span.
    """
    df = _frame_of(trajectory, "trajectory")
    t = np.asarray(df.index, dtype=float)
    lo = -np.inf if window is None or window[0] is None else float(window[0])
    hi = np.inf if window is None or window[1] is None else float(window[1])
    t = t[(t >= lo - 1e-9) & (t <= hi + 1e-9)]
    P = df.loc[t, ["x", "y", "z"]].to_numpy(float).T
    R = _reference_positions(reference, t)
    return pd.Series(np.sqrt(np.sum((P - R) ** 2, axis=0)), index=pd.Index(t, name="t"), name=POSITION)


def _reference_positions(reference: Callable | pd.DataFrame, t: np.ndarray) -> np.ndarray:
    if isinstance(reference, pd.DataFrame):
        tr = np.asarray(reference.index, dtype=float)
        if t.size and (t[0] < tr[0] - 1e-9 or t[-1] > tr[-1] + 1e-9):
            raise InputError(
                f"the reference covers t = {tr[0]:g} .. {tr[-1]:g} s, the trajectory t = {t[0]:g} .. {t[-1]:g} s"
            )
        return np.array([np.interp(t, tr, reference[c].to_numpy(float)) for c in ("x", "y", "z")])
    if not callable(reference):
        raise InputError(
            f"reference must be a callable t -> (x, y, z, ...) or a DataFrame, got {type(reference).__name__}"
        )
    R = np.asarray(reference(t), dtype=float)
    if R.ndim != 2 or R.shape[0] < 3 or R.shape[1] != t.size:
        raise InputError(f"reference(t) must have shape (>=3, {t.size}) for {t.size} times, got {R.shape}")
    return R[:3]


def max_position_error(trajectory, reference, window: tuple[float | None, float | None] | None = None) -> float:
    """Largest distance between a flown trajectory's position and the planned flat outputs.

    Parameters
    ----------
    trajectory : DataFrame or SimulationResult
        Flown trajectory indexed by time ``t`` [s], with NED positions ``x, y, z`` [m].
    reference : callable or DataFrame
        The planned flat outputs; see :func:`position_error`.
    window : (t_lo, t_hi), optional
        Time window [s]; e.g. ``(t0 + 5, None)`` for the error after the first 5 s.

    Returns
    -------
    float
        ``max |(x, y, z) - (x, y, z)_ref|`` [m] over the window; NaN when the
        trajectory holds NaN there or has no time in it.

    Raises
    ------
    InputError
        As :func:`position_error`.
    """
    err = position_error(trajectory, reference, window).to_numpy()
    if err.size == 0 or np.any(np.isnan(err)):
        return float("nan")
    return float(np.max(err))
