"""JSBSim's position without the round-off of its ECEF storage on the flat-earth sphere.

JSBSim integrates the position in the Earth-centred inertial frame, one add per
step and axis (``FGPropagate::Integrate``: ``r += dt (w0 v_k + w1 v_{k-1} +
...)``).  On the flat-earth sphere (radius ``R`` = 1e11 ft,
:data:`harness.engines.jsbsim.export.PLANET_RADIUS_FT`) the run starts at
latitude and longitude 0, where the inertial x axis is the local vertical and
``x`` is about ``R``: a double there has a spacing ``u = ulp(R)`` = 2^-16 ft
(4.65 um), and every vertical increment is rounded to a multiple of it.  A
steady vertical speed ``w`` thus moves the stored position at the nearest
multiple of the quantum ``q = u / dt`` (2.23 mm/s at 1/480 s; the velocity
itself is not rounded), and the altitude drifts by ``T (q round(w / q) - w)``,
up to ``T q / 2`` (6.7 cm in 60 s): the Twin Otter
climbing at 1.5 m/s gains 1.25e-4 of its climb more in JSBSim (1.14 cm in 60 s)
although its speed and flight-path angle agree to 1e-7.  The horizontal axes,
near 0, are not affected.

:class:`PositionRoundoff` replays JSBSim's own position integrator on its own
inertial velocities (read every step), accumulating the increments near 0
where their spacing is negligible, and corrects the position read by the sum
of the rounding errors: the position JSBSim's discrete integration gives in
exact arithmetic.  The dynamics are not changed (a centimetre of altitude
changes the density by 1e-6 and the gravity by 1e-12, relative).
"""

from __future__ import annotations

import math
from collections import deque

#: Weights of JSBSim's position integrators (``FGPropagate::Integrate``), newest derivative first, times dt.
POSITION_WEIGHTS: dict[str, tuple[float, ...]] = {
    "none": (),
    "Euler": (1.0,),
    "trapezoidal": (0.5, 0.5),
    "AB2": (1.5, -0.5),
    "AB3": (23.0 / 12.0, -16.0 / 12.0, 5.0 / 12.0),
    "AB4": (55.0 / 24.0, -59.0 / 24.0, 37.0 / 24.0, -9.0 / 24.0),
    "AB5": (1901.0 / 720.0, -1387.0 / 360.0, 109.0 / 30.0, -637.0 / 360.0, 251.0 / 720.0),
}

#: JSBSim properties of the inertial position [ft] and velocity [ft/s].
ECI_POSITION = ("position/eci-x-ft", "position/eci-y-ft", "position/eci-z-ft")
ECI_VELOCITY = ("velocities/eci-x-fps", "velocities/eci-y-fps", "velocities/eci-z-fps")


