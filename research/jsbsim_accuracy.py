"""Accuracy of the JSBSim engine against the in-house engine: the convergence study of ``docs/jsbsim.md``.

Largest differences JSBSim - in-house (DOP853 at 1e-10) over 10 s of a smooth manoeuvre from trim
(f16c, 150 m/s, 3000 m), for four integrator sets and five steps, the same with the controls shifted
by one step, then every bundled aircraft (trim at 1.6 V_stall, 1000 m, 12 s manoeuvre; trimmed flight
10 s), a 120 s span, and the cost of JSBSim's rotating WGS84 Earth::

    python research/jsbsim_accuracy.py
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's packages, not an installed copy

import numpy as np

from gna.aircraft import list_aircraft, load_aircraft
from gna.trim import stall_speed, trim_level
from harness.engines import JSBSIM_DEFAULT_INTEGRATORS, InHouseEngine, Integrators, JSBSimEngine, fly
from harness.metrics import difference_table
from harness.testing import smooth_inputs

ANGLES = ("gamma", "chi", "alpha", "beta", "mu")


def _summary(table) -> str:
    ang = max(table.row(v).max_abs for v in ANGLES)
    rates = max(table.row(v).max_abs for v in ("p", "q", "r"))
    return f"{table.row('position').max_abs:9.1e} {table.row('V').max_abs:9.1e} {ang:9.1e} {rates:9.1e}"


def accuracy() -> None:
    """Print the convergence study and the per-aircraft cross-engine differences."""
    a = load_aircraft("f16c")
    tr = trim_level(a, 150.0, 3000.0)
    x0, u0 = np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)
    u = smooth_inputs(u0, False)
    ref = InHouseEngine().simulate(a, u, (0.0, 10.0), x0)
    head = f"{'pos [m]':>9} {'V [m/s]':>9} {'ang [rad]':>9} {'pqr[r/s]':>9}"
    print("Convergence: f16c, smooth manoeuvre from trim (150 m/s, 3000 m), 10 s; max |JSBSim - in-house|")
    sets = {
        "JSBSim default (Euler, AB2, Euler, AB3)": JSBSIM_DEFAULT_INTEGRATORS,
        "AB2 everywhere": Integrators("AB2", "AB2", "AB2", "AB2"),
        "AB4 + Buss1 quaternion": Integrators("AB4", "AB4", "Buss1", "AB4"),
        "AB4 + Buss2 quaternion (gflat default)": Integrators(),
    }
    for name, ig in sets.items():
        print(f"  {name}")
        print(f"    {'dt [s]':<8} {head}")
        for hz in (60, 120, 240, 480, 960):
            r = JSBSimEngine(dt=1.0 / hz, integrators=ig).simulate(a, u, (0.0, 10.0), x0)
            print(f"    1/{hz:<6} {_summary(difference_table(ref, r))}")
    print("  AB4 + Buss2 with the controls shifted by one step (wrong timing)")
    for hz in (120, 480):
        r = JSBSimEngine(dt=1.0 / hz).simulate(a, lambda t, h=hz: u(np.asarray(t) - 1.0 / h), (0.0, 10.0), x0)
        print(f"    1/{hz:<6} {_summary(difference_table(ref, r))}")

    print("Every aircraft, gflat default (AB4 + Buss2, dt = 1/480 s): max |JSBSim - in-house|")
    print(f"  {'aircraft':<11} {'case':<24} {head}")
    for name in list_aircraft():
        craft = load_aircraft(name)
        V = 1.6 * stall_speed(craft, 1000.0).V_stall
        t = trim_level(craft, V, 1000.0)
        x, uu = np.array(t.state, dtype=float), np.array(t.controls, dtype=float)
        r = fly(["inhouse", "jsbsim"], craft, x, uu, (0.0, 10.0))
        print(f"  {name:<11} {'trim 10 s':<24} {_summary(difference_table(r['inhouse'], r['jsbsim']))}")
        r = fly(["inhouse", "jsbsim"], craft, x, smooth_inputs(uu, craft.propulsion.count == 2), (0.0, 12.0))
        tab = difference_table(r["inhouse"], r["jsbsim"])
        print(f"  {'':<11} {'manoeuvre 12 s':<24} {_summary(tab)}")
    print("Long span: f16c, 120 s, max |JSBSim - in-house| (flat-earth sphere curvature and ECEF round-off)")
    print(f"  {'case':<36} {head}")
    for name, src in (("trim", u0), ("manoeuvre", u)):
        r = fly(["inhouse", "jsbsim"], a, x0, src, (0.0, 120.0))
        print(f"  {name + ' 120 s':<36} {_summary(difference_table(r['inhouse'], r['jsbsim']))}")
    print("Cost of the flat earth: f16c trim, 10 s, |JSBSim rotating WGS84 Earth - JSBSim flat|")
    print(f"  {'initial latitude':<36} {head}")
    for lat in (0.0, 45.0):
        r = fly(
            {"flat": JSBSimEngine(), "wgs84": JSBSimEngine(earth="wgs84", latitude=np.radians(lat))},
            a,
            x0,
            u0,
            (0.0, 10.0),
        )
        print(f"  {lat:<36.0f} {_summary(difference_table(r['flat'], r['wgs84']))}")


if __name__ == "__main__":
    accuracy()
