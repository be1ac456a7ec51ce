"""Trajectory comparison: difference tables, tolerance specs, cross-engine runs with figures.

:func:`difference_table` compares two trajectories (DataFrames indexed by
``t``, or :class:`gna.simulate.SimulationResult`) variable by variable: max
and RMS of the difference, time of the maximum, pass/fail against a
per-variable tolerance.  ``"position"`` is the distance ``|(dx, dy, dz)|``;
angle differences are wrapped into (-pi, pi].

:func:`compare_engines` flies one problem on several engines
(:func:`harness.propulsion.fly`), tabulates each engine against the first over
the first 10 s and the whole span, and writes figures of the engines against
a reference (the plan).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.errors import InputError
from gna.trajectory import ANGLES, POSITION, UNITS

from .engines import fly

#: Default variables of a table: position, then the 12 states.
DEFAULT_VARIABLES: tuple[str, ...] = (POSITION,) + STATE_NAMES

#: Cross-engine tolerance spec (issue 5's target for matched physics and smooth
#: controls over 10 s: 1e-2 m in position, 1e-4 rad in angles; speed and rates
#: get the same relative scale, 1e-3 m/s and 1e-3 rad/s).
DEFAULT_TOLERANCES: dict[str, float] = {
    POSITION: 1e-2, "x": 1e-2, "y": 1e-2, "z": 1e-2, "V": 1e-3,
    "gamma": 1e-4, "chi": 1e-4, "alpha": 1e-4, "beta": 1e-4, "mu": 1e-4,
    "p": 1e-3, "q": 1e-3, "r": 1e-3,
}

#: Windows of :func:`compare_engines`: name -> duration from t0 (None: whole span).
DEFAULT_WINDOWS: dict[str, float | None] = {"first 10 s": 10.0, "whole span": None}


@dataclass(frozen=True)
class DifferenceRow:
    """One variable of a :class:`DifferenceTable` (``passed`` is None without a tolerance)."""

    variable: str
    unit: str
    max_abs: float
    rms: float
    t_max: float
    tolerance: float | None
    passed: bool | None


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
        return [r for r in self.rows if r.passed is False]

    def row(self, variable: str) -> DifferenceRow:
        for r in self.rows:
            if r.variable == variable:
                return r
        raise KeyError(variable)

    def to_frame(self) -> pd.DataFrame:
        """The table as a DataFrame indexed by variable."""
        return pd.DataFrame([{"variable": r.variable, "unit": r.unit, "max_abs": r.max_abs, "t_max": r.t_max,
                              "rms": r.rms, "tolerance": r.tolerance, "passed": r.passed} for r in self.rows]
                            ).set_index("variable")

    def format(self) -> str:
        """The printed difference table."""
        a, b = self.labels
        lines = [f"difference {b} - {a}, t in [{self.window[0]:g}, {self.window[1]:g}] s, {self.samples} samples",
                 f"  {'variable':<9} {'unit':<6} {'max |diff|':>11} {'at t [s]':>9} {'RMS':>10} "
                 f"{'tolerance':>10}  result"]
        for r in self.rows:
            tol = f"{r.tolerance:10.1e}" if r.tolerance is not None else f"{'-':>10}"
            res = {True: "pass", False: "FAIL", None: ""}[r.passed]
            lines.append(f"  {r.variable:<9} {r.unit:<6} {r.max_abs:11.3e} {r.t_max:9.3f} {r.rms:10.3e} {tol}  {res}")
        for n in self.notes:
            lines.append(f"  note: {n}")
        fails = [r.variable for r in self.failures()]
        if self.passed and all(r.tolerance is None for r in self.rows):
            lines.append("  overall: - (no tolerances given: informative)")
        elif self.passed:
            lines.append("  overall: PASS")
        else:
            lines.append("  overall: FAIL" + (f" ({', '.join(fails)})" if fails else " (coverage)"))
        return "\n".join(lines)

    __str__ = format


def _frame_of(obj, name: str) -> pd.DataFrame:
    df = getattr(obj, "df", obj)
    if not isinstance(df, pd.DataFrame):
        raise InputError(f"{name} must be a DataFrame indexed by t or a simulation result, got {type(obj).__name__}")
    if df.index.size and not np.all(np.diff(np.asarray(df.index, dtype=float)) > 0):
        raise InputError(f"{name}'s time index must be increasing")
    return df


def _resolve_tolerances(tol, variables: Sequence[str]) -> dict[str, float]:
    if tol is None:
        return {v: DEFAULT_TOLERANCES[v] for v in variables if v in DEFAULT_TOLERANCES}
    if isinstance(tol, Mapping):
        out = {}
        for k, v in tol.items():
            if v is None:
                continue
            v = float(v)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"tolerance of {k} must be a non-negative number, got {v}")
            out[str(k)] = v
        return out
    v = float(tol)
    if not (math.isfinite(v) and v >= 0):
        raise InputError(f"tolerance must be a non-negative number, got {tol}")
    return {k: v for k in variables}


def difference_table(a, b, tolerances=None, *, variables: Sequence[str] | None = None,
                     window: tuple[float | None, float | None] | None = None,
                     labels: tuple[str, str] = ("a", "b"), interpolate: bool = False) -> DifferenceTable:
    """Per-variable max and RMS of ``b - a``, time of the maximum and pass/fail.

    Parameters
    ----------
    a, b : DataFrame or SimulationResult
        Trajectories indexed by time ``t`` [s]; ``a`` is the reference.
    tolerances : None, float or mapping
        ``None``: :data:`DEFAULT_TOLERANCES`; a float: the same absolute
        tolerance for every variable; a mapping variable -> tolerance (variables
        not in it are reported without pass/fail).
    variables : sequence of str, optional
        Columns to compare (``"position"`` for the distance); default the
        position and the 12 states, plus any other toleranced column.
    window : (t_lo, t_hi), optional
        Time window (``None`` ends: the trajectories' common span).
    labels : (str, str)
    interpolate : bool
        If the time grids differ, interpolate ``b`` linearly onto ``a``'s
        times; without it, only the times present in both are compared.

    Returns
    -------
    DifferenceTable

    Raises
    ------
    InputError
        Unknown variables, or no common times.
    """
    A, B = _frame_of(a, labels[0]), _frame_of(b, labels[1])
    tol_in = tolerances
    if variables is None:
        extra = [k for k in (tol_in if isinstance(tol_in, Mapping) else {}) if k not in DEFAULT_VARIABLES]
        variables = DEFAULT_VARIABLES + tuple(extra)
    variables = tuple(variables)
    tol = _resolve_tolerances(tol_in, variables)
    need = set()
    for v in variables:
        need |= {"x", "y", "z"} if v == POSITION else {v}
    missing = sorted(n for n in need if n not in A.columns or n not in B.columns)
    if missing:
        raise InputError(f"cannot compare {', '.join(missing)}: not a column of both trajectories")
    unknown_tol = sorted(k for k in tol if k not in variables)
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
        Bv = {n: np.interp(tt, tb, np.unwrap(B[n].to_numpy(float)) if n in ANGLES else B[n].to_numpy(float))
              for n in need}
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
        raise InputError(f"{labels[0]} and {labels[1]} have no common output times in [{lo:g}, {hi:g}] s"
                         + ("" if interpolate else "; pass interpolate=True to compare different grids"))

    rows = []
    for v in variables:
        if v == POSITION:
            d = np.sqrt(sum((Bv[c] - Av[c]) ** 2 for c in ("x", "y", "z")))
        else:
            d = Bv[v] - Av[v]
            if v in ANGLES:
                d = np.remainder(d + math.pi, 2.0 * math.pi) - math.pi
        ad = np.abs(d)
        if np.all(np.isnan(ad)):
            mx, tm, rms = float("nan"), float("nan"), float("nan")
        else:
            k = int(np.nanargmax(ad)) if not np.any(np.isnan(ad)) else int(np.argmax(np.isnan(ad)))
            mx = float(ad[k]) if not np.isnan(ad[k]) else float("nan")
            tm = float(tt[k])
            rms = float(np.sqrt(np.mean(d * d)))
        t_ = tol.get(v)
        passed = None if t_ is None else bool(np.isfinite(mx) and mx <= t_)
        rows.append(DifferenceRow(v, UNITS.get(v, ""), mx, rms, tm, t_, passed))
    return DifferenceTable(rows=rows, labels=tuple(labels), window=(float(tt[0]), float(tt[-1])),
                           samples=int(tt.size), notes=notes)


# --------------------------------------------------------------------------- cross-engine comparison

@dataclass
class EngineComparison:
    """Result of :func:`compare_engines`.

    Attributes
    ----------
    results : dict
        Engine label -> SimulationResult.
    tables : dict
        Engine label (every engine but the reference) -> {window name -> DifferenceTable}.
    reference_engine : str
        Label of the engine the others are compared with (the first).
    figures : list of Path
        Figures written (empty without ``out_dir``).
    """

    results: dict
    tables: dict
    reference_engine: str
    figures: list = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return all(t.passed for per in self.tables.values() for t in per.values())

    def table(self, window: str = "whole span", engine: str | None = None) -> DifferenceTable:
        """One table (``engine`` defaults to the only compared engine)."""
        if engine is None:
            if len(self.tables) != 1:
                raise InputError(f"several engines compared ({', '.join(self.tables)}): name one")
            engine = next(iter(self.tables))
        return self.tables[engine][window]

    def report(self) -> str:
        """All tables, with the run status and settings of each engine."""
        out = []
        for label, res in self.results.items():
            s = res.settings
            extra = (f"dt = {s['dt']:.6g} s, integrators {s['integrators']}, earth {s['earth']}"
                     if s.get("engine") == "jsbsim" else
                     f"{s.get('method')} rtol = {s.get('rtol')}, atol = {s.get('atol')}")
            out.append(f"{label}: {res.status}{(' - ' + res.message) if res.message else ''}; {extra}")
            out += [f"  warning: {w}" for w in res.warnings]
        for label, per in self.tables.items():
            for name, t in per.items():
                out.append(f"[{name}]")
                out.append(t.format())
        return "\n".join(out)


def _reference_frame(reference, times: np.ndarray) -> pd.DataFrame | None:
    if reference is None:
        return None
    if isinstance(reference, pd.DataFrame):
        return reference
    if callable(reference):
        try:
            X = np.asarray(reference(times), dtype=float)
        except Exception:  # not vectorised: evaluate point by point
            X = None
        if X is None or X.shape != (12, times.size):
            X = np.array([np.asarray(reference(float(t)), dtype=float).reshape(12) for t in times]).T
        return pd.DataFrame({n: X[i] for i, n in enumerate(STATE_NAMES)}, index=pd.Index(times, name="t"))
    raise InputError("reference must be a DataFrame of states indexed by t, or a callable t -> 12 states")


def compare_engines(aircraft, controls, t_span=None, x0=None, *, engines=("inhouse", "jsbsim"), env=None,
                    controller=None, dt_out: float = 0.02, tolerances=None,
                    windows: Mapping[str, float | None] | None = None, out_dir: str | Path | None = None,
                    reference=None, title: str | None = None) -> EngineComparison:
    """Fly one problem on several engines and compare each with the first.

    Parameters
    ----------
    aircraft : Aircraft
    controls : control source
        Callable ``t -> 5 controls``, a plan exposing ``controls(t)``,
        ``initial_state``, ``state(t)``, ``env``, ``t0`` and ``t1``
        (:class:`planners.plan.Plan`), or 5 constants; flown open loop unless
        ``controller`` is given.
    t_span : (t0, t1) or None
        Default: the plan's ``(t0, t1)``.
    x0 : array of 12, optional
        Default: the control source's ``initial_state``.
    engines : iterable or mapping
        See :func:`harness.propulsion.fly`; the first is the reference.
    env, controller, dt_out
        As in :func:`harness.propulsion.fly` (``env`` defaults to the plan's).
    tolerances : None, float or mapping
        See :func:`difference_table` (default :data:`DEFAULT_TOLERANCES`).
    windows : mapping name -> duration from t0 or None
        Default :data:`DEFAULT_WINDOWS` (first 10 s, whole span).
    out_dir : path, optional
        Folder for the figures and ``differences.txt``.
    reference : DataFrame or callable t -> 12 states, optional
        The planned trajectory, drawn in the figures (default: the plan's
        ``state``).  For another iterate than the plan's last, pass
        ``controls=plan.control_function(J)``, ``x0=plan.initial_state(J)``,
        ``reference=lambda t: plan.state(t, J)`` and ``env=plan.env``.
    title : str, optional

    Returns
    -------
    EngineComparison
    """
    if t_span is None:
        t_span = (getattr(controls, "t0", None), getattr(controls, "t1", None))
        if None in t_span:
            raise InputError("no time span: pass t_span or a plan with t0 and t1")
    if reference is None and callable(getattr(controls, "state", None)):
        reference = controls.state
    results = fly(engines, aircraft, x0, controls, t_span, env=env, controller=controller, dt_out=dt_out)
    labels = list(results)
    if len(labels) < 2:
        raise InputError("compare_engines needs at least two engines")
    ref = labels[0]
    t0 = float(t_span[0])
    windows = dict(DEFAULT_WINDOWS if windows is None else windows)
    tables = {}
    for other in labels[1:]:
        per = {}
        for name, dur in windows.items():
            # a window longer than the run is clipped to the run's span
            win = (t0, None if dur is None else min(t0 + float(dur), float(t_span[1])))
            per[name] = difference_table(results[ref], results[other], tolerances, window=win, labels=(ref, other))
        tables[other] = per
    comp = EngineComparison(results=results, tables=tables, reference_engine=ref)
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        times = np.asarray(results[ref].df.index, dtype=float)
        refdf = _reference_frame(reference, times)
        heading = title or f"{aircraft.id}: {' vs '.join(labels)}"
        comp.figures = write_figures(results, out, reference=refdf, title=heading, tolerances=tolerances)
        (out / "differences.txt").write_text(heading + "\n" + comp.report() + "\n", encoding="utf-8")
    return comp


_DEG = {"gamma", "chi", "alpha", "beta", "mu", "dl", "dm", "dn"}
_DEG_S = {"p", "q", "r"}


def _plot_scale(name: str) -> tuple[float, str]:
    if name in _DEG:
        return math.degrees(1.0), "deg"
    if name in _DEG_S:
        return math.degrees(1.0), "deg/s"
    return 1.0, UNITS.get(name, "")


def write_figures(results: Mapping, out_dir: str | Path, *, reference: pd.DataFrame | None = None,
                  title: str = "", tolerances=None) -> list[Path]:
    """States and controls of every engine (and the reference), and the differences to the first engine.

    Returns the paths of ``states.png``, ``controls.png`` and ``differences.png``.
    """
    from matplotlib.figure import Figure  # no pyplot: no global state

    out = Path(out_dir)
    labels = list(results)
    paths = []

    fig = Figure(figsize=(13, 11), layout="constrained")
    axs = fig.subplots(4, 3, sharex=True)
    for ax, name in zip(axs.ravel(), STATE_NAMES):
        k, unit = _plot_scale(name)
        if reference is not None and name in reference.columns:
            ax.plot(reference.index, reference[name] * k, "k:", lw=2.0, label="plan")
        for i, lab in enumerate(labels):
            df = results[lab].df
            ax.plot(df.index, df[name] * k, lw=1.2, ls="-" if i == 0 else "--", label=lab)
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("t [s]")
    axs[0, 0].legend(fontsize=8)
    fig.suptitle(f"{title}: states")
    paths.append(out / "states.png")
    fig.savefig(paths[-1], dpi=110)

    fig = Figure(figsize=(13, 7), layout="constrained")
    axs = fig.subplots(2, 3, sharex=True)
    for ax, name in zip(axs.ravel(), CONTROL_NAMES):
        k, unit = _plot_scale(name)
        for i, lab in enumerate(labels):
            df = results[lab].df
            ax.plot(df.index, df[name] * k, lw=1.2, ls="-" if i == 0 else "--", label=lab)
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(alpha=0.3)
    axs.ravel()[-1].axis("off")
    for ax in axs[-1]:
        ax.set_xlabel("t [s]")
    axs[0, 0].legend(fontsize=8)
    fig.suptitle(f"{title}: applied controls")
    paths.append(out / "controls.png")
    fig.savefig(paths[-1], dpi=110)

    if len(labels) > 1:
        tol = _resolve_tolerances(tolerances, DEFAULT_VARIABLES)
        fig = Figure(figsize=(13, 12), layout="constrained")
        axs = fig.subplots(5, 3, sharex=True)
        ref = results[labels[0]].df
        names = DEFAULT_VARIABLES
        for ax, name in zip(axs.ravel(), names):
            for lab in labels[1:]:
                df = results[lab].df
                common = ref.index.intersection(df.index)
                if name == POSITION:
                    d = np.sqrt(sum((df.loc[common, c] - ref.loc[common, c]) ** 2 for c in ("x", "y", "z")))
                else:
                    d = df.loc[common, name] - ref.loc[common, name]
                    if name in ANGLES:
                        d = np.remainder(d + math.pi, 2 * math.pi) - math.pi
                ax.semilogy(common, np.maximum(np.abs(np.asarray(d, dtype=float)), 1e-16), lw=1.0,
                            label=f"{lab} - {labels[0]}")
            if name in tol:
                ax.axhline(tol[name], color="r", ls=":", lw=1.0, label="tolerance")
            ax.set_ylabel(f"|d {name}| [{UNITS.get(name, '')}]")
            ax.grid(alpha=0.3, which="both")
        for ax in axs.ravel()[len(names):]:
            ax.axis("off")
        axs[0, 0].legend(fontsize=8)
        for ax in axs[-1]:
            ax.set_xlabel("t [s]")
        fig.suptitle(f"{title}: differences to {labels[0]}")
        paths.append(out / "differences.png")
        fig.savefig(paths[-1], dpi=110)
    return paths