class PositionRoundoff:
    """The round-off of JSBSim's inertial position, accumulated step by step.

    Parameters
    ----------
    position, velocity : sequence of 3 callables
        Readers of :data:`ECI_POSITION` [ft] and :data:`ECI_VELOCITY` [ft/s].
    integrator : str
        JSBSim's translational position integrator (a key of :data:`POSITION_WEIGHTS`).
    dt : float
        JSBSim's step [s].

    Notes
    -----
    Create it once JSBSim's initial condition is run (its derivative history
    then holds the initial velocity, ``FGPropagate::InitializeDerivatives``)
    and call :meth:`advance` after every ``run()`` that integrates.  The
    replayed increments are summed near 0 (running sums of the velocities,
    :meth:`displacement`), so their own round-off is about ``n ulp(|C|)`` times
    the step: 1e-8 m in 60 s at 1/480 s and 60 m/s.

    Raises
    ------
    ValueError
        An integrator without position weights (JSBSim refuses those for the position).
    """

    def __init__(self, position, velocity, integrator: str, dt: float):
        if integrator not in POSITION_WEIGHTS:
            raise ValueError(f"no position weights for JSBSim integrator {integrator!r}")
        self._read_r = tuple(position)
        self._read_v = tuple(velocity)
        self.weights = tuple(w * dt for w in POSITION_WEIGHTS[integrator])
        self._k_full = sum(i * w for i, w in enumerate(self.weights))
        self.r0 = [r() for r in self._read_r]
        self.v0 = self._v = tuple(v() for v in self._read_v)
        self.steps = 0
        # Running sums C_j = v_0 + ... + v_j of the velocities before each step, the last len(weights) of them.
        self._c = (0.0, 0.0, 0.0)
        self._sums: deque = deque(maxlen=max(len(self.weights), 1))
        self.largest = 0.0  # largest correction returned so far [ft]

    def advance(self) -> None:
        """One integrating step done: the velocity before it added to the running sum, the new one read."""
        c, v = self._c, self._v
        self._c = c = (c[0] + v[0], c[1] + v[1], c[2] + v[2])
        self._sums.appendleft(c)
        r = self._read_v
        self._v = (r[0](), r[1](), r[2]())
        self.steps += 1

    def displacement(self) -> list[float]:
        """The sum of the increments of the steps so far, as JSBSim's integrator computes them [ft].

        Step ``j`` (from 1) adds ``sum_i w_i v_{j-1-i}``, the history before
        the first step being the initial velocity: over ``n`` steps
        ``sum_i w_i (min(i, n) v_0 + C_{n-1-i})`` with the running sums
        ``C_k = v_0 + ... + v_k`` (``C_k = 0`` for ``k < 0``), so that a step
        costs three additions whatever the integrator.

        Returns
        -------
        list of 3 float
            ECI x, y, z [ft].
        """
        n, v0, sums, ws = self.steps, self.v0, self._sums, self.weights
        if n >= len(ws):  # the history is all steps': the v_0 terms are sum_i i w_i v_0
            k = self._k_full
            x, y, z = k * v0[0], k * v0[1], k * v0[2]
            for w, c in zip(ws, sums):
                x += w * c[0]
                y += w * c[1]
                z += w * c[2]
            return [x, y, z]
        x = y = z = 0.0
        for i, w in enumerate(ws):
            k = min(i, n) * w
            x += k * v0[0]
            y += k * v0[1]
            z += k * v0[2]
            if i < n:
                c = sums[i]
                x += w * c[0]
                y += w * c[1]
                z += w * c[2]
        return [x, y, z]

    def error(self) -> tuple[list[float], list[float]]:
        """JSBSim's inertial position minus the replayed one (its accumulated rounding errors).

        Returns
        -------
        error : list of 3 float
            ECI x, y, z components [ft]; ``r - r0`` is exact (Sterbenz) for the small
            displacements of a run on the huge sphere.
        position : list of 3 float
            JSBSim's inertial position read [ft].
        """
        r = [f() for f in self._read_r]
        return [(a - b) - c for a, b, c in zip(r, self.r0, self.displacement())], r

    def correct(self, raw: list, radius_ft: float) -> list:
        """Latitude, longitude and altitude read from JSBSim, less the accumulated round-off (in place).

        Parameters
        ----------
        raw : list
            ``raw[0:3]`` = geocentric latitude [rad], longitude [rad] and
            altitude above the sphere [ft] (the flat-planet position nodes).
        radius_ft : float
            The sphere's radius [ft].

        Returns
        -------
        list
            ``raw``, its first three entries corrected.
        """
        e, r = self.error()
        ex, ey, ez = e
        x, y, z = r
        rho2 = x * x + y * y
        rho, norm = math.sqrt(rho2), math.sqrt(rho2 + z * z)
        e_up = (ex * x + ey * y + ez * z) / norm
        e_east = (ey * x - ex * y) / rho
        e_north = (ez * rho2 - z * (ex * x + ey * y)) / (rho * norm)
        self.largest = max(self.largest, math.sqrt(ex * ex + ey * ey + ez * ez))
        lat, h = raw[0], raw[2]
        raw[2] = h - e_up
        raw[0] = lat - e_north / (radius_ft + h)
        raw[1] -= e_east / ((radius_ft + h) * math.cos(lat))
        return raw
