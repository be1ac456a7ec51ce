"""Difference tables of two trajectories, and tolerance specs.

:func:`difference_table` compares two trajectories variable by variable: max
and RMS of the difference, time of the maximum, pass/fail against a
per-variable tolerance, and the relative difference ``delta_pct``.
``"position"`` is the distance ``|(dx, dy, dz)|``; angle differences are
wrapped into (-pi, pi].  :func:`differences` gives the difference itself as a
time series (for figures).

``delta_pct = 100 max|u - u_ref| / scale`` over the window (informative, never
a verdict).  The scale is ``max|u_ref|`` for variables with a physical zero
(V, gamma, alpha, beta, mu, rates, controls, forces, moments); for the
datum-dependent ones (x, y, z and ``"position"``: NED origin; chi: north) it is
the reference's excursion over the window, ``max u_ref - min u_ref``, so that
the same manoeuvre gives the same percentage wherever and whichever way it is
flown.  ``delta_pct`` is undefined (NaN) where the scale is at most the floor
of the variable's kind of quantity (:mod:`harness.metrics.scales`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from gna.eom import STATE_NAMES
from gna.errors import InputError
from gna.trajectory import ANGLES, POSITION, UNITS

from .scales import DATUM_DEPENDENT, DEFAULT_TOLERANCES, PERCENT_FLOORS, REFERENCE_ZERO, percent_floor, percent_scale  # noqa: F401

#: Default variables of a table: position, then the 12 states.
DEFAULT_VARIABLES: tuple[str, ...] = (POSITION,) + STATE_NAMES

#: Comparison windows: name -> duration from t0 [s] (None: the whole span).
DEFAULT_WINDOWS: dict[str, float | None] = {"first 10 s": 10.0, "whole span": None}


@dataclass(frozen=True)
class DifferenceRow:
    """One variable of a :class:`DifferenceTable` (``passed`` is None without a tolerance).

    Attributes
    ----------
    variable : str
    unit : str
        SI unit (:data:`gna.trajectory.UNITS`).
    max_abs : float
        Largest absolute difference (NaN when a value is NaN).
    rms : float
        Root mean square of the difference.
    t_max : float
        Time of the largest difference [s].
    tolerance : float or None
        Tolerance applied, ``atol + rtol * ref_max``.
    passed : bool or None
    ref_max : float
        Largest absolute value of the reference over the window (the distance
        from the origin for ``"position"``): the scale of ``rtol``.
    delta_pct : float
        Relative difference ``100 max|u - u_ref| / scale`` [%] over the window;
        NaN where the scale is at most the floor of the variable's kind of
        quantity (:func:`percent_floor`): a reference within the absolute
        agreement of its kind of zero is no scale for a percentage.
    atol, rtol : float or None
        Absolute and relative parts of the tolerance, as given.
    scale : float
        Denominator of ``delta_pct`` (:func:`percent_scale`): ``max|u_ref|``,
        or for x, y, z, ``"position"`` and chi (:data:`DATUM_DEPENDENT`) the
        reference's excursion over the window, ``max u_ref - min u_ref``.
    """

    variable: str
    unit: str
    max_abs: float
    rms: float
    t_max: float
    tolerance: float | None
    passed: bool | None
    ref_max: float = float("nan")
    delta_pct: float = float("nan")
    atol: float | None = None
    rtol: float | None = None
    scale: float = float("nan")


@dataclass
class DifferenceTable:
    """Per-variable differences ``b - a`` over a time window.

    Attributes
    ----------
    rows : list of DifferenceRow
    labels : (str, str)
        Names of ``a`` (the reference) and ``b``.
    window : (float, float)
        Time window actually compared [s].
    samples : int
    notes : list of str
        Coverage problems (a trajectory ending early); any note fails the table.
    """

    rows: list
    labels: tuple[str, str]
    window: tuple[float, float]
    samples: int
    notes: list = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """True when every toleranced variable passes and both trajectories cover the window."""
        return not self.notes and all(r.passed is not False for r in self.rows)

    def failures(self) -> list[DifferenceRow]:
        """The rows beyond their tolerance.

        Returns
        -------
        list of DifferenceRow
        """
        return [r for r in self.rows if r.passed is False]

    def row(self, variable: str) -> DifferenceRow:
        """The row of one variable.

        Parameters
        ----------
        variable : str
            Compared variable (column name or ``"position"``).

        Returns
        -------
        DifferenceRow

        Raises
        ------
        KeyError
            The variable was not compared.
        """
        for r in self.rows:
            if r.variable == variable:
                return r
        raise KeyError(variable)

    def to_frame(self) -> pd.DataFrame:
        """The table as a DataFrame.

        Returns
        -------
        pandas.DataFrame
            Indexed by variable; columns ``unit, max_abs, t_max, rms, delta_pct, scale, ref_max, atol, rtol,
            tolerance, passed``.
        """
        return pd.DataFrame(
            [
                {
                    "variable": r.variable,
                    "unit": r.unit,
                    "max_abs": r.max_abs,
                    "t_max": r.t_max,
                    "rms": r.rms,
                    "delta_pct": r.delta_pct,
                    "scale": r.scale,
                    "ref_max": r.ref_max,
                    "atol": r.atol,
                    "rtol": r.rtol,
                    "tolerance": r.tolerance,
                    "passed": r.passed,
                }
                for r in self.rows
            ]
        ).set_index("variable")

    def format(self) -> str:
        """The printed difference table.

        Returns
        -------
        str
            Header (labels, window, samples), one line per variable, notes, overall result.
        """
        a, b = self.labels
        lines = [
            f"difference {b} - {a}, t in [{self.window[0]:g}, {self.window[1]:g}] s, {self.samples} samples",
            f"  {'variable':<9} {'unit':<6} {'max |diff|':>11} {'at t [s]':>9} {'RMS':>10} "
            f"{'delta [%]':>10} {'tolerance':>10}  result",
        ]
        for r in self.rows:
            tol = f"{r.tolerance:10.1e}" if r.tolerance is not None else f"{'-':>10}"
            res = {True: "pass", False: "FAIL", None: ""}[r.passed]
            delta = f"{r.delta_pct:10.3e}" if math.isfinite(r.delta_pct) else f"{'-':>10}"
            lines.append(
                f"  {r.variable:<9} {r.unit:<6} {r.max_abs:11.3e} {r.t_max:9.3f} {r.rms:10.3e} {delta} {tol}  {res}"
            )
        for n in self.notes:
            lines.append(f"  note: {n}")
        fails = [r.variable for r in self.failures()]
        if self.passed and all(r.tolerance is None for r in self.rows):
            lines.append("  overall: - (no tolerances given: informative)")
        elif self.passed:
            lines.append("  overall: PASS")
        else:
            lines.append("  overall: FAIL" + (f" ({', '.join(fails)})" if fails else " (coverage)"))
        floors = dict.fromkeys(f"{percent_floor(r.variable):g} {r.unit}".strip(" -") for r in self.rows)
        foot = (
            f"delta = 100 max|diff| / scale over the window, scale = max|reference| (its excursion max - min "
            f"for x, y, z, chi; the path's diameter for position), undefined (-) where the scale is at most the "
            f"floor of its kind ({', '.join(floors)})"
        )
        if any(r.rtol for r in self.rows):
            foot = "tolerance = atol + rtol * max |reference| over the window; " + foot
        lines.append(f"  ({foot})")
        return "\n".join(lines)

    __str__ = format


def _frame_of(obj, name: str) -> pd.DataFrame:
    df = getattr(obj, "df", obj)
    if not isinstance(df, pd.DataFrame):
        raise InputError(f"{name} must be a DataFrame indexed by t or a simulation result, got {type(obj).__name__}")
    if df.index.size and not np.all(np.diff(np.asarray(df.index, dtype=float)) > 0):
        raise InputError(f"{name}'s time index must be increasing")
    return df


def resolve_tolerances(tolerances, variables: Sequence[str]) -> dict[str, float]:
    """The per-variable tolerances of a tolerance spec.

    Parameters
    ----------
    tolerances : None, float or mapping str -> float or None
        ``None``: :data:`DEFAULT_TOLERANCES` restricted to ``variables``; a
        float: the same absolute tolerance (in each variable's SI unit) for
        every variable; a mapping variable -> tolerance (``None`` values are
        dropped: reported without pass/fail).
    variables : sequence of str
        The compared variables (column names, or ``"position"``).

    Returns
    -------
    dict
        Variable -> absolute tolerance, in the variable's unit
        (:data:`gna.trajectory.UNITS`).

    Raises
    ------
    InputError
        A tolerance that is negative, NaN or infinite.
    """
    if tolerances is None:
        return {v: DEFAULT_TOLERANCES[v] for v in variables if v in DEFAULT_TOLERANCES}
    if isinstance(tolerances, Mapping):
        out = {}
        for k, v in tolerances.items():
            if v is None:
                continue
            v = float(v)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"tolerance of {k} must be a non-negative number, got {v}")
            out[str(k)] = v
        return out
    v = float(tolerances)
    if not (math.isfinite(v) and v >= 0):
        raise InputError(f"tolerance must be a non-negative number, got {tolerances}")
    return {k: v for k in variables}


def difference_table(
    a,
    b,
    tolerances=None,
    *,
    variables: Sequence[str] | None = None,
    window: tuple[float | None, float | None] | None = None,
    labels: tuple[str, str] = ("a", "b"),
    interpolate: bool = False,
    rtol=None,
) -> DifferenceTable:
    """Per-variable max and RMS of ``b - a``, time of the maximum and pass/fail.

    Parameters
    ----------
    a : DataFrame or SimulationResult
        Reference trajectory, indexed by time ``t`` [s] (increasing), columns
        in SI units and radians (:data:`gna.trajectory.UNITS`).
    b : DataFrame or SimulationResult
        Compared trajectory, same layout as ``a``.
    tolerances : None, float or mapping
        ``None``: :data:`DEFAULT_TOLERANCES`; a float: the same absolute
        tolerance for every variable; a mapping variable -> tolerance (variables
        not in it are reported without pass/fail).  See :func:`resolve_tolerances`.
    variables : sequence of str, optional
        Columns to compare (``"position"`` for the distance [m]); default the
        position and the 12 states, plus any other toleranced column.
    window : (t_lo, t_hi), optional
        Time window [s] (``None`` ends: the trajectories' common span).
    labels : (str, str)
        Names of ``a`` and ``b`` in the table and its messages.
    interpolate : bool
        If the time grids differ, interpolate ``b`` linearly onto ``a``'s
        times; without it, only the times present in both are compared.
    rtol : None, float or mapping
        Relative tolerances (same forms as ``tolerances``, no default): a
        variable passes when ``max|b - a| <= atol + rtol * max|a|`` over the window.

    Returns
    -------
    DifferenceTable
        One row per variable; notes when a trajectory does not cover the window.

    Raises
    ------
    InputError
        Unknown variables, tolerances of variables not compared, a bad
        tolerance, an empty trajectory, or no common times.
    """
    A, B = _frame_of(a, labels[0]), _frame_of(b, labels[1])
    tol_in = tolerances
    if variables is None:
        extra = [k for k in (tol_in if isinstance(tol_in, Mapping) else {}) if k not in DEFAULT_VARIABLES]
        variables = DEFAULT_VARIABLES + tuple(extra)
    variables = tuple(variables)
    tol = resolve_tolerances(tol_in, variables)
    rel = resolve_tolerances(rtol, variables) if rtol is not None else {}
    need = set()
    for v in variables:
        need |= {"x", "y", "z"} if v == POSITION else {v}
    missing = sorted(n for n in need if n not in A.columns or n not in B.columns)
    if missing:
        raise InputError(f"cannot compare {', '.join(missing)}: not a column of both trajectories")
    unknown_tol = sorted(k for k in {**tol, **rel} if k not in variables)
    if unknown_tol:
        raise InputError(f"tolerances given for variables not compared: {', '.join(unknown_tol)}")

    ta, tb = np.asarray(A.index, dtype=float), np.asarray(B.index, dtype=float)
    if ta.size == 0 or tb.size == 0:
        raise InputError("cannot compare an empty trajectory")
    span_a, span_b = (ta[0], ta[-1]), (tb[0], tb[-1])
    lo = max(span_a[0], span_b[0]) if window is None or window[0] is None else float(window[0])
    hi_req = None if window is None else window[1]
    hi_common = min(span_a[1], span_b[1])
    hi = hi_common if hi_req is None else min(float(hi_req), hi_common)
    notes = []
    want_hi = max(span_a[1], span_b[1]) if hi_req is None else float(hi_req)
    for lab, sp in ((labels[0], span_a), (labels[1], span_b)):
        if sp[1] < want_hi - 1e-9:
            notes.append(f"{lab} ends at t = {sp[1]:.6g} s, before the end of the window (t = {want_hi:.6g} s)")
        if sp[0] > lo + 1e-9:
            notes.append(f"{lab} starts at t = {sp[0]:.6g} s, after the start of the window (t = {lo:.6g} s)")
    sel_a = (ta >= lo - 1e-9) & (ta <= hi + 1e-9)
    tt = ta[sel_a]
    tol_t = 1e-9 * max(1.0, float(np.max(np.abs(ta))))
    if interpolate:
        tt = tt[(tt >= tb[0] - tol_t) & (tt <= tb[-1] + tol_t)]
        ia = np.searchsorted(ta, tt)
        Bv = {
            n: np.interp(tt, tb, np.unwrap(B[n].to_numpy(float)) if n in ANGLES else B[n].to_numpy(float)) for n in need
        }
        Av = {n: A[n].to_numpy(float)[ia] for n in need}
    else:
        j = np.searchsorted(tb, tt)
        j = np.clip(j, 0, tb.size - 1)
        jm = np.clip(j - 1, 0, tb.size - 1)
        j = np.where(np.abs(tb[jm] - tt) < np.abs(tb[j] - tt), jm, j)
        match = np.abs(tb[j] - tt) <= tol_t
        ia = np.nonzero(sel_a)[0][match]
        jb = j[match]
        tt = ta[ia]
        Av = {n: A[n].to_numpy(float)[ia] for n in need}
        Bv = {n: B[n].to_numpy(float)[jb] for n in need}
    if tt.size == 0:
        raise InputError(
            f"{labels[0]} and {labels[1]} have no common output times in [{lo:g}, {hi:g}] s"
            + ("" if interpolate else "; pass interpolate=True to compare different grids")
        )

    rows = []
    for v in variables:
        d = difference(v, Av, Bv)
        ad = np.abs(d)
        if np.all(np.isnan(ad)):
            mx, tm, rms = float("nan"), float("nan"), float("nan")
        else:
            k = int(np.nanargmax(ad)) if not np.any(np.isnan(ad)) else int(np.argmax(np.isnan(ad)))
            mx = float(ad[k]) if not np.isnan(ad[k]) else float("nan")
            tm = float(tt[k])
            rms = float(np.sqrt(np.mean(d * d)))
        ref = np.abs(_reference(v, Av))
        ref_max = float(np.max(ref)) if ref.size and not np.any(np.isnan(ref)) else float("nan")
        scale = percent_scale(v, Av)
        pct = 100.0 * mx / scale if scale > percent_floor(v) else float("nan")
        a_, r_ = tol.get(v), rel.get(v)
        t_ = None if a_ is None and r_ is None else (a_ or 0.0) + (r_ or 0.0) * (ref_max if ref_max > 0 else 0.0)
        passed = None if t_ is None else bool(np.isfinite(mx) and mx <= t_)
        rows.append(DifferenceRow(v, UNITS.get(v, ""), mx, rms, tm, t_, passed, ref_max, pct, a_, r_, scale))
    return DifferenceTable(
        rows=rows, labels=tuple(labels), window=(float(tt[0]), float(tt[-1])), samples=int(tt.size), notes=notes
    )


def _reference(variable: str, A: Mapping):
    """The reference's values of one variable (its distance from the origin for the position)."""
    if variable == POSITION:
        return np.sqrt(sum(A[c] ** 2 for c in ("x", "y", "z")))
    return A[variable]


def difference(variable: str, A: Mapping, B: Mapping):
    """``B - A`` of one variable on samples already aligned: the one formula of every difference table and figure.

    Parameters
    ----------
    variable : str
        A state or control name, or ``"position"``.
    A, B : mapping
        Column name -> array (or Series) of the same samples; ``x``, ``y``, ``z`` [m] for the position.

    Returns
    -------
    array or Series
        The difference in the variable's unit; the distance between the positions [m] for ``"position"``;
        wrapped into [-pi, pi) [rad] for angles.
    """
    if variable == POSITION:
        return np.sqrt(sum((B[c] - A[c]) ** 2 for c in ("x", "y", "z")))
    d = B[variable] - A[variable]
    if variable in ANGLES:
        d = np.remainder(d + math.pi, 2.0 * math.pi) - math.pi
    return d


def differences(a, b, variable: str) -> pd.Series:
    """The difference ``b - a`` of one variable at the times both trajectories share.

    Parameters
    ----------
    a : DataFrame or SimulationResult
        Reference trajectory indexed by time ``t`` [s].
    b : DataFrame or SimulationResult
        Compared trajectory indexed by time ``t`` [s].
    variable : str
        A column of both, or ``"position"`` (distance between the positions [m]).

    Returns
    -------
    pandas.Series
        Indexed by the common times [s], in the variable's unit; angle
        differences wrapped into (-pi, pi].

    Raises
    ------
    InputError
        A trajectory that is not a DataFrame, or a variable missing from either.
    """
    A, B = _frame_of(a, "a"), _frame_of(b, "b")
    cols = ("x", "y", "z") if variable == POSITION else (variable,)
    missing = [c for c in cols if c not in A.columns or c not in B.columns]
    if missing:
        raise InputError(f"cannot compare {', '.join(missing)}: not a column of both trajectories")
    common = A.index.intersection(B.index)
    d = difference(variable, {c: A.loc[common, c] for c in cols}, {c: B.loc[common, c] for c in cols})
    return pd.Series(np.asarray(d, dtype=float), index=common, name=variable)
