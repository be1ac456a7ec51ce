"""Sampling designs: where a source model is evaluated for a fit.

A design is a list of *blocks*.  A block is a box in the eight aerodynamic
variables (alpha, beta [rad], phat, qhat, rhat [-], dl, dm, dn [rad]); a
variable whose interval has zero width is held fixed.  Each block serves the
coefficients listed with it and draws ``n_fit + n_test`` points independently
and uniformly in its box from ``numpy.random.default_rng([seed, k])`` (``k``
the block's position): the first ``n_fit`` are fitted, the last ``n_test``
are held out for validation.  The same design and seed give the same points.

:func:`standard_design` builds the design used for the bundled aircraft
(after ``shared/notes/jsbsim_aero_sampling.md``, its variants A/B):

* ``box``: all eight variables vary; fits CY, Cl, Cn (and CD, CL, Cm when
  ``longitudinal_plane`` is false);
* ``longitudinal``: alpha, qhat, dm vary; beta = phat = rhat = dl = dn = 0;
  fits CD, CL, Cm.  The GNA structure has no beta, |dm| or dm^2 term in CD,
  so fitting the longitudinal coefficients where the lateral variables are
  zero keeps the lateral variation (which the structure cannot represent)
  out of the drag polar and the pitching moment used for trim.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..aero import AERO_VARIABLES, COEFFICIENTS, AeroState
from ..errors import InputError

#: Variables shown in degrees in messages and reports.
ANGLE_VARIABLES: tuple[str, ...] = ("alpha", "beta", "dl", "dm", "dn")

#: Variables of the longitudinal plane.
LONGITUDINAL_VARIABLES: tuple[str, ...] = ("alpha", "qhat", "dm")


def _clean(x: float) -> float:
    """``x`` to 12 significant digits (degrees converted from radians read 30.0, not 29.999999999999996)."""
    return float(f"{x:.12g}")


def format_value(var: str, value: float) -> str:
    """``value`` of ``var`` in the unit people read it in (deg for angles), for messages.

    Parameters
    ----------
    var : str
        A name of :data:`gna.aero.AERO_VARIABLES`.
    value : float
        Its value [rad for :data:`ANGLE_VARIABLES`, nondimensional otherwise].

    Returns
    -------
    str
        Four significant digits, with ``" deg"`` for an angle.
    """
    return f"{math.degrees(value):.4g} deg" if var in ANGLE_VARIABLES else f"{value:.4g}"


def format_range(var: str, lo: float, hi: float) -> str:
    """An interval of ``var`` in the unit people read it in (deg for angles), for messages.

    Parameters
    ----------
    var : str
        A name of :data:`gna.aero.AERO_VARIABLES`.
    lo, hi : float
        Its bounds [rad for :data:`ANGLE_VARIABLES`, nondimensional otherwise].

    Returns
    -------
    str
        ``"[lo, hi]"`` to four significant digits, with ``" deg"`` for an angle.
    """
    if var in ANGLE_VARIABLES:
        return f"[{math.degrees(lo):.4g}, {math.degrees(hi):.4g}] deg"
    return f"[{lo:.4g}, {hi:.4g}]"


@dataclass(frozen=True)
class Block:
    """A box of the design and the coefficients fitted on it.

    Parameters
    ----------
    name : str
        Block name, unique in its design.
    coefficients : tuple of str
        Names of :data:`gna.aero.COEFFICIENTS` fitted on this block.
    ranges : mapping
        Every name of :data:`gna.aero.AERO_VARIABLES` -> ``(lo, hi)`` in rad or
        nondimensional; ``lo == hi`` holds the variable fixed.
    n_fit, n_test : int
        Points fitted and held out.
    dm_band : float
        If positive, ``dm`` is drawn uniformly in
        ``[dm0(alpha) - dm_band, dm0(alpha) + dm_band]`` intersected with its
        range, where ``dm0(alpha)`` is the source's pitch-trim schedule
        (:func:`elevator_schedule`); 0 draws ``dm`` over its whole range.

    Raises
    ------
    InputError
        An unknown coefficient, ranges not naming exactly the eight variables, a range that is not two
        finite numbers with ``lo <= hi``, ``n_fit`` or ``n_test`` not a positive integer, a negative
        ``dm_band``, or a positive one while alpha or dm is held fixed.
    """

    name: str
    coefficients: tuple[str, ...]
    ranges: Mapping[str, tuple[float, float]]
    n_fit: int
    n_test: int
    dm_band: float = 0.0

    def __post_init__(self):
        unknown = [c for c in self.coefficients if c not in COEFFICIENTS]
        if unknown:
            raise InputError(f"design block {self.name!r}: unknown coefficient(s) {', '.join(unknown)}")
        missing = [v for v in AERO_VARIABLES if v not in self.ranges]
        extra = [v for v in self.ranges if v not in AERO_VARIABLES]
        if missing or extra:
            raise InputError(
                f"design block {self.name!r}: ranges must give exactly {', '.join(AERO_VARIABLES)} "
                f"(missing: {', '.join(missing) or 'none'}; unknown: {', '.join(extra) or 'none'})"
            )
        clean = {}
        for v in AERO_VARIABLES:
            try:
                lo, hi = (float(x) for x in self.ranges[v])
            except (TypeError, ValueError):
                raise InputError(
                    f"design block {self.name!r}: range of {v} must be two numbers, got {self.ranges[v]!r}"
                ) from None
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise InputError(f"design block {self.name!r}: range of {v} is not finite ({lo}, {hi})")
            if lo > hi:
                raise InputError(
                    f"design block {self.name!r}: range of {v} is empty ({format_value(v, lo)} > {format_value(v, hi)})"
                )
            clean[v] = (lo, hi)
        object.__setattr__(self, "ranges", clean)
        for k in ("n_fit", "n_test"):
            n = getattr(self, k)
            if not isinstance(n, (int, np.integer)) or n < 1:
                raise InputError(f"design block {self.name!r}: {k} must be a positive integer, got {n!r}")
        if not (math.isfinite(self.dm_band) and self.dm_band >= 0):
            raise InputError(f"design block {self.name!r}: dm_band must be >= 0, got {self.dm_band}")
        if self.dm_band > 0 and not (
            self.ranges["dm"][1] > self.ranges["dm"][0] and self.ranges["alpha"][1] > self.ranges["alpha"][0]
        ):
            raise InputError(
                f"design block {self.name!r}: a dm band around the trim schedule needs alpha and dm to vary"
            )

    @property
    def varied(self) -> tuple[str, ...]:
        """Variables that vary in this block."""
        return tuple(v for v in AERO_VARIABLES if self.ranges[v][1] > self.ranges[v][0])

    def contains(self, other: Block) -> bool:
        """Whether ``other``'s box lies inside this one (its held-out points then also validate this block's fit).

        Parameters
        ----------
        other : Block
            Another block.

        Returns
        -------
        bool
            True when every range of ``other`` lies inside the same variable's range here.
        """
        return all(
            self.ranges[v][0] <= other.ranges[v][0] and other.ranges[v][1] <= self.ranges[v][1] for v in AERO_VARIABLES
        )

    def draw(self, rng: np.random.Generator, schedule=None) -> tuple[AeroState, AeroState]:
        """Independent uniform points of the box: ``n_fit`` to fit, ``n_test`` held out.

        With a positive :attr:`dm_band`, ``dm`` is drawn in the band around the schedule's ``dm0(alpha)``
        (linear interpolation), clipped to its range.

        Parameters
        ----------
        rng : numpy.random.Generator
            The random source (one ``rng.random((n_fit + n_test, 8))`` draw).
        schedule : tuple of two ndarray, optional
            ``(alpha_grid, dm0)`` [rad] from :func:`elevator_schedule`; needed when :attr:`dm_band` is positive.

        Returns
        -------
        fit, test : AeroState
            The points, each field an array of shape ``(n_fit,)`` resp. ``(n_test,)`` [rad / nondimensional].

        Raises
        ------
        InputError
            A positive :attr:`dm_band` without a ``schedule``.
        """
        n = self.n_fit + self.n_test
        u = rng.random((n, len(AERO_VARIABLES)))
        cols = []
        for j, v in enumerate(AERO_VARIABLES):
            lo, hi = self.ranges[v]
            cols.append(lo + (hi - lo) * u[:, j] if hi > lo else np.full(n, lo))
        if self.dm_band > 0:
            if schedule is None:
                raise InputError(
                    f"design block {self.name!r} samples dm around the trim schedule: the source is needed to draw it"
                )
            j = AERO_VARIABLES.index("dm")
            lo, hi = self.ranges["dm"]
            centre = np.interp(cols[0], schedule[0], schedule[1])
            a = np.clip(centre - self.dm_band, lo, hi)
            b = np.clip(centre + self.dm_band, lo, hi)
            cols[j] = a + (b - a) * u[:, j]
        fit = AeroState(*(c[: self.n_fit] for c in cols))
        test = AeroState(*(c[self.n_fit :] for c in cols))
        return fit, test

    def to_dict(self) -> dict:
        """The block as plain data for an aircraft file's provenance (angles in degrees).

        Returns
        -------
        dict
            ``coefficients``, ``n_fit``, ``n_test``, ``ranges`` (``<angle>_deg`` keys in deg, the rates
            nondimensional), and with a dm band ``dm_band_deg`` and ``dm_schedule`` (its description).
        """
        rng = {}
        for v in AERO_VARIABLES:
            lo, hi = self.ranges[v]
            if v in ANGLE_VARIABLES:
                rng[f"{v}_deg"] = [_clean(math.degrees(lo)), _clean(math.degrees(hi))]
            else:
                rng[v] = [lo, hi]
        out = {
            "coefficients": list(self.coefficients),
            "n_fit": int(self.n_fit),
            "n_test": int(self.n_test),
            "ranges": rng,
        }
        if self.dm_band > 0:
            out["dm_band_deg"] = _clean(math.degrees(self.dm_band))
            out["dm_schedule"] = SCHEDULE_DESCRIPTION
        return out


@dataclass(frozen=True)
class SamplingDesign:
    """Blocks of uniform random points, with a seed.

    Every coefficient appears in exactly one block (it is fitted on that
    block's fit points and validated on its held-out points, and also on the
    held-out points of any block whose box contains it).

    Parameters
    ----------
    blocks : sequence of Block
        At least one; unique names; each coefficient in at most one block.
    seed : int
        Non-negative; block ``k`` draws from ``numpy.random.default_rng([seed, k])``.
    description : str
        One line for provenance and reports (not compared).

    Raises
    ------
    InputError
        No block, duplicate block names, a coefficient in two blocks, or a negative or non-integer seed.
    """

    blocks: tuple[Block, ...]
    seed: int = 0
    description: str = field(default="", compare=False)

    def __post_init__(self):
        object.__setattr__(self, "blocks", tuple(self.blocks))
        if not self.blocks:
            raise InputError("a sampling design needs at least one block")
        names = [b.name for b in self.blocks]
        if len(set(names)) != len(names):
            raise InputError(f"design block names must be unique, got {names}")
        seen: dict[str, str] = {}
        for b in self.blocks:
            for c in b.coefficients:
                if c in seen:
                    raise InputError(f"coefficient {c} is fitted in two design blocks ({seen[c]!r}, {b.name!r})")
                seen[c] = b.name
        if not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise InputError(f"design seed must be a non-negative integer, got {self.seed!r}")

    def block_of(self, coefficient: str) -> Block:
        """The block that fits ``coefficient``.

        Parameters
        ----------
        coefficient : str
            A name of :data:`gna.aero.COEFFICIENTS`.

        Returns
        -------
        Block
            The block listing it.

        Raises
        ------
        InputError
            No block fits it.
        """
        for b in self.blocks:
            if coefficient in b.coefficients:
                return b
        raise InputError(f"the sampling design fits no block for {coefficient}")

    def draw(self, source=None) -> dict[str, tuple[AeroState, AeroState]]:
        """The points of every block, reproducibly from :attr:`seed`.

        Parameters
        ----------
        source : object, optional
            The source model (``coefficients(AeroState)``), needed by blocks with a dm band to compute
            their :func:`elevator_schedule`.

        Returns
        -------
        dict of str to (AeroState, AeroState)
            Block name -> (fit states, held-out states) (:meth:`Block.draw`).

        Raises
        ------
        InputError
            A block with a dm band and no ``source`` (from :func:`elevator_schedule`).
        """
        out = {}
        for k, b in enumerate(self.blocks):
            sched = elevator_schedule(source, b.ranges["alpha"], b.ranges["dm"]) if b.dm_band > 0 else None
            out[b.name] = b.draw(np.random.default_rng([int(self.seed), k]), sched)
        return out

    def to_dict(self) -> dict:
        """The design as plain data for an aircraft file's provenance.

        Returns
        -------
        dict
            ``method``, ``seed``, ``description`` and ``blocks`` (name -> :meth:`Block.to_dict`).
        """
        return {
            "method": "independent uniform points per block, numpy.random.default_rng([seed, block index])",
            "seed": int(self.seed),
            "description": self.description,
            "blocks": {b.name: b.to_dict() for b in self.blocks},
        }


SCHEDULE_DESCRIPTION = (
    "dm0(alpha) solves Cm = 0 at beta = phat = qhat = rhat = dl = dn = 0 on a 0.5 deg alpha "
    "grid (bisection, 60 steps, within the dm range; the range end of smaller |Cm| where Cm "
    "does not change sign), linearly interpolated"
)


def elevator_schedule(
    source,
    alpha_range: tuple[float, float],
    dm_range: tuple[float, float],
    step: float = math.radians(0.5),
    iterations: int = 60,
) -> tuple[np.ndarray, np.ndarray]:
    """The source's pitch-trim schedule ``dm0(alpha)`` on a grid over ``alpha_range``.

    ``Cm(alpha, 0, 0, 0, 0, 0, dm0, 0) = 0`` by bisection, all grid points at
    once; where Cm does not change sign over ``dm_range`` the end with the
    smaller ``|Cm|`` is taken.

    Parameters
    ----------
    source : object
        The source model: ``source.coefficients(AeroState)`` gives the coefficients (its ``Cm`` is used).
    alpha_range : tuple of float
        ``(lo, hi)`` angle of attack [rad].
    dm_range : tuple of float
        ``(lo, hi)`` elevator deflection [rad] searched.
    step : float
        Largest grid spacing in alpha [rad] (default 0.5 deg; at least two points).
    iterations : int
        Bisection steps.

    Returns
    -------
    alpha, dm0 : ndarray, shape (n,)
        The alpha grid and the trim elevator at each point [rad].

    Raises
    ------
    InputError
        ``source`` is None.
    """
    if source is None:
        raise InputError("a dm band around the trim schedule needs the source model")
    a_lo, a_hi = alpha_range
    n = max(2, int(math.ceil((a_hi - a_lo) / step)) + 1)
    alpha = np.linspace(a_lo, a_hi, n)
    zero = np.zeros(n)

    def cm(dm):
        c = source.coefficients(AeroState(alpha, zero, zero, zero, zero, zero, dm, zero))
        return np.broadcast_to(np.asarray(c.Cm, dtype=float), (n,))

    lo = np.full(n, float(dm_range[0]))
    hi = np.full(n, float(dm_range[1]))
    f_lo, f_hi = cm(lo), cm(hi)
    bracket = np.sign(f_lo) != np.sign(f_hi)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        f_mid = cm(mid)
        left = np.sign(f_mid) == np.sign(f_lo)
        lo = np.where(left, mid, lo)
        f_lo = np.where(left, f_mid, f_lo)
        hi = np.where(left, hi, mid)
    root = 0.5 * (lo + hi)
    ends = np.where(np.abs(cm(np.full(n, dm_range[0]))) < np.abs(cm(np.full(n, dm_range[1]))), dm_range[0], dm_range[1])
    return alpha, np.where(bracket, root, ends)


def standard_design(
    ranges: Mapping[str, tuple[float, float]],
    *,
    n_fit: int = 4000,
    n_test: int = 1000,
    seed: int = 0,
    longitudinal_plane: bool = True,
    n_fit_lon: int | None = None,
    n_test_lon: int | None = None,
    dm_band: float = 0.0,
) -> SamplingDesign:
    """The design of the bundled fits: an 8-D box, plus the longitudinal plane for CD, CL, Cm.

    Parameters
    ----------
    ranges : mapping
        Variable -> (lo, hi), rad / nondimensional, for all eight variables.
    n_fit, n_test : int
        Points of the box block.
    seed : int
        Seed of the design (:class:`SamplingDesign`).
    longitudinal_plane : bool
        Fit CD, CL, Cm on the plane beta = phat = rhat = dl = dn = 0 (those
        ranges must contain 0); otherwise on the box.
    n_fit_lon, n_test_lon : int, optional
        Points of the plane block (default: ``n_fit``, ``n_test``).
    dm_band : float
        Half-width [rad] of the dm band around the trim schedule on the plane
        (0: dm over its whole range).

    Returns
    -------
    SamplingDesign
        Blocks ``box`` (CY, Cl, Cn; all six coefficients without the plane) and ``longitudinal`` (CD, CL, Cm).

    Raises
    ------
    InputError
        With the plane, a range of beta, phat, rhat, dl or dn that excludes 0; or an invalid block
        (:class:`Block`).
    """
    box = Block("box", ("CY", "Cl", "Cn") if longitudinal_plane else COEFFICIENTS, ranges, n_fit, n_test)
    if not longitudinal_plane:
        return SamplingDesign((box,), seed, "8-D box for all six coefficients")
    lon = {}
    for v in AERO_VARIABLES:
        lo, hi = box.ranges[v]
        if v in LONGITUDINAL_VARIABLES:
            lon[v] = (lo, hi)
        else:
            if not lo <= 0.0 <= hi:
                raise InputError(f"the longitudinal plane holds {v} = 0, outside its range {format_range(v, lo, hi)}")
            lon[v] = (0.0, 0.0)
    plane = Block(
        "longitudinal",
        ("CD", "CL", "Cm"),
        lon,
        n_fit if n_fit_lon is None else n_fit_lon,
        n_test if n_test_lon is None else n_test_lon,
        dm_band,
    )
    band = f", dm within {math.degrees(dm_band):.3g} deg of the pitch-trim schedule" if dm_band > 0 else ""
    return SamplingDesign(
        (box, plane),
        seed,
        "CY, Cl, Cn fitted on the 8-D box; CD, CL, Cm on the longitudinal plane "
        f"(beta = phat = rhat = dl = dn = 0{band})",
    )
