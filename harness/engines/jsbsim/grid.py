"""JSBSim's step grid set by its own step alone, and its outputs on any time grid.

The step is the engine's setting (``JSBSimEngine.dt``), shortened at most to
divide the span exactly; it never depends on the output grid, so changing only
the output interval leaves the trajectory at the common times unchanged.
Output times on the step grid are the recorded states themselves; an output
time between two steps is interpolated by the cubic Lagrange polynomial
through the four surrounding steps (error of order ``dt^4`` times the fourth
derivative: about 1e-11 of the variable's scale at the default 1/480 s).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from gna.errors import InputError
from gna.trajectory import ANGLES, check_span
from gna.trajectory import output_grid as checked_output_times


def output_grid(
    t0: float, t1: float, dt_max: float, dt_out: float, t_eval
) -> tuple[int, float, np.ndarray, np.ndarray]:
    """The step grid (from the span and the largest step only), the output times and the steps to record.

    Parameters
    ----------
    t0, t1 : float
        Span [s].
    dt_max : float
        Largest step [s] (the engine's ``dt``).
    dt_out : float
        Output interval [s] (used when ``t_eval`` is None); it must divide the span
        (:func:`gna.trajectory.output_grid`, the same check as the in-house engine's).
    t_eval : array_like, shape (m,), or None
        Output times [s], inside the span, increasing.

    Returns
    -------
    n : int
        Number of steps.
    dt : float
        Step [s], ``(t1 - t0) / n``.
    out_times : ndarray, shape (m,)
        Output times [s].
    record : ndarray of int
        Step indices whose states are recorded (the output times on the grid,
        and the four neighbours of each output time between two steps).

    Raises
    ------
    InputError
        Bad span, ``dt_max``, ``dt_out`` or ``t_eval``.
    """
    t0, t1 = check_span((t0, t1))
    span = t1 - t0
    if not (math.isfinite(dt_max) and dt_max > 0):
        raise InputError(f"JSBSim step dt must be positive, got {dt_max}")
    n = max(int(math.ceil(span / dt_max - 1e-9)), 1)
    dt = span / n
    out = np.clip(checked_output_times(t0, t1, dt_out, t_eval), t0, t1)  # the in-house engine's checks
    s = (out - t0) / dt
    k = np.rint(s).astype(int)
    on = np.abs(s - k) <= 1e-6
    steps = [k[on]]
    kf = np.floor(s[~on]).astype(int)
    for off in (-1, 0, 1, 2):
        steps.append(np.clip(kf + off, 0, n))
    record = np.unique(np.concatenate(steps + [np.array([0])]))
    return n, dt, out, record


def resample(frame: pd.DataFrame, out_times: np.ndarray, t0: float, dt: float) -> pd.DataFrame:
    """A frame recorded at steps, at the output times: exact on the grid, cubic Lagrange between steps.

    Parameters
    ----------
    frame : DataFrame
        Indexed by the recorded step times [s] (``t0 + k dt``).
    out_times : ndarray, shape (m,)
        Output times [s].
    t0 : float
        Start of the step grid [s].
    dt : float
        Step [s].

    Returns
    -------
    DataFrame
        Indexed by the output times covered by the records (a run ended early
        covers fewer); angle columns are unwrapped over each stencil first.
    """
    if frame is None or frame.empty:
        return frame
    rec_t = np.asarray(frame.index, dtype=float)
    rec_k = np.rint((rec_t - t0) / dt).astype(int)
    pos = {int(k): i for i, k in enumerate(rec_k)}
    values = frame.to_numpy(dtype=float)
    angle_cols = [j for j, c in enumerate(frame.columns) if c in ANGLES]
    rows, times = [], []
    for tau in np.asarray(out_times, dtype=float):
        s = (tau - t0) / dt
        k = int(round(s))
        if abs(s - k) <= 1e-6:
            if k in pos:
                rows.append(values[pos[k]])
                times.append(float(rec_t[pos[k]]) if abs(rec_t[pos[k]] - tau) < 1e-9 * max(1.0, abs(tau)) else tau)
            continue
        kf = int(math.floor(s))
        ks = [kk for kk in (kf - 1, kf, kf + 1, kf + 2) if kk in pos]
        if kf not in pos or kf + 1 not in pos:
            continue  # beyond the end of a run stopped early
        V = values[[pos[kk] for kk in ks]]
        if angle_cols:
            V = V.copy()
            V[:, angle_cols] = np.unwrap(V[:, angle_cols], axis=0)
        x = np.array(ks, dtype=float)
        w = np.ones(len(ks))
        for a in range(len(ks)):
            for b in range(len(ks)):
                if a != b:
                    w[a] *= (s - x[b]) / (x[a] - x[b])
        rows.append(w @ V)
        times.append(float(tau))
    out = pd.DataFrame(
        np.array(rows, dtype=float).reshape(len(rows), values.shape[1]),
        index=pd.Index(times, name=frame.index.name),
        columns=frame.columns,
    )
    return out


def resample_result(res, out_times: np.ndarray, t0: float, dt: float):
    """A run's frames (trajectory, controller states, feedback) at the output times (:func:`resample`).

    Parameters
    ----------
    res : SimulationResult
        Recorded at steps of the grid ``t0 + k dt``.
    out_times : ndarray, shape (m,)
        Output times [s].
    t0 : float
        Start of the step grid [s].
    dt : float
        Step [s].

    Returns
    -------
    SimulationResult
        The same object, its frames replaced; ``t_end`` is the last output time kept.
    """
    res.df = resample(res.df, out_times, t0, dt)
    for name in ("controller_states", "feedback"):
        fr = getattr(res, name, None)
        if isinstance(fr, pd.DataFrame) and not fr.empty:
            setattr(res, name, resample(fr, out_times, t0, dt))
    if res.df.index.size and res.status != "completed":
        res.t_end = float(res.df.index[-1])
    return res
