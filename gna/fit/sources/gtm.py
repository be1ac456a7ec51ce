"""NASA Generic Transport Model (GTM T2, 5.5 % scale) aerodynamic database.

Evaluates the gridded database of NASA's public GTM_DesignSim
(``T2_polynomial_aerodatabase.mat``, "unlimited distribution") the way the
simulation's ``Aero`` subsystem does, vectorised over numpy arrays; the data
and the description of every rule (with the Simulink line it comes from) are
in ``gna/data/sources/gtm/`` (``PROVENANCE.md``).  Nominal (undamaged)
aircraft only; the stall rolling-moment asymmetry is off, as in the
simulation's default.

Build-up, body axes, moments about the 25 % MAC reference point::

    C6 = C6_bas(a, b) + sum of 18 surface parts + dynamic(a, b, p, q, r, V)

* surfaces: stabilizer and the four elevator panels from ``dC3_ele`` (each
  panel a quarter of the increment, with a roll/yaw coupling of its span
  arm), ailerons and spoilers from right-side tables (left side mirrored in
  beta and in the lateral coefficients), rudder from negative-deflection
  tables (positive mirrored), constant flap derivatives, gear table;
* dynamic: hybrid Kalviste blending splits (p, q, r) into a rotation about
  the velocity vector (rotary-balance table ``dC6_w``, rate saturated at
  +-0.5) and oscillatory rates (forced-oscillation tables ``dC3_p/q/r``),
  normalised with ``V' = tas_kt * 1.689`` ft/s, ``tas_kt = 0.592487 V``;
* every table: multilinear interpolation with linear extrapolation.

Units inside :class:`GTMAeroDatabase` are the source's (deg, rad/s, ft/s):
it is the edge where the source's conventions live.  :class:`GTMSource`
converts from the project's (rad, nondimensional rates) and returns the
project's coefficients (stability-axis CD, CL).
"""

from __future__ import annotations

import gzip
import itertools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources

import numpy as np

from ... import units
from ...aero import AeroState, Coefficients
from ...errors import InputError
from .base import SourceModel, broadcast_state, stability_from_body

#: The 18 individual surfaces of the simulation (deg; GEAR 0 up / 1 down).
SURFACES: tuple[str, ...] = (
    "ELLOB",
    "ELLIB",
    "ELRIB",
    "ELROB",
    "STAB",
    "AILL",
    "AILR",
    "RUDU",
    "RUDL",
    "SPLLIB",
    "SPLLOB",
    "SPLRIB",
    "SPLROB",
    "FLAPLOB",
    "FLAPLIB",
    "FLAPRIB",
    "FLAPROB",
    "GEAR",
)

#: Order in which the simulation sums the surface parts (Control Surfaces Mux).
MUX_ORDER: tuple[str, ...] = (
    "RUDU",
    "RUDL",
    "AILL",
    "AILR",
    "SPLLIB",
    "SPLLOB",
    "SPLRIB",
    "SPLROB",
    "STAB",
    "ELLOB",
    "ELLIB",
    "ELRIB",
    "ELROB",
    "FLAPLOB",
    "FLAPLIB",
    "FLAPRIB",
    "FLAPROB",
    "GEAR",
)

_LAT = (1, 3, 5)  # CY, Cl, Cn in the body 6-vector [CX CY CZ Cl Cm Cn]
_LON = (0, 2, 4)  # CX, CZ, Cm
_MIRROR = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])
_RUDDER_GAINS = {"RUDU": np.array([0.5, 0.5, 0.5, 0.67, 0.67, 0.5]), "RUDL": np.array([0.5, 0.5, 0.5, 0.33, 0.33, 0.5])}
_SPOILER_GAINS = {
    "IB": np.array([0.45, 0.45, 0.45, 0.26, 0.45, 0.26]),
    "OB": np.array([0.55, 0.55, 0.55, 0.74, 0.55, 0.74]),
}
_ELEVATOR_ARMS = {"ELLOB": -0.07, "ELLIB": -0.03, "ELRIB": 0.03, "ELROB": 0.07}

