"""Test helpers for users' own tests (pytest or plain ``assert``).

>>> from harness.testing import assert_trajectories_close
>>> assert_trajectories_close(jsbsim_run, inhouse_run, tol={"position": 1e-2, "mu": 1e-4})  # doctest: +SKIP
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .metrics import difference_table


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
        return [u0[0] * (1 + 0.1 * np.sin(0.5 * t)), u0[1] + (0.3 * np.sin(0.7 * t) if twin else 0 * t),
                u0[2] + 0.02 * np.sin(1.3 * t) * (1 - np.cos(0.8 * t)),
                u0[3] + 0.02 * np.sin(0.9 * t) * (1 - np.cos(0.7 * t)),
                u0[4] + 0.01 * np.sin(1.1 * t) * (1 - np.cos(0.6 * t))]
    return u


def assert_trajectories_close(actual, expected, tol=None, *, variables: Sequence[str] | None = None,
                              window: tuple[float | None, float | None] | None = None,
                              labels: tuple[str, str] = ("expected", "actual"), interpolate: bool = False) -> None:
    """Assert that two trajectories agree within per-variable absolute tolerances.

    Parameters
    ----------
    actual, expected : DataFrame or SimulationResult
        Trajectories indexed by time ``t`` [s] (``expected`` is the reference).
    tol : None, float or mapping
        ``None``: :data:`harness.metrics.DEFAULT_TOLERANCES` (1e-2 m position,
        1e-4 rad angles, 1e-3 m/s, 1e-3 rad/s); a float for every compared
        variable; or a mapping variable -> tolerance (``"position"`` is the
        distance between the positions).
    variables, window, interpolate
        See :func:`harness.metrics.difference_table`.
    labels : (str, str)
        Names used in the message for ``expected`` and ``actual``.

    Raises
    ------
    AssertionError
        Naming each failing variable with its largest difference, the time it
        occurs and the tolerance, followed by the whole difference table.
    """
    table = difference_table(expected, actual, tol, variables=variables, window=window, labels=labels,
                             interpolate=interpolate)
    if table.passed:
        return
    lines = [f"trajectories differ ({labels[1]} vs {labels[0]}):"]
    for r in table.failures():
        lines.append(f"  {r.variable}: max |difference| {r.max_abs:.3e} {r.unit} at t = {r.t_max:.4g} s "
                     f"exceeds the tolerance {r.tolerance:.3e} {r.unit}")
    lines += [f"  {n}" for n in table.notes]
    lines.append(table.format())
    raise AssertionError("\n".join(lines))
