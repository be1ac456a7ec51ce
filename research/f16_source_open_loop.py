"""The f16-s-turn plan flown open loop on inhouse, jsbsim and jsbsim-source; and a trim hold on jsbsim-source.

Run from the repository root: ``python research/f16_source_open_loop.py``.  Prints

* the plan's feasibility (Newton failures, bank, surfaces and thrust against the limits);
* per engine, the largest distance between the flown position and the planned flat outputs (x, y, z)
  over [0, T] for T = 5, 10, 30, 60 s;
* the fitted set's level trim at 195 m/s and 3000 m flown for 10 s on JSBSim's own f16: the drift that
  the fit's bias causes (what a tracking feedback has to absorb).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's packages, not an installed copy

import math
import time

import numpy as np

from gna.trim import trim_level
from harness.engines import fly
from harness.engines.jsbsim.source import JSBSimSourceEngine
from planners.generalized import plan_scenario
from planners.scenario import load_scenario

HORIZONS = (5.0, 10.0, 30.0, 60.0)


def position_error(df, xs, ys, zs) -> np.ndarray:
    t = df.index.to_numpy()
    return np.sqrt(
        (df["x"].to_numpy() - xs(t)) ** 2 + (df["y"].to_numpy() - ys(t)) ** 2 + (df["z"].to_numpy() - zs(t)) ** 2
    )


def main() -> None:
    sc = load_scenario("f16-s-turn")
    plan = plan_scenario(sc)
    t = np.arange(sc.t0, sc.t1 + 1e-9, 0.02)
    X, U = plan.state(t), plan.controls(t)
    lim = sc.aircraft.envelope.control_limits
    print(
        f"plan {sc.name}: feasible {plan.feasible}, Newton failures {len(plan.newton_failures)}, "
        f"warnings {len(plan.warnings)}"
    )
    print(
        f"  max |mu| {math.degrees(np.abs(X[8]).max()):.2f} deg, max |beta| {math.degrees(np.abs(X[7]).max()):.2g} deg, "
        f"alpha {math.degrees(X[6].min()):.2f}..{math.degrees(X[6].max()):.2f} deg, "
        f"V {X[3].min():.2f}..{X[3].max():.2f} m/s"
    )
    for i, name in ((2, "dl"), (3, "dm"), (4, "dn")):
        print(
            f"  {name}: {math.degrees(U[i].min()):+.3f}..{math.degrees(U[i].max()):+.3f} deg "
            f"(limit +-{math.degrees(lim.get(name, math.nan)):.2f} deg)"
        )
    print(f"  F: {U[0].min():.0f}..{U[0].max():.0f} N (max {sc.aircraft.propulsion.max_thrust:.0f} N)")

    runs = fly(("inhouse", "jsbsim", JSBSimSourceEngine()), sc.aircraft, None, plan, (sc.t0, sc.t1), env=sc.env)
    print("open loop, max position error vs the flat outputs over [0, T] [m]:")
    print("  engine          " + "".join(f"{f'T={h:g} s':>10}" for h in HORIZONS) + "   status")
    for label, res in runs.items():
        e = position_error(res.df, sc.x, sc.y, sc.z)
        tt = res.df.index.to_numpy()
        cells = "".join(f"{e[tt <= h + 1e-9].max():10.3g}" for h in HORIZONS)
        print(f"  {label:15s} {cells}   {res.status} {res.message}")
    src = runs["jsbsim-source"]
    print(f"  jsbsim-source thrust loop: {src.settings['thrust']['max_abs_error_N']:.3g} N max |F_cmd - thrust|")

    tr = trim_level(sc.aircraft, 195.0, 3000.0, env=sc.env)
    v = tr.values
    print(
        f"trim hold: fitted set's level trim at 195 m/s, 3000 m: alpha {math.degrees(v['alpha']):.3f} deg, "
        f"dm {math.degrees(v['dm']):.3f} deg, F {v['F']:.0f} N; flown 10 s with constant controls"
    )
    x0 = np.asarray(tr.state, dtype=float)
    u0 = np.asarray(tr.controls, dtype=float)
    t_wall = time.perf_counter()
    hold = fly(("inhouse", JSBSimSourceEngine()), sc.aircraft, x0, u0, (0.0, 10.0), env=sc.env)
    for label, res in hold.items():
        d, s = res.df, res.df.iloc[-1]
        x_ref = x0[0] + x0[3] * d.index.to_numpy()
        e = np.sqrt((d["x"] - x_ref) ** 2 + (d["y"] - x0[1]) ** 2 + (d["z"] - x0[2]) ** 2).to_numpy()
        print(
            f"  {label:15s} after 10 s: position {e[-1]:.3g} m (z {s['z'] - x0[2]:+.3g} m), V {s['V'] - x0[3]:+.3g} m/s, "
            f"gamma {math.degrees(s['gamma']):+.3g} deg, alpha {math.degrees(s['alpha'] - x0[6]):+.3g} deg, "
            f"mu {math.degrees(s['mu']):+.3g} deg, chi {math.degrees(s['chi']):+.3g} deg; "
            f"error at 5 s {e[np.searchsorted(d.index.to_numpy(), 5.0)]:.3g} m"
        )
    print(f"  ({time.perf_counter() - t_wall:.2f} s wall)")


if __name__ == "__main__":
    main()
