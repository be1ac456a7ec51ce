"""The aircraft's limits: one definition, read by the planner's warnings, the flyability verdict and the figures.

An aircraft file gives its limits in ``[envelope]`` (the validity box of the
aerodynamic data: alpha, beta, optionally Mach; surface deflection limits;
optionally a structural load-factor range) and ``[engines]`` (total thrust
limit, per-engine rating).  :func:`aircraft_limits` turns them into
:class:`Limit` records, each a quantity of a trajectory (a control, a
per-engine thrust or a state) between a lower and an upper bound;
:func:`limit_violations` finds where a trajectory leaves them, with the worst
value, its time and the share of the span (:class:`Violation`).  The limits:

- ``dl``, ``dm``, ``dn``: ``|u| <= u_max`` (``[envelope] dl_max`` ...; absent: not limited) [rad];
- ``thrust[i]``: engine i's thrust ``F (1 + eta) / 2`` (engine 1), ``F (1 - eta) / 2`` (engine 2), or
  ``F`` with one engine, within ``0 .. min(max_thrust / count, rating(V))`` (``[engines]``; the rating
  of :meth:`gna.aircraft.Propulsion.engine_thrust_limit`); no engine of the model gives reverse thrust [N];
- ``eta``: ``|eta| <= 1`` with two engines [-];
- ``alpha``: ``alpha_min .. alpha_max``; ``beta``: ``|beta| <= beta_max`` [rad];
- ``mach``: ``mach_min .. mach_max`` (ISA speed of sound; only when the file gives a bound) [-];
- ``nz``: ``nz_min .. nz_max``, the structural limit (only when the file gives one) [-].

A bounded planner and the tracking feedback's saturation read the same
records (:func:`control_ranges` gives the constant control ranges).

The validity box of the aerodynamic data (:func:`validity_limits`: alpha, beta and Mach) is also said
aloud: :class:`ValidityWarnings` warns once per command, aircraft and quantity when a trim, a plan or a
flight leaves it (the worst value, its time, the box), and once that an aircraft's validity is unknown
when its file has no ``[envelope]`` table.  A file without a Mach range is taken, for these warnings
only, as valid up to :data:`SUBSONIC_MACH` (the GNA models are subsonic); the flyability verdict checks
only the bounds the file gives.
"""

from __future__ import annotations

import logging
import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from .atmosphere import speed_of_sound
from .eom import CONTROL_NAMES, STATE_NAMES, Controls, State, loads

#: Finest step of the grid a plan's limits are checked on [s]: at most this, or an eighth of the node step.
FINE_STEP_MAX = 0.01

#: Every name a limit may have (the keys a scenario's ``[verdicts] known`` records may name).
LIMIT_NAMES: tuple[str, ...] = (
    "thrust[1]",
    "thrust[2]",
    "eta",
    "dl",
    "dm",
    "dn",
    "alpha",
    "beta",
    "mach",
    "nz",
)

#: What each limit bounds, for messages.
_WHAT = {
    "eta": "thrust asymmetry eta",
    "dl": "aileron dl",
    "dm": "elevator dm",
    "dn": "rudder dn",
    "alpha": "angle of attack alpha",
    "beta": "sideslip beta",
    "mach": "Mach number",
    "nz": "load factor nz",
}


def fine_step(node_step: float) -> float:
    """Step of the grid a plan's limits are checked on: ``min(FINE_STEP_MAX, node_step / 8)``.

    Parameters
    ----------
    node_step : float
        The plan's smallest node step [s].

    Returns
    -------
    float
        Step [s].
    """
    return min(FINE_STEP_MAX, float(node_step) / 8.0)