#: Simulation constants: ft/s -> kt gain, and the kt -> ft/s constant of the rate normalisation.
FPS_TO_KT = 0.592487
KT_TO_FPS_RATES = 1.689
#: Saturation of the normalised rotation rate about the velocity vector.
OMEGA_HAT_LIMIT = 0.5

_DATA = ("gna", "data", "sources", "gtm")


def _data_file(name: str):
    root = resources.files(_DATA[0])
    for part in _DATA[1:]:
        root = root / part
    return root / name


@dataclass(frozen=True)
class Table:
    """A gridded table: breakpoint axes first, then index axes (selected, not interpolated)."""

    name: str
    breakpoints: tuple[np.ndarray, ...]
    data: np.ndarray

    @classmethod
    def from_json(cls, name: str, t: Mapping) -> Table:
        """A table from its JSON form in the vendored database.

        Parameters
        ----------
        name : str
            Table name (e.g. ``"C6_bas"``), for messages.
        t : mapping
            ``dims`` (each with ``kind`` ``"breakpoint"`` or an index kind, and ``values``), ``shape`` and
            the nested-list ``data``.

        Returns
        -------
        Table
            With float breakpoints and data.

        Raises
        ------
        InputError
            Data of another shape than declared, or breakpoints not strictly increasing or not matching
            their axis length.
        """
        bps = tuple(np.asarray(d["values"], dtype=float) for d in t["dims"] if d["kind"] == "breakpoint")
        data = np.asarray(t["data"], dtype=float)
        if tuple(data.shape) != tuple(t["shape"]):
            raise InputError(f"GTM table {name}: data shape {data.shape} != declared {t['shape']}")
        for k, bp in enumerate(bps):
            if data.shape[k] != len(bp) or np.any(np.diff(bp) <= 0):
                raise InputError(f"GTM table {name}: breakpoints of axis {k} are not increasing or do not match")
        return cls(name, bps, data)

    def interpolate(self, inputs, select: tuple = ()) -> np.ndarray:
        """Multilinear interpolation, linear extrapolation beyond the breakpoints.

        Parameters
        ----------
        inputs : sequence of arrays
            One per breakpoint axis, broadcast together (shape ``S``).
        select : tuple of int
            Indices of the index axes that follow the breakpoint axes.

        Returns
        -------
        ndarray
            Shape ``S + remaining axes`` (the coefficients).
        """
        u = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in inputs))
        kf = []
        for bp, x in zip(self.breakpoints, u):
            k = np.clip(np.searchsorted(bp, x, side="right") - 1, 0, len(bp) - 2)
            kf.append((k, (x - bp[k]) / (bp[k + 1] - bp[k])))
        extra = self.data.ndim - len(self.breakpoints) - len(select)
        out = 0.0
        for corner in itertools.product((0, 1), repeat=len(self.breakpoints)):
            w = 1.0
            idx = []
            for (k, f), c in zip(kf, corner):
                w = w * (f if c else 1.0 - f)
                idx.append(k + c)
            w = np.asarray(w)
            out = out + w.reshape(w.shape + (1,) * extra) * self.data[tuple(idx) + tuple(select)]
        return np.asarray(out)


