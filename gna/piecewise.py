"""Piecewise polynomials of time: control histories an integrator calls thousands of times.

A plan's controls between nodes are polynomials of ``t - t_i`` on each interval ``[t_i, t_(i+1)]``.
The integrators call them once per right-hand-side evaluation at a single time, so the scalar path
(:meth:`PiecewisePolynomial.__call__`) is written for one float: a bisection on a Python list and a
Horner sum on Python floats per function of one interval (the same operations, in the same order, as
the vectorised path).  :meth:`PiecewisePolynomial.evaluate`
is the vectorised path for output grids.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError


@dataclass(frozen=True)
class PiecewisePolynomial:
    """``m`` functions of time, each a polynomial of ``t - breaks[i]`` on ``[breaks[i], breaks[i+1]]``.

    Parameters
    ----------
    breaks : ndarray, shape (n + 1,)
        Strictly increasing interval ends [s].
    coeffs : ndarray, shape (n, m, d + 1)
        Coefficients in ascending powers of ``t - breaks[i]`` (units of each function per s^k).

    Raises
    ------
    InputError
        Shapes that do not match, fewer than two breaks, breaks not strictly increasing, or
        non-finite numbers.

    Notes
    -----
    Times outside ``[breaks[0], breaks[-1]]`` are refused by :meth:`evaluate`; the scalar call
    extrapolates the end intervals by at most a relative 1e-9 of the span (integrators probe the
    end time with round-off) and refuses beyond.
    """

    breaks: np.ndarray
    coeffs: np.ndarray
    _rows: list = field(init=False, repr=False, compare=False)
    _b: list = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        b = np.asarray(self.breaks, dtype=float)
        c = np.asarray(self.coeffs, dtype=float)
        if b.ndim != 1 or b.size < 2:
            raise InputError(f"a piecewise polynomial needs at least two breaks, got shape {b.shape}")
        if c.ndim != 3 or c.shape[0] != b.size - 1 or c.shape[2] < 1:
            raise InputError(
                f"coefficients must have shape (n, m, d + 1) with n = {b.size - 1} intervals, got {c.shape}"
            )
        if not np.all(np.diff(b) > 0):
            i = int(np.argmin(np.diff(b)))
            raise InputError(f"breaks must increase strictly: breaks[{i}] = {b[i]:g}, breaks[{i + 1}] = {b[i + 1]:g}")
        if not (np.all(np.isfinite(b)) and np.all(np.isfinite(c))):
            raise InputError("a piecewise polynomial's breaks and coefficients must be finite")
        object.__setattr__(self, "breaks", b)
        object.__setattr__(self, "coeffs", c)
        # The scalar path's data: per interval, per function, the coefficients highest power first as
        # Python floats (a Horner sum on floats costs less than numpy calls on (m,) rows).
        object.__setattr__(self, "_rows", [[row.tolist() for row in c[i, :, ::-1]] for i in range(c.shape[0])])
        object.__setattr__(self, "_b", b.tolist())

    @property
    def n_functions(self) -> int:
        """Number ``m`` of functions."""
        return self.coeffs.shape[1]

    @property
    def degree(self) -> int:
        """Polynomial degree ``d``."""
        return self.coeffs.shape[2] - 1

    def _slack(self) -> float:
        return 1e-9 * max(1.0, self._b[-1] - self._b[0], abs(self._b[0]), abs(self._b[-1]))

    def __call__(self, t: float) -> np.ndarray:
        """Values of the ``m`` functions at one time.

        Parameters
        ----------
        t : float
            Time [s] in ``[breaks[0], breaks[-1]]``.

        Returns
        -------
        ndarray, shape (m,)

        Raises
        ------
        InputError
            A time outside the span.
        """
        b = self._b
        t = float(t)
        i = bisect.bisect_right(b, t) - 1
        if i < 0 or i >= len(b) - 1:
            if not b[0] - self._slack() <= t <= b[-1] + self._slack():
                raise InputError(f"time outside the span [{b[0]:g}, {b[-1]:g}] s: {t:g}")
            i = 0 if i < 0 else len(b) - 2
        s = t - b[i]
        out = []
        for row in self._rows[i]:
            coefficients = iter(row)
            acc = next(coefficients)
            for c in coefficients:
                acc = acc * s + c
            out.append(acc)
        return np.array(out)

    def evaluate(self, t, derivative: int = 0) -> np.ndarray:
        """Values (or a derivative) of the ``m`` functions at many times.

        Parameters
        ----------
        t : array_like, shape (N,)
            Times [s] in ``[breaks[0], breaks[-1]]``.
        derivative : int
            Order of the time derivative (0: the values).

        Returns
        -------
        ndarray, shape (m, N)
            In each function's unit per s^derivative.

        Raises
        ------
        InputError
            A time outside the span, or a negative derivative order.
        """
        if derivative < 0:
            raise InputError(f"derivative order must be >= 0, got {derivative}")
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        b = self.breaks
        sl = self._slack()
        if tt.size and (tt.min() < b[0] - sl or tt.max() > b[-1] + sl):
            raise InputError(f"time outside the span [{b[0]:g}, {b[-1]:g}] s: {tt.min():g} .. {tt.max():g}")
        i = np.clip(np.searchsorted(b, tt, side="right") - 1, 0, b.size - 2)
        s = tt - b[i]
        c = self.coeffs[i]  # (N, m, d + 1)
        d = c.shape[2] - 1
        if derivative > d:
            return np.zeros((self.n_functions, tt.size))
        k = np.arange(derivative, d + 1)
        fall = np.ones(k.size)
        for j in range(derivative):
            fall = fall * (k - j)
        c = c[:, :, derivative:] * fall
        out = c[:, :, -1]
        for p in range(c.shape[2] - 2, -1, -1):
            out = out * s[:, None] + c[:, :, p]
        return out.T.copy()
