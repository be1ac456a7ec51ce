"""Speed of the coupled JSBSim engine against bare ``fdm.run()``, and its accuracy (no assertions).

Speed (default).  The coupled run is :meth:`harness.engines.JSBSimEngine.simulate`: control
writes every step, divergence check, output reads, conversion to the 12
wind-frame states and the DataFrame.  The bare loop is ``fdm.run()`` alone on
the same aircraft file, settings and step.  Timings are medians of interleaved
repetitions (expect +-15 % scatter on a shared 2-core machine)::

    python benchmarks/bench_jsbsim.py [--aircraft f16c] [--seconds 20] [--repeats 5]

It ends with the closed-loop lines: real-time factors of the JSBSim engine open
loop and with a 1-state controller (PI altitude hold) sampled at every step and
at ``controller_dt = 1/60 s`` (medians), and of the in-house engine open and
closed loop; then the same for a paper scenario (``--scenario``) flown with the
tracking feedback of :mod:`planners.tracking`, against the plan flown open loop.

Accuracy (``--accuracy``): largest differences JSBSim - in-house (DOP853 at
1e-10) over 10 s of a smooth manoeuvre from trim (f16c, 150 m/s, 3000 m), for
four integrator sets and five steps (the convergence study of
``docs/jsbsim.md``), the same with the controls shifted by one step, then every
bundled aircraft (trim at 1.6 V_stall, 1000 m, 12 s manoeuvre; trimmed flight
10 s) and the cost of JSBSim's rotating WGS84 Earth::

    python benchmarks/bench_jsbsim.py --accuracy
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from gna.aircraft import list_aircraft, load_aircraft
from gna.atmosphere import ISA, Environment
from gna.trim import stall_speed, trim_level
from harness.engines import JSBSIM_DEFAULT_INTEGRATORS, InHouseEngine, Integrators, JSBSimEngine, fly, load_fdm
from harness.engines.jsbsim.fdm import prepare
from harness.metrics import difference_table
from harness.testing import smooth_inputs
from planners.generalized import plan_scenario
from planners.scenario import load_scenario
from planners.tracking import tracking_controller

ANGLES = ("gamma", "chi", "alpha", "beta", "mu")


def bare_steps_per_second(engine: JSBSimEngine, aircraft, env, x0, u0, steps: int) -> float:
    """``fdm.run()`` alone, same file, integrators, step and initial condition."""
    fdm, _, capture = load_fdm(engine.xml(aircraft, env, x0), aircraft.id)
    with capture:
        prepare(fdm, engine.integrators, engine.dt, env, x0, planet_radius_ft=engine.planet_radius_ft)
        fdm["external_reactions/engine1/magnitude"] = u0[0] / 2 / 4.4482216152605
        fdm["external_reactions/engine2/magnitude"] = u0[0] / 2 / 4.4482216152605
        fdm["ctrl/delta-m-rad"] = u0[3]
        fdm.run_ic()
        run = fdm.run
        t = time.perf_counter()
        for _ in range(steps):
            run()
        return steps / (time.perf_counter() - t)


class AltitudeHold:
    """A 1-state controller: PI altitude hold on the elevator with pitch damping, speed hold on thrust."""

    n_states = 1
    state_names = ("I_z",)

    def __init__(self, z_ref: float, V_ref: float):
        self.z_ref, self.V_ref = z_ref, V_ref

    def initial_state(self, t0, x0):
        return np.zeros(1)

    def derivative(self, t, x, xc):
        return np.array([x[2] - self.z_ref])

    def output(self, t, x, xc):
        dm = -2e-3 * (x[2] - self.z_ref) - 4e-4 * xc[0] + 0.5 * x[4] + 0.3 * x[10]
        return np.array([-2000.0 * (x[3] - self.V_ref), 0.0, 0.0, dm, 0.0])


def closed_loop(a, env, x0, u0, seconds: float, repeats: int, controller_dt: float = 1.0 / 60.0) -> None:
    """Real-time factors open loop and with a 1-state controller (medians of interleaved repetitions)."""
    c = AltitudeHold(float(x0[2]), float(x0[3]))
    x1 = x0.copy()
    x1[2] += 5.0
    runs = {
        "JSBSim open loop": (JSBSimEngine(), None),
        "JSBSim, 1-state controller every step": (JSBSimEngine(), c),
        f"JSBSim, 1-state controller, controller_dt = {controller_dt:.4g} s": (
            JSBSimEngine(controller_dt=controller_dt),
            c,
        ),
        "in-house open loop": (InHouseEngine(), None),
        "in-house, 1-state controller": (InHouseEngine(), c),
    }
    rtf = {k: [] for k in runs}
    for _ in range(repeats):
        for name, (eng, ctrl) in runs.items():
            t = time.perf_counter()
            res = eng.simulate(a, u0, (0.0, seconds), x1, env=env, controller=ctrl, dt_out=0.02)
            wall = time.perf_counter() - t
            assert res.status == "completed", res.message
            rtf[name].append(seconds / wall)
    base = {
        "JSBSim": statistics.median(rtf["JSBSim open loop"]),
        "in-house": statistics.median(rtf["in-house open loop"]),
    }
    print(f"Closed loop, {a.id}, {seconds:g} s simulated, end to end, median of {repeats}")
    print(f"  {'run':<56} {'x real time':>12} {'vs open loop':>13}")
    for name in runs:
        m = statistics.median(rtf[name])
        ref = base["JSBSim" if name.startswith("JSBSim") else "in-house"]
        print(f"  {name:<56} {m:12.1f} {100 * m / ref:12.0f}%")


def tracking(name: str, repeats: int, controller_dt: float = 1.0 / 60.0) -> None:
    """Real-time factors of a paper scenario flown with the tracking feedback (medians of interleaved repetitions).

    The peer of each closed-loop run is the same engine flying the plan's controls open loop in the same run.
    """
    sc = load_scenario(name)
    plan = plan_scenario(sc)
    c = tracking_controller(
        plan, sc.tracking.lambdas, feedforward_iterate=sc.tracking.feedforward_iterate, saturate=sc.tracking.saturate
    )
    span, x0 = (plan.t0, plan.t1), plan.initial_state()
    runs = {
        "JSBSim open loop (plan controls)": (JSBSimEngine(), None),
        "JSBSim, tracking feedback every step": (JSBSimEngine(), c),
        f"JSBSim, tracking feedback, controller_dt = {controller_dt:.4g} s": (
            JSBSimEngine(controller_dt=controller_dt),
            c,
        ),
        "in-house open loop (plan controls)": (InHouseEngine(), None),
        "in-house, tracking feedback": (InHouseEngine(), c),
    }
    rtf = {k: [] for k in runs}
    for _ in range(repeats):
        for label, (eng, ctrl) in runs.items():
            controls = plan if ctrl is None else ctrl.controls
            t = time.perf_counter()
            res = eng.simulate(plan.aircraft, controls, span, x0, env=plan.env, controller=ctrl, dt_out=0.05)
            wall = time.perf_counter() - t
            assert res.status == "completed", res.message
            rtf[label].append((span[1] - span[0]) / wall)
    base = {
        "JSBSim": statistics.median(rtf["JSBSim open loop (plan controls)"]),
        "in-house": statistics.median(rtf["in-house open loop (plan controls)"]),
    }
    print(f"Tracking feedback, {name}, {span[1] - span[0]:g} s, end to end, median of {repeats}")
    print(f"  {'run':<56} {'x real time':>12} {'vs open loop':>13}")
    for label in runs:
        m = statistics.median(rtf[label])
        ref = base["JSBSim" if label.startswith("JSBSim") else "in-house"]
        print(f"  {label:<56} {m:12.1f} {100 * m / ref:12.0f}%")


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


def main() -> None:
    """Run the benchmark and print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--aircraft", default="f16c")
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated time per run [s]")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--accuracy", action="store_true", help="print the accuracy study instead of the speed")
    parser.add_argument(
        "--scenario",
        default="twin-otter-single-engine",
        help="paper scenario flown with the tracking feedback in the last table",
    )
    args = parser.parse_args()
    if args.accuracy:
        accuracy()
        return

    a = load_aircraft(args.aircraft)
    env = Environment(ISA())
    tr = trim_level(a, 150.0, 3000.0, env=env)
    x0, u0 = np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)
    engine = JSBSimEngine()
    k = np.array([0.05 * u0[0], 0.0, 0.01, 0.01, 0.005])

    def smooth(t):  # vectorisable: evaluated once on the whole step grid
        s = np.sin(0.8 * np.asarray(t))
        return [u0[i] + k[i] * s for i in range(5)]

    def scalar(t):  # not vectorisable: called at every step
        s = np.sin(0.8 * float(t))
        return u0 + k * s

    gains = np.zeros((5, 12))
    gains[3, 10], gains[2, 9], gains[4, 11] = -0.3, 0.1, 0.2
    xref = x0.copy()

    def controller(t, x):
        e = x - xref
        e[:6] = 0.0
        return gains @ e

    cases = {
        "coupled, controls vectorised": dict(controls=smooth),
        "coupled, controls called each step": dict(controls=scalar),
        "coupled, with controller (2 evaluations/step)": dict(controls=smooth, controller=controller),
    }
    steps = int(round(args.seconds / engine.dt))
    bare, coupled, loop = [], {c: [] for c in cases}, {c: [] for c in cases}
    for _ in range(args.repeats):
        bare.append(bare_steps_per_second(engine, a, env, x0, u0, steps))
        for name, kw in cases.items():
            t = time.perf_counter()
            res = engine.simulate(
                a, kw["controls"], (0.0, args.seconds), x0, env=env, controller=kw.get("controller"), dt_out=0.02
            )
            wall = time.perf_counter() - t
            assert res.status == "completed", res.message
            coupled[name].append(res.settings["steps"] / wall)
            loop[name].append(res.settings["steps"] / res.settings["wall_time_s"]["stepping"])
    b = statistics.median(bare)
    print(
        f"JSBSim speed, {a.id}, {args.seconds:g} s simulated at dt = {engine.dt:.6g} s ({steps} steps), "
        f"integrators {engine.integrators.as_dict()}, median of {args.repeats}"
    )
    print(f"  {'run':<56} {'steps/s':>10} {'vs bare':>8} {'x real time':>12}")
    print(f"  {'bare fdm.run()':<56} {b:10.0f} {100.0:7.0f}% {b * engine.dt:12.0f}")
    for name in cases:
        c, lo = statistics.median(coupled[name]), statistics.median(loop[name])
        print(f"  {name + ', end to end':<56} {c:10.0f} {100 * c / b:7.0f}% {c * engine.dt:12.0f}")
        print(f"  {name + ', stepping loop':<56} {lo:10.0f} {100 * lo / b:7.0f}% {lo * engine.dt:12.0f}")
    closed_loop(a, env, x0, u0, args.seconds, args.repeats)
    tracking(args.scenario, args.repeats)


if __name__ == "__main__":
    main()