def kalviste(alpha_deg, beta_deg, p, q, r):
    """Hybrid Kalviste blending (GTM_DesignSim ``hykal``), vectorised.

    Splits the body rates into a steady rotation ``Omega`` about the velocity
    vector and residual oscillatory rates.  Case 1 (``p_osc = 0``):
    ``Omega = p/(cos a cos b)``, accepted if ``r_osc`` is no larger than ``r``
    and of the same sign; case 2 (``r_osc = 0``): ``Omega = r/(sin a cos b)``,
    accepted likewise on ``p_osc``, and preferred to case 1; otherwise case 3:
    ``Omega = 0``.  Exact zeros of ``p``, ``r``, ``cos a cos b``,
    ``sin a cos b`` skip a case.

    Parameters
    ----------
    alpha_deg, beta_deg : array_like
        Angle of attack and sideslip [deg].
    p, q, r : array_like
        Body rates [rad/s], broadcast with the angles.

    Returns
    -------
    omega, p_osc, q_osc, r_osc : ndarray
        Rotation rate about the velocity vector and the oscillatory body rates [rad/s].
    case : ndarray of int
        The case taken at each point (1, 2 or 3).
    """
    a = np.radians(alpha_deg)
    b = np.radians(beta_deg)
    p, q, r = (np.asarray(x, dtype=float) for x in (p, q, r))
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    cacb, sacb = ca * cb, sa * cb
    with np.errstate(divide="ignore", invalid="ignore"):
        om1 = p / cacb
        r_osc1 = r - om1 * sa * cb
        ok1 = (cacb != 0) & (p != 0) & ~(np.abs(r_osc1) > np.abs(r)) & ~(r_osc1 * r < 0)
        om2 = r / sacb
        p_osc2 = p - om2 * ca * cb
        ok2 = (sacb != 0) & (r != 0) & ~(np.abs(p_osc2) > np.abs(p)) & ~(p_osc2 * p < 0)
    case = np.where(ok2, 2, np.where(ok1, 1, 3))
    omega = np.where(case == 1, om1, np.where(case == 2, om2, 0.0))
    p_osc = np.where(case == 1, 0.0, np.where(case == 2, p_osc2, p))
    q_osc = np.where(case == 3, q, q - omega * sb)
    r_osc = np.where(case == 1, r_osc1, np.where(case == 2, 0.0, r))
    return omega, p_osc, q_osc, r_osc, case


