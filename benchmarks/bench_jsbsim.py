"""Speed of the coupled JSBSim engine against bare ``fdm.run()`` (no assertions).

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

The accuracy study (JSBSim against the in-house engine by integrator and step) is
``research/jsbsim_accuracy.py``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from gna.aircraft import load_aircraft
from gna.atmosphere import ISA, Environment
from gna.trim import trim_level
from harness.engines import InHouseEngine, JSBSimEngine, load_fdm
from harness.engines.jsbsim.fdm import prepare
from planners.generalized import plan_scenario
from planners.scenario import load_scenario
from planners.tracking import tracking_controller


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


def main() -> None:
    """Run the benchmark and print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--aircraft", default="f16c")
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated time per run [s]")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--scenario",
        default="twin-otter-single-engine",
        help="paper scenario flown with the tracking feedback in the last table",
    )
    args = parser.parse_args()
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
