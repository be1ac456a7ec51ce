"""Test helpers for users' own tests (pytest or plain ``assert``).

:func:`assert_trajectories_close` compares an ``actual`` trajectory with an
``expected`` one column by column, ``|actual - expected| <= atol + rtol |expected|``
at every compared time (angles wrapped into (-pi, pi]), with tolerances per
quantity group (:data:`GROUPS`) or per column, and raises an
:class:`AssertionError` carrying the difference table.  The pytest plugin
(:mod:`harness.pytest_plugin`) builds its golden-trajectory fixture on it.

>>> from harness.testing import assert_trajectories_close
>>> assert_trajectories_close(expected=inhouse_run, actual=jsbsim_run,
...                           atol={"position": 1e-2, "angle": 1e-4, "mu": 2e-4})  # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from gna.eom import STATE_NAMES
from gna.errors import InputError
from gna.trajectory import ANGLES, UNITS

#: Quantity groups a tolerance may name, and their columns.
GROUPS: dict[str, tuple[str, ...]] = {
    "position": ("x", "y", "z"),
    "velocity": ("V",),
    "angle": ("gamma", "chi", "alpha", "beta", "mu"),
    "rate": ("p", "q", "r"),
}

#: Default absolute tolerances per group (SI units, rad): the cross-engine scale of
#: :data:`harness.metrics.DEFAULT_TOLERANCES` (matched physics, smooth controls, 10 s).
DEFAULT_ATOL: dict[str, float] = {"position": 1e-2, "velocity": 1e-3, "angle": 1e-4, "rate": 1e-3}

#: Default relative tolerances per group (none: absolute tolerances only).
DEFAULT_RTOL: dict[str, float] = {"position": 0.0, "velocity": 0.0, "angle": 0.0, "rate": 0.0}


def smooth_inputs(u0, twin: bool = False):
    """Smooth, vectorisable control inputs around a trim for engine checks.

    Thrust +-10 %, differential thrust +-0.3 (twins only), and aileron, elevator and rudder
    oscillations of 0.01--0.02 rad that start from zero slope.

    Parameters
    ----------
    u0 : array of shape (5,)
        Trim controls F [N], eta [-], dl, dm, dn [rad].
    twin : bool
        Vary the differential thrust eta too (aircraft with two engines).

    Returns
    -------
    callable
        ``u(t) -> [F, eta, dl, dm, dn]``, ``t`` [s] a float or an array.
    """

    def u(t):
        t = np.asarray(t, dtype=float)
        return [
            u0[0] * (1 + 0.1 * np.sin(0.5 * t)),
            u0[1] + (0.3 * np.sin(0.7 * t) if twin else 0 * t),
            u0[2] + 0.02 * np.sin(1.3 * t) * (1 - np.cos(0.8 * t)),
            u0[3] + 0.02 * np.sin(0.9 * t) * (1 - np.cos(0.7 * t)),
            u0[4] + 0.01 * np.sin(1.1 * t) * (1 - np.cos(0.6 * t)),
        ]

    return u


def _frame(obj, name: str) -> pd.DataFrame:
    df = getattr(obj, "df", obj)
    if not isinstance(df, pd.DataFrame):
        raise InputError(
            f"{name} must be a DataFrame indexed by time t [s] or a SimulationResult, got {type(obj).__name__}"
        )
    t = np.asarray(df.index, dtype=float)
    if t.size == 0:
        raise InputError(f"{name} is empty")
    if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
        raise InputError(f"{name}'s time index must be finite and increasing")
    return df


def resolve_tolerance(spec, defaults: Mapping[str, float], columns: Sequence[str], what: str) -> dict[str, float]:
    """Per-column tolerances from a tolerance spec.

    Parameters
    ----------
    spec : None, float or mapping str -> float
        ``None``: ``defaults`` (per group); a float: every column; a mapping whose keys are
        groups of :data:`GROUPS` or column names (a column's own value overrides its group's;
        groups and columns not named keep ``defaults``).
    defaults : mapping str -> float
        Default value per group.
    columns : sequence of str
        The compared columns.
    what : str
        ``"atol"`` or ``"rtol"`` (for messages).

    Returns
    -------
    dict of str to float
        Column -> tolerance (in the column's unit for ``atol``, a fraction for ``rtol``); columns
        without any value are absent.

    Raises
    ------
    InputError
        A negative, NaN or infinite tolerance, or a key that is neither a group nor a compared column.
    """

    def check(key, v):
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{what} of {key} must be a number, got {v!r}") from None
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"{what} of {key} must be a non-negative number, got {v}")
        return v

    if spec is not None and not isinstance(spec, Mapping):
        v = check("every column", spec)
        return {c: v for c in columns}
    spec = dict(spec or {})
    unknown = sorted(k for k in spec if k not in GROUPS and k not in columns)
    if unknown:
        raise InputError(
            f"{what} given for {', '.join(map(str, unknown))}: neither a group "
            f"({', '.join(GROUPS)}) nor a compared column"
        )
    out = {}
    for group, cols in GROUPS.items():
        value = spec.get(group, defaults.get(group))
        if value is not None:
            out.update({c: check(group, value) for c in cols if c in columns})
    out.update({c: check(c, spec[c]) for c in columns if c in spec})
    return out


def check_tolerances(atol, rtol, columns: Sequence[str]) -> tuple[dict[str, float], dict[str, float]]:
    """Per-column ``atol`` and ``rtol``, checked before anything is flown or written.

    Parameters
    ----------
    atol, rtol : None, float or mapping str -> float
        As :func:`assert_trajectories_close`.
    columns : sequence of str
        The compared columns.

    Returns
    -------
    tuple of dict
        Column -> atol, column -> rtol (:func:`resolve_tolerance`).

    Raises
    ------
    InputError
        A bad tolerance (:func:`resolve_tolerance`), or a column left without any tolerance.
    """
    at = resolve_tolerance(atol, DEFAULT_ATOL, columns, "atol")
    rt = resolve_tolerance(rtol, DEFAULT_RTOL, columns, "rtol")
    untoleranced = [c for c in columns if c not in at and c not in rt]
    if untoleranced:
        raise InputError(
            f"no tolerance for {', '.join(untoleranced)}: give atol={{'{untoleranced[0]}': ...}} or a single number"
        )
    return at, rt


def _values(df: pd.DataFrame, column: str, t: np.ndarray) -> np.ndarray:
    """``df[column]`` at times ``t`` (linear interpolation; angles unwrapped first)."""
    v = df[column].to_numpy(dtype=float)
    if column in ANGLES:
        v = np.unwrap(v)
    return np.interp(t, np.asarray(df.index, dtype=float), v)


def trajectory_differences(
    expected,
    actual,
    *,
    atol=None,
    rtol=None,
    columns: Sequence[str] | None = None,
    times=None,
    labels: tuple[str, str] = ("expected", "actual"),
) -> tuple[pd.DataFrame, list[str]]:
    """The difference table of :func:`assert_trajectories_close` without asserting.

    Parameters
    ----------
    expected, actual, atol, rtol, columns, times, labels
        As :func:`assert_trajectories_close`.

    Returns
    -------
    table : pandas.DataFrame
        One row per column (index): ``unit``, ``max_abs`` (largest ``|actual - expected|``),
        ``t_worst`` [s], ``expected`` and ``actual`` at that time, ``atol``, ``rtol``, ``ratio``
        (largest ``|difference| / (atol + rtol |expected|)``, <= 1 passes) and ``passed``.
    problems : list of str
        Coverage problems (a trajectory that does not cover the compared times).

    Raises
    ------
    InputError
        Not a trajectory, unknown columns, bad tolerances or times, no column with a tolerance.
    """
    E, A = _frame(expected, labels[0]), _frame(actual, labels[1])
    cols = tuple(columns) if columns is not None else STATE_NAMES
    missing = [c for c in cols if c not in E.columns or c not in A.columns]
    if missing:
        raise InputError(f"cannot compare {', '.join(missing)}: not a column of both {labels[0]} and {labels[1]}")
    at, rt = check_tolerances(atol, rtol, cols)
    te, ta = np.asarray(E.index, dtype=float), np.asarray(A.index, dtype=float)
    problems = []
    if times is None:
        t = te
    else:
        t = np.asarray(times, dtype=float).ravel()
        if t.size == 0 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputError("times must be a non-empty increasing sequence of finite times [s]")
    slack = 1e-9 * max(1.0, float(np.max(np.abs(t))))
    for lab, tt in ((labels[0], te), (labels[1], ta)):
        if tt[-1] < t[-1] - slack:
            problems.append(f"{lab} ends at t = {tt[-1]:.6g} s, before the last compared time t = {t[-1]:.6g} s")
        if tt[0] > t[0] + slack:
            problems.append(f"{lab} starts at t = {tt[0]:.6g} s, after the first compared time t = {t[0]:.6g} s")
    t = t[(t >= max(te[0], ta[0]) - slack) & (t <= min(te[-1], ta[-1]) + slack)]
    if t.size == 0:
        raise InputError(f"{labels[0]} and {labels[1]} share no compared time")
    rows = {}
    for c in cols:
        e, a = _values(E, c, t), _values(A, c, t)
        d = a - e
        if c in ANGLES:
            d = np.remainder(d + math.pi, 2.0 * math.pi) - math.pi
        allowed = at.get(c, 0.0) + rt.get(c, 0.0) * np.abs(e)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(d == 0.0, 0.0, np.abs(d) / allowed)
        ratio = np.where(np.isnan(d), np.inf, ratio)
        k = int(np.argmax(ratio))
        rows[c] = {
            "unit": UNITS.get(c, ""),
            "max_abs": float(np.max(np.abs(d))) if not np.isnan(d).any() else float("nan"),
            "t_worst": float(t[k]),
            "expected": float(e[k]),
            "actual": float(a[k]),
            "atol": at.get(c, 0.0),
            "rtol": rt.get(c, 0.0),
            "ratio": float(ratio[k]),
            "passed": bool(ratio[k] <= 1.0),
        }
    table = pd.DataFrame.from_dict(rows, orient="index")
    table.index.name = "column"
    return table, problems


def format_table(table: pd.DataFrame) -> str:
    """Fixed-width text of a :func:`trajectory_differences` table.

    Parameters
    ----------
    table : pandas.DataFrame
        The table.

    Returns
    -------
    str
    """
    head = (
        f"{'column':<8} {'unit':<6} {'max|diff|':>10} {'at t [s]':>10} {'expected':>13} {'actual':>13} "
        f"{'atol':>9} {'rtol':>9} {'ratio':>9}  verdict"
    )
    lines = [head, "-" * len(head)]
    for c, r in table.iterrows():
        lines.append(
            f"{c:<8} {r['unit']:<6} {r['max_abs']:>10.3e} {r['t_worst']:>10.4g} {r['expected']:>13.6g} "
            f"{r['actual']:>13.6g} {r['atol']:>9.2e} {r['rtol']:>9.2e} {r['ratio']:>9.3g}  "
            f"{'ok' if r['passed'] else 'FAIL'}"
        )
    return "\n".join(lines)


def assert_trajectories_close(
    expected,
    actual,
    *,
    atol=None,
    rtol=None,
    columns: Sequence[str] | None = None,
    times=None,
    labels: tuple[str, str] = ("expected", "actual"),
) -> pd.DataFrame:
    """Assert that ``actual`` follows ``expected``: ``|actual - expected| <= atol + rtol |expected|`` everywhere.

    Parameters
    ----------
    expected : SimulationResult or pandas.DataFrame
        The reference trajectory, indexed by time ``t`` [s] (increasing), columns in SI units and
        radians (:data:`gna.trajectory.UNITS`).
    actual : SimulationResult or pandas.DataFrame
        The trajectory under test, same layout (its own time grid).
    atol : None, float or mapping
        Absolute tolerances in each column's unit: ``None`` for :data:`DEFAULT_ATOL` (1e-2 m position,
        1e-3 m/s velocity, 1e-4 rad angles, 1e-3 rad/s rates); one number for every column; or a
        mapping of groups (``"position"``, ``"velocity"``, ``"angle"``, ``"rate"``, see :data:`GROUPS`)
        and columns to values, a column overriding its group, the rest keeping the defaults.
    rtol : None, float or mapping
        Relative tolerances (fractions of ``|expected|``), same forms; default 0.
    columns : sequence of str, optional
        Compared columns; default the 12 states. Other columns (controls, derived) need a tolerance
        in ``atol`` or ``rtol``.
    times : array_like, shape (n,), optional
        Compared times [s]; default the times of ``expected``. Both trajectories are interpolated
        linearly onto them (angles unwrapped first); they must cover them.
    labels : (str, str)
        Names of ``expected`` and ``actual`` in the message.

    Returns
    -------
    pandas.DataFrame
        The difference table (:func:`trajectory_differences`) when the trajectories agree.

    Raises
    ------
    AssertionError
        When a column exceeds its tolerance or a trajectory does not cover the compared times; the
        message names the failing columns and carries the whole difference table.
    InputError
        Not a trajectory, unknown columns, bad tolerances or times.
    """
    table, problems = trajectory_differences(
        expected, actual, atol=atol, rtol=rtol, columns=columns, times=times, labels=labels
    )
    failing = [c for c, ok in table["passed"].items() if not ok]
    if not failing and not problems:
        return table
    rule = "|actual - expected| <= atol + rtol |expected|"
    head = (
        f"{len(failing)} of {len(table)} columns exceed {rule} ({', '.join(failing)})"
        if failing
        else f"every column within {rule}, but the compared times are not covered"
    )
    lines = [f"trajectories differ: {labels[1]} (actual) vs {labels[0]} (expected): {head}"]
    lines += [f"  {p}" for p in problems]
    lines.append(format_table(table))
    raise AssertionError("\n".join(lines))