class GTMAeroDatabase:
    """The GTM T2 nominal aerodynamic database and its evaluation (source units).

    Parameters
    ----------
    tables : dict
        Name -> :class:`Table` (the nominal tables of the database).
    flaps : dict
        Flap panel -> 6-vector of derivatives per deg.
    b, cbar : float
        Span and mean chord [ft] (used in the rate normalisation).

    Raises
    ------
    InputError
        One of :attr:`NEEDED` tables is missing.
    """

    NEEDED = (
        "C6_bas",
        "dC3_sym",
        "dC3_ele",
        "dC3_lgr",
        "dC3_p",
        "dC3_q",
        "dC3_r",
        "dC6_ail",
        "dC6_rud",
        "dC6_spo",
        "dC6_w",
    )

    def __init__(self, tables: Mapping[str, Table], flaps: Mapping[str, np.ndarray], b: float, cbar: float):
        missing = [t for t in self.NEEDED if t not in tables]
        if missing:
            raise InputError(f"GTM database lacks table(s) {', '.join(missing)}")
        self.tables = dict(tables)
        self.flaps = {k: np.asarray(v, dtype=float) for k, v in flaps.items()}
        self.b = float(b)
        self.cbar = float(cbar)

    @classmethod
    def load(cls) -> GTMAeroDatabase:
        """The vendored database (``gna/data/sources/gtm``).

        Returns
        -------
        GTMAeroDatabase
            The nominal tables, the four flap panels' derivatives and the span and chord of ``vehicle.json``.

        Raises
        ------
        InputError
            A malformed or missing table (:meth:`Table.from_json`).
        """
        with _data_file("gtm_t2_aero_nominal.json.gz").open("rb") as fh:
            db = json.loads(gzip.decompress(fh.read()))
        veh = load_vehicle()
        tables = {k: Table.from_json(k, v) for k, v in db["tables"].items()}
        fl = db["linear_derivatives"]["flaps"]
        flaps = {k: fl[k] for k in ("FLAPLOB", "FLAPLIB", "FLAPRIB", "FLAPROB")}
        return cls(tables, flaps, veh["geometry"]["b_ft"], veh["geometry"]["cbar_ft"])

    def breakpoint_range(self, table: str, axis: int) -> tuple[float, float]:
        """First and last breakpoint of one axis of a table (the data's range on that axis).

        Parameters
        ----------
        table : str
            Table name.
        axis : int
            Breakpoint axis.

        Returns
        -------
        tuple of float
            ``(lo, hi)`` in the table's units (deg, or nondimensional rate).
        """
        bp = self.tables[table].breakpoints[axis]
        return float(bp[0]), float(bp[-1])

    # -- the three parts of the build-up ---------------------------------------------------------
    def basic(self, alpha, beta) -> np.ndarray:
        """Basic airframe ``C6_bas`` plus the (all-zero) symmetrisation increment on CY, Cl, Cn.

        Parameters
        ----------
        alpha, beta : array_like
            Angle of attack and sideslip [deg].

        Returns
        -------
        ndarray, shape (..., 6)
            Body-axis ``[CX, CY, CZ, Cl, Cm, Cn]``.
        """
        c = self.tables["C6_bas"].interpolate((alpha, beta))
        sym = self.tables["dC3_sym"].interpolate((alpha, beta))
        out = c.copy()
        out[..., _LAT] = out[..., _LAT] + sym
        return out

    def surfaces(self, alpha, beta, s: Mapping[str, np.ndarray]) -> np.ndarray:
        """Sum of the 18 surface contributions, in the simulation's summing order (:data:`MUX_ORDER`).

        Parameters
        ----------
        alpha, beta : array_like
            Angle of attack and sideslip [deg].
        s : mapping of str to array_like
            Deflection of every one of :data:`SURFACES` [deg] (GEAR 0 up / 1 down).

        Returns
        -------
        ndarray, shape (..., 6)
            Body-axis ``[CX, CY, CZ, Cl, Cm, Cn]`` increments.
        """
        T = self.tables
        shape = np.broadcast(np.asarray(alpha), np.asarray(beta), *(np.asarray(v) for v in s.values())).shape
        zeros6 = np.zeros(shape + (6,))
        parts = {}
        for name, gains in _RUDDER_GAINS.items():
            d = np.asarray(s[name], dtype=float)
            sg = np.where(d >= 0, -1.0, 1.0)
            s6 = np.ones(shape + (6,))
            s6[..., _LAT] = sg[..., None] if np.ndim(sg) else sg
            parts[name] = gains * s6 * T["dC6_rud"].interpolate((alpha, sg * beta, -np.abs(d)))
        parts["AILR"] = T["dC6_ail"].interpolate((alpha, beta, s["AILR"]))
        parts["AILL"] = _MIRROR * T["dC6_ail"].interpolate((alpha, -np.asarray(beta), s["AILL"]))
        for side, mirror_beta, mirror in (("R", 1.0, np.ones(6)), ("L", -1.0, _MIRROR)):
            for pos in ("IB", "OB"):
                name = f"SPL{side}{pos}"
                parts[name] = (
                    _SPOILER_GAINS[pos]
                    * mirror
                    * T["dC6_spo"].interpolate((alpha, mirror_beta * np.asarray(beta), s[name]))
                )
        stab = s["STAB"]
        c0 = T["dC3_ele"].interpolate((alpha, beta, stab, 0.0))
        v = zeros6.copy()
        v[..., _LON] = c0
        parts["STAB"] = v
        for name, arm in _ELEVATOR_ARMS.items():
            d3 = 0.25 * (T["dC3_ele"].interpolate((alpha, beta, stab, s[name])) - c0)
            v = zeros6.copy()
            v[..., _LON] = d3
            v[..., 3] = v[..., 3] + arm * d3[..., 1]  # Cl += arm * dCZ
            v[..., 5] = v[..., 5] - arm * d3[..., 0]  # Cn -= arm * dCX
            parts[name] = v
        for name in ("FLAPLOB", "FLAPLIB", "FLAPRIB", "FLAPROB"):
            parts[name] = self.flaps[name] * np.asarray(s[name], dtype=float)[..., None]
        gear = np.asarray(s["GEAR"], dtype=float)
        down = T["dC3_lgr"].interpolate((alpha,), select=(1,))
        up = T["dC3_lgr"].interpolate((alpha,), select=(0,))
        v = zeros6.copy()
        v[..., _LON] = np.where((gear != 0)[..., None], down, up)
        parts["GEAR"] = v
        total = zeros6
        for name in MUX_ORDER:
            total = total + parts[name]
        return total

    def dynamic(self, alpha, beta, p, q, r, V_fps) -> np.ndarray:
        """Rotary-balance plus forced-oscillation increments (:func:`kalviste` splits the rates).

        Parameters
        ----------
        alpha, beta : array_like
            Angle of attack and sideslip [deg].
        p, q, r : array_like
            Body rates [rad/s].
        V_fps : array_like
            True airspeed [ft/s] (clipped to 1..10000 kt for the normalisation).

        Returns
        -------
        ndarray, shape (..., 6)
            Body-axis ``[CX, CY, CZ, Cl, Cm, Cn]`` increments.
        """
        T = self.tables
        tas = np.clip(np.asarray(V_fps, dtype=float) * FPS_TO_KT, 1.0, 10000.0)
        omega, p_osc, q_osc, r_osc, _ = kalviste(alpha, beta, p, q, r)
        b2v = self.b / (2.0 * tas * KT_TO_FPS_RATES)
        c2v = self.cbar / (2.0 * tas * KT_TO_FPS_RATES)
        what = np.clip(omega * b2v, -OMEGA_HAT_LIMIT, OMEGA_HAT_LIMIT)
        out = T["dC6_w"].interpolate((alpha, what, beta))
        out = np.array(out, dtype=float, copy=True)
        dp = T["dC3_p"].interpolate((alpha, p_osc * b2v))
        dq = T["dC3_q"].interpolate((alpha, q_osc * c2v))
        dr = T["dC3_r"].interpolate((alpha, r_osc * b2v))
        zeros = np.zeros(out.shape)
        tp, tq, tr = zeros.copy(), zeros.copy(), zeros.copy()
        tp[..., _LAT] = dp
        tq[..., _LON] = dq
        tr[..., _LAT] = dr
        return out + tp + tq + tr

    def body_coefficients(
        self, alpha_deg, beta_deg, p, q, r, V_fps, surfaces: Mapping[str, object] | None = None
    ) -> np.ndarray:
        """Body-axis ``[CX, CY, CZ, Cl, Cm, Cn]`` about the 25 % MAC reference (last axis).

        Parameters
        ----------
        alpha_deg, beta_deg : array_like
            Angle of attack and sideslip [deg].
        p, q, r : array_like
            Body rates [rad/s].
        V_fps : array_like
            True airspeed [ft/s].
        surfaces : mapping, optional
            Deflections of any of :data:`SURFACES` [deg] (GEAR 0/1); others 0.

        Returns
        -------
        ndarray, shape (..., 6)
            The coefficients, inputs broadcast together.

        Raises
        ------
        InputError
            A surface name not in :data:`SURFACES`.
        """
        s = {k: 0.0 for k in SURFACES}
        for k, v in (surfaces or {}).items():
            if k not in s:
                raise InputError(f"unknown GTM surface {k!r}; known: {', '.join(SURFACES)}")
            s[k] = v
        arrays = np.broadcast_arrays(
            *(np.asarray(x, dtype=float) for x in (alpha_deg, beta_deg, p, q, r, V_fps, *s.values()))
        )
        a, b, p, q, r, V = arrays[:6]
        s = dict(zip(s, arrays[6:]))
        return self.basic(a, b) + self.surfaces(a, b, s) + self.dynamic(a, b, p, q, r, V)


