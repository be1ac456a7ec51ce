"""JSBSim's inertial-position round-off along a steady climb: the law, and the engine's correction.

The Twin Otter trimmed at V climbing at w from h0 (constant density, so that the climb is steady) is flown
for T s on the in-house engine and on JSBSim with and without ``compensate_roundoff``; printed: the altitude
gained, JSBSim - in-house in z at T (uncorrected and corrected), the law's prediction
``-T (q round(w/q) - w)`` with ``q = ulp(R + h0) / dt`` (``harness.engines.jsbsim.roundoff``), and the
difference in x (the sphere's curvature, the same in both)::

    python research/jsbsim_climb_roundoff.py            # the table of docs/jsbsim.md, section 3
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's packages, not an installed copy

import numpy as np  # noqa: E402

from gna import units  # noqa: E402
from gna.aircraft import load_aircraft  # noqa: E402
from gna.atmosphere import Environment  # noqa: E402
from gna.trim import trim  # noqa: E402
from harness.engines import InHouseEngine, JSBSimEngine  # noqa: E402
from harness.engines.jsbsim.export import PLANET_RADIUS_FT  # noqa: E402

KT = 1852.0 / 3600.0
AIRCRAFT = load_aircraft("twin-otter")


def predicted(w: float, dt: float, T: float, h0: float, radius_ft: float = PLANET_RADIUS_FT) -> float:
    """JSBSim - exact in z [m] after ``T`` s of a steady climb at ``w`` [m/s] (its position increments rounded)."""
    d = w / units.FT * dt  # the vertical increment of one step [ft]
    u = math.ulp(radius_ft + h0 / units.FT)
    return -(T / dt) * (round(d / u) * u - d) * units.FT


def case(V=110 * KT, w=1.5, T=60.0, dt=1 / 480, h0=300.0):
    """``(climb [m], dz uncorrected, dz corrected, predicted, dx) [m]`` of one case."""
    env = Environment.constant(h0)
    tr = trim(AIRCRAFT, {"V": V, "gamma": math.asin(w / V), "beta": 0.0, "chi_dot": 0.0}, altitude=h0, env=env)
    x0, u0 = np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)
    ref = InHouseEngine().simulate(AIRCRAFT, u0, (0.0, T), x0, env=env, dt_out=T / 10).df
    out = []
    for on in (False, True):
        r = JSBSimEngine(dt=dt, compensate_roundoff=on).simulate(AIRCRAFT, u0, (0.0, T), x0, env=env, dt_out=T / 10)
        out.append(r)
    dz = [float(r.df["z"].iloc[-1] - ref["z"].iloc[-1]) for r in out]
    dx = float(out[1].df["x"].iloc[-1] - ref["x"].iloc[-1])
    climb = float(ref["z"].iloc[0] - ref["z"].iloc[-1])
    return climb, dz[0], dz[1], predicted(w, out[0].settings.dt, T, h0), dx


def main() -> None:
    """Print the table."""
    rows = [("w = 1.5 m/s, V = 110 kt, T = 60 s, dt = 1/480 s, h0 = 300 m", {})]
    rows += [(f"T = {T:g} s", {"T": T}) for T in (10.0, 30.0, 120.0)]
    rows += [(f"w = {w:g} m/s", {"w": w}) for w in (0.0, 1.4978, 1.4989, 1.5011, 3.0, -1.5)]
    rows += [(f"w = 1.4989 m/s, dt = 1/{hz}", {"w": 1.4989, "dt": 1 / hz}) for hz in (240, 960)]
    rows += [(f"V = {V:g} m/s", {"V": V}) for V in (45.0, 70.0, 90.0)]
    rows += [("h0 = 3000 m", {"h0": 3000.0})]
    print(f"{'case':<58} {'climb':>8} {'predicted':>10} {'uncorr.':>10} {'corrected':>10} {'dx':>9}   [m, z in mm]")
    for label, kw in rows:
        climb, raw, fixed, pred, dx = case(**kw)
        print(f"{label:<58} {climb:8.2f} {pred * 1e3:10.3f} {raw * 1e3:10.3f} {fixed * 1e3:10.4f} {dx * 1e3:9.4f}")


if __name__ == "__main__":
    main()
