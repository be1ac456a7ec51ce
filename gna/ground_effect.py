"""Ground effect: lift and induced drag of the aircraft by height over span (an environment option).

The model
---------
Near the ground the image of the wing's trailing vortex system (mirrored in
the ground plane) cancels part of the downwash at the wing.  With ``h`` the
height of the wing above a flat ground and ``b`` the span, the induced drag at
a given lift is multiplied by

.. math::  \\phi(h/b) = \\frac{(16\\,h/b)^2}{1 + (16\\,h/b)^2}

(McCormick, *Aerodynamics, Aeronautics, and Flight Mechanics*, 2nd ed.,
Wiley, 1995, ch. 7, *Airplane performance*, takeoff: "ground effect"; the
expression fits the image-vortex result for an elliptically loaded wing).
``phi`` is 0.959 at ``h/b = 0.3``, 0.719 at 0.1 and 0.990 at 0.6.

The same downwash reduction lowers the wing's induced angle of attack
``alpha_i = C_L / (pi e A)`` (McCormick 1995, ch. 4, "Induced drag":
``C_Di = C_L alpha_i``) to ``phi C_L/(pi e A)``.  In the lifting-line lift
slope of a finite wing, ``C_L,alpha = a0 / (1 + a0/(pi e A))`` (McCormick
1995, ch. 3, "The lifting characteristics of a finite wing" / "The lifting
line model"; with the Oswald factor ``e`` for the planform factor
``1/(1 + tau)``), this is the *equivalent aspect ratio* ``A/phi``, so at the
same angle of attack (from zero lift) the lift is multiplied by

.. math::  k_L(h/b) = \\frac{1 + a_0/(\\pi e A)}{1 + \\phi\\, a_0/(\\pi e A)}.

How it is applied to a GNA polynomial model
-------------------------------------------
A GNA model gives ``C_L`` and ``C_D`` as polynomials with no explicit
lift-slope / induced-drag split.  The correction therefore treats the model's
free-air lift ``C_L`` (all its terms: angle of attack, surfaces, rates) as the
lift of a wing of the aircraft's aspect ratio ``A = b^2/S`` with a stated
Oswald factor ``e`` (default 0.8) and section slope ``a0`` (default ``2 pi``,
thin-airfoil theory), and that free-air ``C_D`` contains the free-air induced
drag ``C_L^2/(pi e A)``:

* ``C_L,g = k_L C_L``;
* ``C_D,g = C_D - C_L^2/(pi e A) + phi C_L,g^2/(pi e A)
  = C_D + (phi k_L^2 - 1) C_L^2/(pi e A)``:
  the free-air induced drag is replaced by the ground-effect induced drag of
  the lift actually produced;
* side force and the three moment coefficients are unchanged (the change of
  downwash at the tail, hence of ``C_m``, is not modelled); the moments
  transferred from the moment reference to the CG use the corrected forces.

Height and attitude: ``h`` is the altitude of the aircraft reference point
(the centre of gravity, the point whose NED position ``(x, y, z)`` the model
integrates) above a flat horizontal ground at elevation
:attr:`GroundEffect.elevation`: ``h = -z - elevation``.  The wing is taken at
the CG's height whatever the pitch and bank (no attitude correction: a banked
wing's lower tip is not brought nearer the ground).  This is exactly JSBSim's
``aero/h_b-cg-ft`` (distance of the CG above the terrain over the span, see
:mod:`harness.engines.jsbsim.export`).

Every function is rational in ``z`` (no branch on values): it evaluates on
floats, numpy arrays and truncated power series alike, as :mod:`gna.eom` requires.
The model holds for ``h > 0``; :meth:`GroundEffect.check_height` refuses a
height at or below the ground (trim, plan nodes); the engines stop a flight
that reaches it (:func:`gna.trajectory.domain_bounds`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .aero import Coefficients
from .errors import DomainError, InputError

#: The constant 16 of McCormick's induced-drag factor ``phi = (16 h/b)^2 / (1 + (16 h/b)^2)``.
MCCORMICK_CONSTANT = 16.0


def induced_drag_factor(h_over_b):
    """McCormick's ground-effect factor on the induced drag, ``phi = (16 h/b)^2 / (1 + (16 h/b)^2)``.

    McCormick, *Aerodynamics, Aeronautics, and Flight Mechanics*, 2nd ed., 1995, ch. 7 (takeoff, ground effect).

    Parameters
    ----------
    h_over_b : float, array or Series
        Height of the wing above the ground over the span [-].

    Returns
    -------
    float, array or Series
        ``phi`` in [0, 1): the induced drag at a given lift is multiplied by ``phi``; 1 far from the ground.
    """
    x = MCCORMICK_CONSTANT * h_over_b
    x2 = x * x
    return x2 / (1.0 + x2)


def lift_factor(h_over_b, aspect_ratio: float, oswald: float = 0.8, section_lift_slope: float = 2.0 * math.pi):
    """Lift ratio in/out of ground effect at the same angle of attack, ``k_L = (1 + K)/(1 + phi K)``.

    ``K = a0/(pi e A)``: the lifting-line lift slope ``a0/(1 + K)`` (McCormick 1995, ch. 3, lifting line)
    with the induced angle reduced by :func:`induced_drag_factor` (equivalent aspect ratio ``A/phi``).

    Parameters
    ----------
    h_over_b : float, array or Series
        Height of the wing above the ground over the span [-].
    aspect_ratio : float
        Wing aspect ratio ``A = b^2/S`` [-].
    oswald : float
        Oswald span efficiency factor ``e`` [-].
    section_lift_slope : float
        Section (two-dimensional) lift slope ``a0`` [1/rad].

    Returns
    -------
    float, array or Series
        ``k_L >= 1``; 1 far from the ground.
    """
    K = section_lift_slope / (math.pi * oswald * aspect_ratio)
    return (1.0 + K) / (1.0 + K * induced_drag_factor(h_over_b))


@dataclass(frozen=True)
class GroundEffect:
    """Ground effect on lift and induced drag over a flat, horizontal ground (see the module notes).

    Parameters
    ----------
    elevation : float
        Ground elevation [m]: altitude (``-z``) of the ground plane.
    oswald : float
        Oswald span efficiency factor ``e`` of the induced drag ``C_L^2/(pi e A)`` [-], in (0, 1].
    section_lift_slope : float
        Section lift slope ``a0`` [1/rad] of the lifting-line lift slope; default ``2 pi`` (thin airfoil).

    Raises
    ------
    InputError
        A non-finite elevation, ``e`` outside (0, 1] or a non-positive ``a0``.
    """

    elevation: float = 0.0
    oswald: float = 0.8
    section_lift_slope: float = 2.0 * math.pi

    def __post_init__(self):
        if not math.isfinite(self.elevation):
            raise InputError(f"ground effect: the ground elevation must be finite, got {self.elevation!r} m")
        if not (math.isfinite(self.oswald) and 0.0 < self.oswald <= 1.0):
            raise InputError(f"ground effect: the Oswald factor must be in (0, 1], got {self.oswald!r}")
        if not (math.isfinite(self.section_lift_slope) and self.section_lift_slope > 0.0):
            raise InputError(
                f"ground effect: the section lift slope must be positive [1/rad], got {self.section_lift_slope!r}"
            )

    def height_over_span(self, span: float, z):
        """Height of the CG above the ground over the span, ``h/b = (-z - elevation)/b``.

        Parameters
        ----------
        span : float
            Wing span ``b`` [m].
        z : float, array or Series
            NED down coordinate of the CG [m] (altitude ``-z``).

        Returns
        -------
        float, array or Series
            ``h/b`` [-].
        """
        return (-z - self.elevation) * (1.0 / span)

    def coefficients(self, aircraft, z, c: Coefficients) -> Coefficients:
        """Free-air coefficients corrected for the ground: ``C_L k_L`` and ``C_D + (phi k_L^2 - 1) C_L^2/(pi e A)``.

        Parameters
        ----------
        aircraft : Aircraft
            Its span ``b`` [m] and wing area ``S`` [m^2] give ``A = b^2/S``.
        z : float, array or Series
            NED down coordinate of the CG [m].
        c : Coefficients
            Free-air coefficients (stability-axis ``CD, CL``); floats, arrays or series.

        Returns
        -------
        Coefficients
            ``c`` with ``CL`` and ``CD`` corrected; ``CY, Cl, Cm, Cn`` unchanged.
        """
        geo = aircraft.geometry
        A = geo.b * geo.b / geo.S
        hb = self.height_over_span(geo.b, z)
        phi = induced_drag_factor(hb)
        K = self.section_lift_slope / (math.pi * self.oswald * A)
        kL = (1.0 + K) / (1.0 + K * phi)
        CL2 = c.CL * c.CL
        return c._replace(CL=kL * c.CL, CD=c.CD + (phi * kL * kL - 1.0) * CL2 * (1.0 / (math.pi * self.oswald * A)))

    def check_height(self, h, where: str = "", times=None) -> None:
        """Refuse a height at or below the ground (the model needs ``h > 0``).

        Parameters
        ----------
        h : float or array_like
            Altitude(s) ``-z`` [m] (constant terms of series).
        where : str
            What the altitude is (for the message).
        times : array_like, optional
            Times [s] of the altitudes (the message names the first bad one).

        Raises
        ------
        DomainError
            An altitude at or below the ground elevation (``variable = "altitude"``).
        """
        c = getattr(h, "constant_term", None)
        hv = np.atleast_1d(np.real(np.asarray(c if c is not None else h, dtype=float)))
        bad = ~(hv > self.elevation)
        if bad.any():
            i = int(np.argmax(bad))
            t = None if times is None else float(np.atleast_1d(times)[i])
            at = (f" at t = {t:g} s" if t is not None else "") + (f" ({where})" if where else "")
            raise DomainError(
                f"altitude {hv[i]:g} m{at} is at or below the ground at {self.elevation:g} m: "
                f"the ground-effect model needs a positive height",
                variable="altitude",
                value=float(hv[i]),
                time=t,
            )

    def describe(self) -> str:
        """One line for run settings: the model, its source and its parameters.

        Returns
        -------
        str
            The ground elevation [m], the model (McCormick 1995), Oswald factor and section lift slope.
        """
        return (
            f"ground effect over a flat ground at {self.elevation:g} m (McCormick 1995 phi(h/b) on induced "
            f"drag, lifting-line lift factor; e = {self.oswald:g}, a0 = {self.section_lift_slope:.6g} /rad; "
            f"h at the CG, no attitude correction)"
        )


def ground_effect_coefficients(aircraft, env, z, c: Coefficients) -> Coefficients:
    """``c`` corrected by ``env.ground_effect`` (``c`` itself when the environment has none).

    Parameters
    ----------
    aircraft : Aircraft
        Span and wing area.
    env : Environment
        Its ``ground_effect`` (a :class:`GroundEffect` or None).
    z : float, array or Series
        NED down coordinate of the CG [m].
    c : Coefficients
        Free-air coefficients.

    Returns
    -------
    Coefficients
        Corrected coefficients, or ``c`` unchanged (the same object) without ground effect.
    """
    ge = getattr(env, "ground_effect", None)
    return c if ge is None else ge.coefficients(aircraft, z, c)