def load_vehicle() -> dict:
    """The vendored GTM vehicle data (``vehicle.json``, every value with its source).

    Returns
    -------
    dict
        The parsed JSON: mass, inertia, geometry, reference points, engines (source units: lb, slug ft^2, ft).
    """
    with _data_file("vehicle.json").open("r") as fh:
        return json.load(fh)


def grouped_surfaces(elevator=0.0, aileron=0.0, rudder=0.0) -> dict:
    """The simulation's trim-mode grouping of the surfaces.

    All elevator panels together, ``AILL = -aileron``, ``AILR = +aileron`` (positive: right trailing edge
    down), both rudder panels together; stabilizer, flaps, spoilers 0, gear up.

    Parameters
    ----------
    elevator, aileron, rudder : float or array_like
        Grouped deflections [deg].

    Returns
    -------
    dict of str to float or ndarray
        Deflection of every one of :data:`SURFACES` [deg].
    """
    s = {k: 0.0 for k in SURFACES}
    for k in ("ELLOB", "ELLIB", "ELRIB", "ELROB"):
        s[k] = elevator
    s["AILL"] = -np.asarray(aileron, dtype=float)
    s["AILR"] = aileron
    s["RUDU"] = s["RUDL"] = rudder
    return s


class GTMSource(SourceModel):
    """The GTM database in the project's conventions, clean configuration.

    ``dl`` is the aileron command (right trailing edge down positive:
    ``AILR = dl``, ``AILL = -dl``), ``dm`` all four elevator panels, ``dn``
    both rudder panels (trailing edge left positive); stabilizer 0, flaps and
    spoilers 0, gear up.  Moments about the 25 % MAC reference point.

    Rates: ``p = phat 2V/b`` etc. with ``V = V_ref``; the database normalises
    them again with ``V' = 1.000711 V``, so the result does not depend on
    ``V_ref`` (any positive value above 1 kt).

    Parameters
    ----------
    database : GTMAeroDatabase, optional
        Default: the vendored one.
    V_ref : float
        Airspeed [m/s] used to turn the nondimensional rates into rad/s.

    Raises
    ------
    InputError
        ``V_ref`` not finite or not above 1 kt.
    """

    def __init__(self, database: GTMAeroDatabase | None = None, V_ref: float = 75.0 * units.KT):
        self.db = database if database is not None else GTMAeroDatabase.load()
        if not (math.isfinite(V_ref) and V_ref > units.KT):
            raise InputError(f"GTM reference speed must exceed 1 kt, got {V_ref} m/s")
        self.V_ref = float(V_ref)
        self.name = "NASA GTM T2 aerodynamic database (GTM_DesignSim), clean configuration"
        d = math.radians
        a_lo = self.db.breakpoint_range("C6_bas", 0)[0]
        a_hi = min(self.db.breakpoint_range("C6_bas", 0)[1], self.db.breakpoint_range("dC3_q", 0)[1])
        b_lo, b_hi = self.db.breakpoint_range("C6_bas", 1)
        el = self.db.breakpoint_range("dC3_ele", 3)
        ai = self.db.breakpoint_range("dC6_ail", 2)
        ru = self.db.breakpoint_range("dC6_rud", 2)
        self.envelope = {
            "alpha": (d(a_lo), d(a_hi)),
            "beta": (d(b_lo), d(b_hi)),
            "phat": self.db.breakpoint_range("dC3_p", 1),
            "qhat": self.db.breakpoint_range("dC3_q", 1),
            "rhat": self.db.breakpoint_range("dC3_r", 1),
            "dl": (d(ai[0]), d(ai[1])),
            "dm": (d(el[0]), d(el[1])),
            "dn": (d(ru[0]), d(-ru[0])),
        }
        self.envelope_origin = {
            "alpha": "static tables C6_bas etc. from -5 deg; pitch forced-oscillation table dC3_q to 50 deg",
            "beta": "static tables",
            "phat": "roll forced-oscillation table dC3_p",
            "qhat": "pitch forced-oscillation table dC3_q",
            "rhat": "yaw forced-oscillation table dC3_r",
            "dl": "aileron table dC6_ail",
            "dm": "elevator breakpoints of dC3_ele",
            "dn": "rudder table dC6_rud (negative deflections, mirrored)",
        }

    def body_coefficients(self, state: AeroState) -> np.ndarray:
        """The database's body-axis coefficients at states in the project's variables.

        Parameters
        ----------
        state : AeroState
            The eight aerodynamic variables (broadcast together) [rad / nondimensional]; the rates are
            made dimensional with :attr:`V_ref`.

        Returns
        -------
        ndarray, shape (..., 6)
            ``[CX, CY, CZ, Cl, Cm, Cn]`` about the 25 % MAC reference point.
        """
        st, _ = broadcast_state(state)
        V = self.V_ref / units.FT
        p = st.phat * 2.0 * V / self.db.b
        q = st.qhat * 2.0 * V / self.db.cbar
        r = st.rhat * 2.0 * V / self.db.b
        s = grouped_surfaces(np.degrees(st.dm), np.degrees(st.dl), np.degrees(st.dn))
        return self.db.body_coefficients(np.degrees(st.alpha), np.degrees(st.beta), p, q, r, V, s)

    def coefficients(self, state: AeroState) -> Coefficients:
        st, _ = broadcast_state(state)
        c = self.body_coefficients(st)
        CD, CL = stability_from_body(st.alpha, c[..., 0], c[..., 2])
        return Coefficients(CD, c[..., 1], CL, c[..., 3], c[..., 4], c[..., 5])

    def provenance(self) -> dict[str, str]:
        return {
            "source": "NASA GTM_DesignSim (github.com/nasa/GTM_DesignSim, commit 9717143), "
            "T2_polynomial_aerodatabase.mat 'Polynominal Fit Aero database (unlimited distribution), "
            "Version 0.2', vendored in gna/data/sources/gtm",
            "source_model": "gna.fit.sources.gtm: the simulation's Aero subsystem re-implemented (nominal, "
            "clean: stab 0, flaps 0, spoilers 0, gear up); checked against "
            "reference_points.csv",
        }


