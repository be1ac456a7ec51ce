"""Worst relative difference, per variable, between the wind-frame model and the body-axis 6-DoF
over the 24 random cases of ``tests/gna/test_eom.py`` (the test asserts <= 1e-7).

Usage: ``python research/eom_margin.py`` (from the repository root).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gna import body6dof  # noqa: E402
from gna.eom import STATE_NAMES, Controls, State, derivatives  # noqa: E402
from tests.gna.test_eom import CASES, _controls  # noqa: E402


def main() -> None:
    worst = dict.fromkeys(STATE_NAMES, 0.0)
    for craft, env, s0, u0, amp, w, ph in CASES:
        u = _controls(u0, amp, w, ph)
        tol = dict(rtol=1e-12, atol=1e-12, method="DOP853", t_eval=np.linspace(0, 10, 201))
        a = solve_ivp(
            lambda t, y: np.array(derivatives(craft, env, State(*y), Controls(*u(t))), dtype=float),  # noqa: B023
            (0, 10),
            s0,
            **tol,  # noqa: B023
        ).y
        b = body6dof.to_wind_state(
            solve_ivp(
                lambda t, y: body6dof.derivative(craft, env, y, u(t)),  # noqa: B023
                (0, 10),
                body6dof.from_wind_state(s0),
                **tol,  # noqa: B023
            ).y
        )
        for i, n in enumerate(STATE_NAMES):
            bb = a[i] + np.angle(np.exp(1j * (b[i] - a[i]))) if n in ("chi", "mu") else b[i]
            worst[n] = max(worst[n], float(np.max(np.abs(a[i] - bb)) / max(np.max(np.abs(a[i])), 1e-3)))
    print(f"{len(CASES)} cases, 10 s each; worst relative difference per variable:")
    print("  " + "  ".join(f"{k} {v:.1e}" for k, v in worst.items()))


if __name__ == "__main__":
    main()