@dataclass(frozen=True)
class Limit:
    """One bound of the aircraft: a quantity of a trajectory between ``lower`` and ``upper``.

    Attributes
    ----------
    name : str
        One of :data:`LIMIT_NAMES`.
    kind : {"control", "state"}
        A control of the plan (surfaces, thrust, eta) or a state (the model's domain of validity).
    unit : str
        ``"rad"``, ``"N"`` or ``"-"`` (SI).
    lower, upper : float or None
        Constant bounds (None: unbounded on that side).  A per-engine thrust's upper bound may also
        depend on the airspeed (``upper_of``); ``upper`` is then its static part.
    source : str
        Where the bound comes from (the aircraft file's table and key).
    value_of : callable
        ``value_of(frame, env) -> ndarray``: the bounded quantity on the frame's rows.
    upper_of : callable, optional
        ``upper_of(frame) -> ndarray``: a varying upper bound (the thrust rating at the airspeed).
    columns : tuple of str
        The trajectory columns ``value_of`` and ``upper_of`` read.
    """

    name: str
    kind: str
    unit: str
    lower: float | None
    upper: float | None
    source: str
    value_of: Callable = field(compare=False, repr=False)
    upper_of: Callable | None = field(default=None, compare=False, repr=False)
    columns: tuple = ()

    def bounds(self, frame) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds on the frame's rows (``-inf``/``inf`` where unbounded).

        Parameters
        ----------
        frame : pandas.DataFrame
            A trajectory with :attr:`columns`.

        Returns
        -------
        (ndarray, ndarray)
            Shape (n,) each, in :attr:`unit`.
        """
        n = len(frame)
        lo = np.full(n, -np.inf if self.lower is None else self.lower)
        hi = np.full(n, np.inf if self.upper is None else self.upper)
        if self.upper_of is not None:
            hi = np.minimum(hi, self.upper_of(frame))
        return lo, hi


@dataclass(frozen=True)
class Violation:
    """Where a trajectory leaves one side of a :class:`Limit`.

    Attributes
    ----------
    name : str
        The limit's name (``"dl"``, ``"thrust[1]"``, ``"alpha"``, ...).
    limit : float
        The bound crossed, at the worst point (SI, rad; signed: ``-0.349`` for dl below -20 deg).
    worst : float
        The value farthest beyond it (SI, rad).
    time : float
        Its time [s].
    fraction : float
        Share of the span spent beyond the bound, 0 .. 1.
    first, last : float
        First and last times beyond it [s].
    unit : str
    side : {"lower", "upper"}
    source : str
        Where the bound comes from.
    """

    name: str
    limit: float
    worst: float
    time: float
    fraction: float
    first: float
    last: float
    unit: str
    side: str
    source: str = ""

    def to_dict(self) -> dict:
        """The violation as JSON-ready data (the verdict's ``violations`` records).

        Returns
        -------
        dict
            ``name``, ``limit``, ``worst``, ``time``, ``fraction``, ``first``, ``last``, ``unit``, ``side``.
        """
        return {
            "name": self.name,
            "limit": self.limit,
            "worst": self.worst,
            "time": self.time,
            "fraction": self.fraction,
            "first": self.first,
            "last": self.last,
            "unit": self.unit,
            "side": self.side,
        }

    def text(self) -> str:
        """One line for warnings and printed summaries (angles in degrees, thrust in N).

        Returns
        -------
        str
        """
        if self.unit == "rad":
            shown = lambda v: f"{math.degrees(v):.2f} deg"  # noqa: E731
        elif self.unit == "N":
            shown = lambda v: f"{v:.1f} N"  # noqa: E731
        else:
            shown = lambda v: f"{v:.4g}"  # noqa: E731
        span = (
            f"at t = {self.first:.4g} s"
            if self.first == self.last
            else f"from t = {self.first:.4g} to {self.last:.4g} s ({100 * self.fraction:.0f} % of the run)"
        )
        worst = f"worst {shown(self.worst)} at t = {self.time:.4g} s"
        side = "below" if self.side == "lower" else "above"
        if self.name.startswith("thrust["):
            engine = f"engine {self.name[7:-1]}"
            rating = "limit" if "max_thrust" in self.source else "rating"
            bound = "zero (no reverse thrust)" if self.side == "lower" else f"its {rating} {shown(self.limit)}"
            return (
                f"{engine} thrust {shown(self.worst)} at t = {self.time:.4g} s {side} {bound} "
                f"({100 * self.fraction:.0f} % of the run) (per-engine limit: {self.source})"
            )
        if self.name in ("dl", "dm", "dn"):
            return f"control {self.name} beyond its limit {math.degrees(abs(self.limit)):.1f} deg {span}; {worst}"
        if self.name == "eta":
            return f"|eta| above 1 (one engine would need negative thrust) {span}; {worst}"
        if self.name == "beta":
            return f"|beta| above the aerodynamic model's envelope ({math.degrees(abs(self.limit)):.1f} deg) {span}; {worst}"
        if self.name == "alpha":
            return f"alpha {side} the aerodynamic model's envelope ({math.degrees(self.limit):.1f} deg) {span}; {worst}"
        return f"{_WHAT.get(self.name, self.name)} {side} its limit {shown(self.limit)} [{self.source}] {span}; {worst}"


def _column(name: str) -> Callable:
    return lambda frame, env: frame[name].to_numpy(dtype=float)


def _mach(frame, env) -> np.ndarray:
    if "Mach" in frame.columns:
        return frame["Mach"].to_numpy(dtype=float)
    return frame["V"].to_numpy(dtype=float) / speed_of_sound(-frame["z"].to_numpy(dtype=float))


def load_factor_z(aircraft, env, frame) -> np.ndarray:
    """Normal load factor ``nz``: the non-gravitational specific force along body -z over g (1 in level flight).

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
    env : gna.atmosphere.Environment
        Density and gravity.
    frame : pandas.DataFrame
        Every state and control (SI, rad), one row per time.

    Returns
    -------
    ndarray, shape (n,)
        ``nz`` [-], as :func:`gna.simulate.simulate` tabulates it.
    """
    s = State(*(frame[n].to_numpy(dtype=float) for n in STATE_NAMES))
    u = Controls(*(frame[n].to_numpy(dtype=float) for n in CONTROL_NAMES))
    return body_load_factors(aircraft, env, s, loads(aircraft, env, s, u))[2]


def body_load_factors(aircraft, env, s, ld) -> tuple:
    """Load factors ``(nx, ny, nz)``: the aerodynamic and propulsive force in body axes over ``m g`` (nz up).

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
    env : gna.atmosphere.Environment
    s : gna.eom.State
        States (alpha, beta read).
    ld : gna.eom.Loads
        The loads (:func:`gna.eom.loads`), wind-axis forces ``Xa, Ya, Za``.

    Returns
    -------
    tuple of ndarray
        ``nx, ny, nz`` [-].
    """
    m, g = aircraft.mass.mass, env.g
    ca, sa, cb, sb = np.cos(s.alpha), np.sin(s.alpha), np.cos(s.beta), np.sin(s.beta)
    fx_w, fy_w, fz_w = ld.Xa, ld.Ya, ld.Za
    fbx = ca * cb * fx_w - ca * sb * fy_w - sa * fz_w
    fby = sb * fx_w + cb * fy_w
    fbz = sa * cb * fx_w - sa * sb * fy_w + ca * fz_w
    return fbx / (m * g), fby / (m * g), -fbz / (m * g)


def _nz(aircraft):
    def value(frame, env):
        if "nz" in frame.columns:
            return frame["nz"].to_numpy(dtype=float)
        return load_factor_z(aircraft, env, frame)

    return value


def _engine_thrust(index: int, count: int) -> Callable:
    sign = 1.0 if index == 1 else -1.0

    def value(frame, env):
        F = frame["F"].to_numpy(dtype=float)
        if count == 1:
            return F
        return 0.5 * F * (1.0 + sign * frame["eta"].to_numpy(dtype=float))

    return value


def _rating(prop) -> Callable:
    def upper(frame):
        return prop.engine_thrust_limits(frame["V"].to_numpy(dtype=float))

    return upper


def aircraft_limits(aircraft) -> tuple[Limit, ...]:
    """Every limit the aircraft file gives (the table of the module docstring).

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        Its ``envelope`` and ``propulsion``.

    Returns
    -------
    tuple of Limit
        Controls first (F, thrust per engine, eta, surfaces), then the states (alpha, beta, Mach, nz);
        built once per aircraft object (an immutable dataclass).
    """
    key = id(aircraft)
    hit = _LIMITS.get(key)
    if hit is not None and hit[0]() is aircraft:
        return hit[1]
    out = _aircraft_limits(aircraft)
    try:
        ref = weakref.ref(aircraft, lambda _r, key=key, store=_LIMITS: store.pop(key, None))
    except TypeError:  # an object without weak references: not kept
        return out
    _LIMITS[key] = (ref, out)
    return out


#: id(aircraft) -> (weak reference, its limits): :func:`aircraft_limits` once per aircraft object (kept out of
#: the aircraft itself, which stays picklable; its limits' functions are closures).
_LIMITS: dict = {}


def _aircraft_limits(aircraft) -> tuple[Limit, ...]:
    env, prop = aircraft.envelope, aircraft.propulsion
    out = []
    fmax = prop.max_thrust
    rated = prop.engine_power is not None or prop.engine_static_thrust is not None
    rating = _rating(prop) if rated else None  # one function for the engines: limit_violations computes it once
    for i in range(1, prop.count + 1):
        out.append(
            Limit(
                f"thrust[{i}]",
                "control",
                "N",
                0.0,
                None if fmax is None else fmax / prop.count,
                (prop.engine_source or "[engines] rating") if rated else "[engines] max_thrust / count",
                _engine_thrust(i, prop.count),
                rating,
                columns=("F", "eta", "V") if rated else ("F", "eta"),
            )
        )
    if prop.count == 2:
        out.append(Limit("eta", "control", "-", -1.0, 1.0, "two engines", _column("eta"), columns=("eta",)))
    for name, lim in env.control_limits.items():
        out.append(Limit(name, "control", "rad", -lim, lim, f"[envelope] {name}_max", _column(name), columns=(name,)))
    out.append(
        Limit(
            "alpha",
            "state",
            "rad",
            env.alpha_min,
            env.alpha_max,
            "[envelope] alpha_min, alpha_max",
            _column("alpha"),
            columns=("alpha",),
        )
    )
    out.append(
        Limit(
            "beta",
            "state",
            "rad",
            -env.beta_max,
            env.beta_max,
            "[envelope] beta_max",
            _column("beta"),
            columns=("beta",),
        )
    )
    if env.mach_min is not None or env.mach_max is not None:
        out.append(
            Limit(
                "mach",
                "state",
                "-",
                env.mach_min,
                env.mach_max,
                "[envelope] mach_min, mach_max",
                _mach,
                columns=("V", "z"),
            )
        )
    if env.nz_min is not None or env.nz_max is not None:
        out.append(
            Limit(
                "nz",
                "state",
                "-",
                env.nz_min,
                env.nz_max,
                "[envelope] nz_min, nz_max",
                _nz(aircraft),
                columns=STATE_NAMES + CONTROL_NAMES,
            )
        )
    return tuple(out)


def limit_columns(aircraft) -> tuple[str, ...]:
    """The trajectory columns :func:`limit_violations` reads for this aircraft.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft

    Returns
    -------
    tuple of str
        In the order of :data:`gna.eom.STATE_NAMES` then :data:`gna.eom.CONTROL_NAMES`.
    """
    need = {c for lim in aircraft_limits(aircraft) for c in lim.columns}
    return tuple(n for n in STATE_NAMES + CONTROL_NAMES if n in need)


def control_ranges(aircraft) -> dict[str, tuple[float, float]]:
    """Constant range of every bounded control: F ``0 .. max_thrust``, ``|eta| <= 1`` with two engines, surfaces.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft

    Returns
    -------
    dict
        Control name -> (lower, upper) in SI units (the F range only with a ``max_thrust``).
    """
    out = {}
    if aircraft.propulsion.max_thrust is not None:
        out["F"] = (0.0, float(aircraft.propulsion.max_thrust))
    for lim in aircraft_limits(aircraft):
        if lim.name in CONTROL_NAMES:
            out[lim.name] = (float(lim.lower), float(lim.upper))
    return out


class TrajectoryColumns:
    """A trajectory's float columns as arrays: what the limits' functions read (``columns``,
    ``frame[name].to_numpy(dtype=float)``, ``len``), without a DataFrame's lookups.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Times [s].
    columns : sequence of str
        Column names.
    values : ndarray, shape (len(columns), n)
        One row per column (SI, rad).
    """

    class _Column:
        __slots__ = ("values",)

        def __init__(self, values: np.ndarray) -> None:
            self.values = values

        def to_numpy(self, dtype=float) -> np.ndarray:
            return self.values.astype(dtype, copy=False)

    class _Index:
        __slots__ = ("t",)

        def __init__(self, t: np.ndarray) -> None:
            self.t = t

        def to_numpy(self, dtype=float) -> np.ndarray:
            return self.t.astype(dtype, copy=False)

    def __init__(self, t, columns, values) -> None:
        self.index = self._Index(np.asarray(t, dtype=float))
        self.columns = tuple(columns)
        self._cols = {c: values[i] for i, c in enumerate(self.columns)}

    @classmethod
    def from_frame(cls, frame) -> TrajectoryColumns:
        """The numeric columns of a DataFrame, read once.

        Parameters
        ----------
        frame : pandas.DataFrame
            Indexed by time [s].

        Returns
        -------
        TrajectoryColumns
        """
        out = cls.__new__(cls)
        out.index = cls._Index(frame.index.to_numpy(dtype=float))
        out.columns = tuple(frame.columns)
        try:
            block = frame.to_numpy(dtype=float)
        except (TypeError, ValueError):  # a column that is not numeric: read the numeric ones one by one
            block = None
        if block is not None:
            out._cols = {c: block[:, i] for i, c in enumerate(out.columns)}
        else:
            out._cols = {}
            for c in out.columns:
                try:
                    out._cols[c] = frame[c].to_numpy(dtype=float)
                except (TypeError, ValueError):
                    continue
        return out

    def __getitem__(self, name: str):
        return self._Column(self._cols[name])

    def __len__(self) -> int:
        return self.index.t.size


def limit_violations(aircraft, frame, env=None, scan: Callable | None = None) -> list[Violation]:
    """Where a trajectory leaves the aircraft's limits, one record per limit and side.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
        Its limits (:func:`aircraft_limits`).
    frame : pandas.DataFrame or TrajectoryColumns
        A trajectory indexed by time [s] with the columns of :func:`limit_columns` (a load-factor limit
        reads ``nz`` when the frame has it, else computes it from every state and control with ``env``).
    env : gna.atmosphere.Environment, optional
        Needed only to compute ``nz``; without it (and without an ``nz`` column) that limit is skipped.
    scan : callable, optional
        Another implementation of :func:`scan_sides` (the same results: a compiled one); default that.

    Returns
    -------
    list of Violation
        In the order of :func:`aircraft_limits`; empty inside every limit.  The fraction of the span is
        the rectangle rule on the rows (each row counts until the next).
    """
    return _violations(aircraft_limits(aircraft), frame, env, scan)


def scan_sides(t: np.ndarray, sides: list) -> list:
    """Which sides of the limits a trajectory leaves, and where: the test of :func:`limit_violations`.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Times [s].
    sides : list of (Limit, str, ndarray, float or ndarray)
        The limit, its side (``"lower"``, ``"upper"``), the bounded quantity (shape (n,)) and the bound on that
        side (a number, ``-inf``/``inf`` or NaN where unbounded, or an array of shape (n,)).

    Returns
    -------
    list
        Per side: None when no row is beyond the bound (its excess, ``bound - v`` below or ``v - bound``
        above, > 0), else ``(i, first, last)``: the row of the largest excess (the first of equal ones), the
        first and the last row beyond it.
    """
    out = []
    for _lim, side, v, bound in sides:
        if np.ndim(bound) == 0:
            if np.isnan(bound) or bound == (-np.inf if side == "lower" else np.inf):
                out.append(None)  # unbounded on that side: no excess is positive
                continue
            # a constant bound: some excess is positive iff the extreme value (NaN ignored) passes it
            if not (np.fmin.reduce(v) < bound if side == "lower" else np.fmax.reduce(v) > bound):
                out.append(None)
                continue
        excess = bound - v if side == "lower" else v - bound
        over = excess > 0
        if not over.any():
            out.append(None)
            continue
        rows = np.flatnonzero(over)
        out.append((int(np.argmax(np.where(over, excess, -np.inf))), int(rows[0]), int(rows[-1])))
    return out


def _violations(limits, frame, env, scan=None) -> list[Violation]:
    """:func:`limit_violations` of the given limits."""
    if not isinstance(frame, TrajectoryColumns):  # the columns read once (a DataFrame's lookups cost more)
        frame = TrajectoryColumns.from_frame(frame)
    t = frame.index.to_numpy(dtype=float)
    if t.size == 0:
        return []
    uppers: dict = {}
    have = set(frame.columns)
    sides = []
    for lim in limits:
        if lim.name == "nz":
            if "nz" not in have and (env is None or not set(lim.columns) <= have):
                continue
        elif lim.name == "mach":
            if "Mach" not in have and not {"V", "z"} <= have:
                continue
        elif not set(lim.columns) <= have:
            continue
        v = lim.value_of(frame, env)
        lo = -np.inf if lim.lower is None else float(lim.lower)
        if lim.upper_of is None:  # constant bounds: compared as numbers (the same tests as on arrays of them)
            hi = np.inf if lim.upper is None else float(lim.upper)
        else:  # a varying upper bound (the engines' rating): computed once per function
            if lim.upper_of not in uppers:
                uppers[lim.upper_of] = lim.upper_of(frame)
            hi = np.minimum(np.inf if lim.upper is None else lim.upper, uppers[lim.upper_of])
        sides.append((lim, "lower", v, lo))
        sides.append((lim, "upper", v, hi))
    out = []
    dt = None
    span = max(float(t[-1] - t[0]), 1e-300)
    for (lim, side, v, bound), hit in zip(sides, (scan or scan_sides)(t, sides)):
        if hit is None:
            continue
        i, first, last = hit
        if dt is None:
            dt = np.diff(t, append=t[-1])
        over = (bound - v if side == "lower" else v - bound) > 0
        out.append(
            Violation(
                name=lim.name,
                limit=float(bound if np.ndim(bound) == 0 else bound[i]),
                worst=float(v[i]),
                time=float(t[i]),
                fraction=float(np.sum(dt[over])) / span if t.size > 1 else 1.0,
                first=float(t[first]),
                last=float(t[last]),
                unit=lim.unit,
                side=side,
                source=lim.source,
            )
        )
    return out


#: The Mach number an aircraft file without a Mach range (``[envelope] mach_min, mach_max``) is taken as valid
#: up to, for :class:`ValidityWarnings` only: the GNA models are subsonic (the paper, after Grauer and Morelli
#: 2014), and the subsonic regime ends near Mach 0.8, where transonic flow begins.
SUBSONIC_MACH = 0.8

#: The quantities of the validity box of the aerodynamic data.
VALIDITY_NAMES: tuple[str, ...] = ("alpha", "beta", "mach")

#: The trajectory columns :func:`validity_excursions` reads.
VALIDITY_COLUMNS: tuple[str, ...] = ("z", "V", "alpha", "beta")


def validity_limits(aircraft) -> tuple[Limit, ...]:
    """The validity box of the aircraft's aerodynamic data: alpha, beta and Mach.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft

    Returns
    -------
    tuple of Limit
        ``alpha`` and ``beta`` as :func:`aircraft_limits`; ``mach`` the file's range, else ``0 ..``
        :data:`SUBSONIC_MACH` (its ``source`` says it is assumed).
    """
    env = aircraft.envelope
    out = [lim for lim in aircraft_limits(aircraft) if lim.name in VALIDITY_NAMES]
    if not any(lim.name == "mach" for lim in out):
        out.append(
            Limit(
                "mach",
                "state",
                "-",
                0.0,
                SUBSONIC_MACH,
                "subsonic assumed: the aircraft file gives no [envelope] mach_min, mach_max",
                _mach,
                columns=("V", "z"),
            )
        )
    if not getattr(env, "declared", True):
        out = [lim if lim.name == "mach" else replace(lim, source="gflat's default, assumed") for lim in out]
    return tuple(out)


def validity_excursions(aircraft, frame, env=None) -> list[Violation]:
    """Where a trajectory leaves the validity box of the aircraft's aerodynamic data (:func:`validity_limits`).

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft
    frame : pandas.DataFrame or TrajectoryColumns
        Indexed by time [s], with the columns :data:`VALIDITY_COLUMNS` (``Mach`` read when there).
    env : gna.atmosphere.Environment, optional
        Unused (the speed of sound is ISA's); accepted as :func:`limit_violations`.

    Returns
    -------
    list of Violation
        One per quantity and side left.
    """
    return _violations(validity_limits(aircraft), frame, env)


def _box_text(lim: Limit) -> str:
    """A validity limit's range for people: ``alpha -5.0 .. 12.0 deg``, ``Mach 0 .. 0.8``."""
    if lim.name == "beta":
        return f"|beta| <= {math.degrees(lim.upper):.1f} deg"
    if lim.unit == "rad":
        return f"{lim.name} {math.degrees(lim.lower):.1f} .. {math.degrees(lim.upper):.1f} deg"
    lo = "0" if not lim.lower else f"{lim.lower:g}"
    hi = "no upper bound" if lim.upper is None else f"{lim.upper:g}"
    return f"Mach {lo} .. {hi}"


class ValidityWarnings:
    """The validity box said aloud: one warning per aircraft and quantity left, however often it is left.

    A command makes one and checks with it every trim, plan and flight it makes (:meth:`check`,
    :meth:`check_point`); each warning is one line (logger ``gna.limits``, level WARNING) naming the
    aircraft, the quantity, the worst value (degrees for angles), its time and what it was (``plan of
    gtm-forward-slip, j = 6``), and the box's range and source.  An aircraft whose file has no
    ``[envelope]`` table warns once that the validity of its data is unknown.  Nothing here changes a verdict.

    Parameters
    ----------
    logger : logging.Logger, optional
        Default ``logging.getLogger("gna.limits")``.

    Attributes
    ----------
    said : list of str
        Every warning given, in order.
    """

    def __init__(self, logger: logging.Logger | None = None) -> None:
        self._log = logger or logging.getLogger("gna.limits")
        self._done: set = set()
        self.said: list[str] = []

    def _say(self, key, text: str) -> str | None:
        if key in self._done:
            return None
        self._done.add(key)
        self.said.append(text)
        self._log.warning("%s", text)
        return text

    def _unknown(self, aircraft) -> list[str]:
        if getattr(aircraft.envelope, "declared", True):
            return []
        box = ", ".join(_box_text(lim) for lim in validity_limits(aircraft))
        text = self._say(
            (aircraft.id, "envelope"),
            f"{aircraft.id}: its aircraft file has no [envelope] table: the validity of its aerodynamic data is "
            f"unknown (assumed: {box})",
        )
        return [text] if text else []

    def check(self, aircraft, frame, what: str, *, timed: bool = True) -> list[str]:
        """Warn of the quantities of the validity box ``frame`` leaves, each once per aircraft.

        Parameters
        ----------
        aircraft : gna.aircraft.Aircraft
        frame : pandas.DataFrame or TrajectoryColumns
            A trajectory indexed by time [s] (:func:`validity_excursions`).
        what : str
            What the trajectory is, in the line (``"JSBSim flight of gtm-forward-slip, open loop"``).
        timed : bool
            Name the worst value's time (False: a single steady point, a trim).

        Returns
        -------
        list of str
            The warnings given now (none for a quantity already warned of).
        """
        out = self._unknown(aircraft)
        worst: dict[str, Violation] = {}
        for v in validity_excursions(aircraft, frame):
            if not math.isfinite(v.worst):
                continue
            if v.name not in worst or abs(v.worst - v.limit) > abs(worst[v.name].worst - worst[v.name].limit):
                worst[v.name] = v
        limits = {lim.name: lim for lim in validity_limits(aircraft)}
        for name, v in worst.items():
            if (aircraft.id, name) in self._done:
                continue
            lim = limits[name]
            value = f"{math.degrees(v.worst):.2f} deg" if v.unit == "rad" else f"{v.worst:.3g}"
            shown = "Mach" if name == "mach" else name
            when = f" at t = {v.time:.4g} s" if timed else ""
            text = self._say(
                (aircraft.id, name),
                f"{aircraft.id}: {shown} {value}{when} ({what}) outside the validity box of its aerodynamic data: "
                f"{_box_text(lim)} ({lim.source})",
            )
            if text:
                out.append(text)
        return out

    def check_point(self, aircraft, *, V: float, altitude: float, alpha: float, beta: float, what: str) -> list[str]:
        """:meth:`check` of one steady point (a trim): airspeed, altitude and the wind angles.

        Parameters
        ----------
        aircraft : gna.aircraft.Aircraft
        V : float
            Airspeed [m/s].
        altitude : float
            [m] (ISA's speed of sound there).
        alpha, beta : float
            [rad].
        what : str
            What the point is (``"trim"``).

        Returns
        -------
        list of str
        """
        frame = TrajectoryColumns(
            np.zeros(1), VALIDITY_COLUMNS, np.array([[-altitude], [V], [alpha], [beta]], dtype=float)
        )
        return self.check(aircraft, frame, what, timed=False)