def vehicle_sections() -> dict[str, dict]:
    """``[mass]``, ``[geometry]``, ``[engines]`` sections of the GTM aircraft file (source units).

    Inertia: the values the simulation uses at zero fuel burn (``Inertia0``
    plus the constant terms of its fuel polynomials); ``Ixy`` (0.006 slug ft^2)
    is dropped (the project's model is symmetric).  Thrust line: the mean of
    the two engines' pitch angles; their toe angles (2.22 and -1.18 deg) and
    the thrust line's 0.33 ft offset below the CG are not represented.

    Returns
    -------
    dict of str to dict
        ``mass``, ``geometry``, ``engines`` in the aircraft-file layout, each with its ``source``.

    Raises
    ------
    InputError
        The two engines are not symmetric about the plane of symmetry.
    """
    veh = load_vehicle()
    inertia = veh["inertia"]["as_used_by_sim_at_fuel_used_0"]
    geo = veh["geometry"]
    rp = veh["reference_points"]
    eng = veh["engines"]
    yl, yr = eng["left"]["position_ft"][1], eng["right"]["position_ft"][1]
    if abs(yl + yr) > 1e-9:
        raise InputError(f"GTM engines are not symmetric (y = {yl}, {yr} ft)")
    pitch = 0.5 * (eng["left"]["angles_deg"][1] + eng["right"]["angles_deg"][1])
    static = eng["thrust_model"]["static_sea_level_thrust_per_engine_lbf"]["throttle_100pct"]
    return {
        "mass": {
            "weight_lb": veh["mass"]["weight_w0_lbf"],
            "Ixx_slugft2": inertia["Ixx_slug_ft2"],
            "Iyy_slugft2": inertia["Iyy_slug_ft2"],
            "Izz_slugft2": inertia["Izz_slug_ft2"],
            "Ixz_slugft2": inertia["Ixz_slug_ft2"],
            "source": "GTM_DesignSim AC_baseparams_T2.m:13,22-28,38-40 via gna/data/sources/gtm/vehicle.json "
            "(weight w0; inertia as the simulation uses it at zero fuel burn, gear up; "
            f"Ixy = {inertia['Ixy_slug_ft2']} slug ft^2 dropped)",
        },
        "geometry": {
            "S_ft2": geo["S_ft2"],
            "b_ft": geo["b_ft"],
            "cbar_ft": geo["cbar_ft"],
            "x_cg_cbar": round(rp["cg_percent_mac"] / 100.0, 12),
            "x_ref_cbar": round(rp["ref_percent_mac"] / 100.0, 12),
            "source": "AC_baseparams_T2.m:43-48 via vehicle.json: CG cg_pos0 (21.99 % MAC, full fuel, gear "
            "up), moment reference 25 % MAC; the CG's offsets of 0.036 ft up and 0.0118 ft left "
            "of the reference are not represented",
        },
        "engines": {
            "count": 2,
            "y_p_ft": yr,
            "epsilon_deg": round(pitch, 12),
            "max_thrust_lbf": 2.0 * static,
            "source": "AC_baseparams_T2.m:57-60 via vehicle.json: engines at y = +-1.1833 ft, thrust line "
            "pitched up by the mean of 1.98 and 1.95 deg; toe angles (2.22, -1.18 deg) and the "
            "0.33 ft offset of the thrust line below the CG not represented; max thrust = 2 x "
            f"{static:.4f} lbf, sea-level static at 100 % throttle from the JetCat P70 curve fits",
        },
    }
