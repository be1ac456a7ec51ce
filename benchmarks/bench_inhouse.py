"""Speed of the in-house engine on the paper's scenarios, against JSBSim in the same run (no assertions).

Each scenario is planned once (not timed); its controls are flown open loop from the plan's own
initial state, for the whole span, by three runs interleaved ``--repeats`` times (medians):

* ``in-house``: :func:`gna.simulate.simulate` as shipped (DOP853, rtol = atol = 1e-10), whose
  right-hand side is the traced float program of :mod:`gna.tape`;
* ``in-house generic``: the same run with the right-hand side evaluating the generic definition
  :func:`gna.eom.derivatives` on numpy floats (what the engine did before the fast path);
* ``JSBSim``: :func:`harness.engines.fly` with ``"jsbsim"`` (export, load and the run, as a user
  flies it), on the same controls, initial state and output grid.

The controls are the plan's :meth:`planners.plan.Plan.control_function` when it is a
:class:`gna.piecewise.PiecewisePolynomial` (cheap to call), otherwise a cubic Hermite
``PiecewisePolynomial`` of the planned controls and their derivatives at the nodes, so the
figures measure the engine rather than the evaluation of the plan's series.

Printed per scenario: simulated span, wall and CPU medians [s], real-time factor (span / wall),
right-hand-side calls and the wall per call [us]; the ratio in-house / JSBSim of the real-time factors; the cost of
one derivative evaluation alone (generic and traced); the trajectory difference fast - generic;
and the forward slip flown closed loop with the paper's tracking feedback::

    python benchmarks/bench_inhouse.py [--repeats 5] [--scenarios gtm-forward-slip ...] [--no-jsbsim]
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import sys
import time
import timeit
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # measure the checkout this script is in

from gna.eom import CONTROL_NAMES, Controls, State, derivatives
from gna.piecewise import PiecewisePolynomial
from gna.tape import CompiledDerivatives, compile_derivatives
from harness.engines import InHouseEngine, fly
from planners.generalized import plan_scenario
from planners.scenario import load_scenario
from planners.tracking import tracking_controller

#: The paper's three manoeuvres.
SCENARIOS = ("gtm-forward-slip", "gtm-aileron-roll", "twin-otter-single-engine")

_simulate_module = importlib.import_module("gna.simulate")


class _Counted(PiecewisePolynomial):
    """A piecewise polynomial counting its scalar calls (the engine calls it once per right-hand side)."""

    def __call__(self, t):
        self.calls[0] += 1
        return PiecewisePolynomial.__call__(self, t)


def plan_controls(plan) -> tuple[PiecewisePolynomial, str]:
    """The plan's controls as a piecewise polynomial of time, and how it was obtained."""
    f = plan.control_function()
    if isinstance(f, PiecewisePolynomial):
        return f, "plan.control_function()"
    tn = plan.t_nodes
    v = np.array([plan.evaluate(n, tn) for n in CONTROL_NAMES])
    d = np.array([plan.evaluate(n, tn, derivative=1) for n in CONTROL_NAMES])
    h = np.diff(tn)
    y0, y1, d0, d1 = v[:, :-1], v[:, 1:], d[:, :-1], d[:, 1:]
    c2 = (3.0 * (y1 - y0) / h - 2.0 * d0 - d1) / h
    c3 = (2.0 * (y0 - y1) / h + d0 + d1) / h**2
    return (
        PiecewisePolynomial(tn, np.stack([y0, d0, c2, c3], axis=-1).transpose(1, 0, 2)),
        "cubic Hermite of the planned controls at the nodes",
    )


def _generic_only(aircraft, env, model="full", h=None, x0=None, u0=None):
    f = CompiledDerivatives(aircraft, env, model, h)
    f.reason = "generic evaluation requested by the benchmark"
    return f


def run_inhouse(plan, controls, generic: bool, controller=None):
    """One in-house run; with ``generic`` the right-hand side is the generic definition."""
    if generic:
        _simulate_module.compile_derivatives = _generic_only
    try:
        return InHouseEngine().simulate(
            plan.aircraft, controls, (plan.t0, plan.t1), plan.initial_state(), env=plan.env, controller=controller
        )
    finally:
        _simulate_module.compile_derivatives = compile_derivatives


def run_jsbsim(plan, controls, controller=None):
    """One JSBSim run through :func:`harness.engines.fly`."""
    return fly(
        ["jsbsim"],
        plan.aircraft,
        plan.initial_state(),
        controls,
        (plan.t0, plan.t1),
        env=plan.env,
        controller=controller,
    )["jsbsim"]


def rhs_calls(plan, controls) -> int:
    """Right-hand-side evaluations of one in-house run (scalar control calls, minus the start-up checks)."""
    counted = _Counted(controls.breaks, controls.coeffs)
    object.__setattr__(counted, "calls", [0])
    run_inhouse(plan, counted, generic=False)
    return counted.calls[0] - 1  # the check of the controls at t0


def per_call_us(plan, controls, number: int = 2000) -> tuple[float, float]:
    """One derivative evaluation at the initial state: generic definition and traced program [us]."""
    x0 = plan.initial_state()
    u0 = controls(plan.t0)
    s, u = State(*x0), Controls(*u0)
    fast = compile_derivatives(plan.aircraft, plan.env, x0=x0, u0=u0)
    sl, ul = x0.tolist(), u0.tolist()
    generic = min(timeit.repeat(lambda: derivatives(plan.aircraft, plan.env, s, u), number=number // 4, repeat=3)) / (
        number // 4
    )
    traced = min(timeit.repeat(lambda: fast.values(sl, ul), number=number, repeat=3)) / number
    return 1e6 * generic, 1e6 * traced


def max_relative_difference(a, b) -> float:
    """Largest |a - b| over the 12 states, each relative to its peak magnitude in ``b``."""
    cols = ["x", "y", "z", "V", "gamma", "chi", "alpha", "beta", "mu", "p", "q", "r"]
    A, B = a.df[cols].to_numpy(), b.df[cols].to_numpy()
    return float(np.max(np.max(np.abs(A - B), axis=0) / np.maximum(np.max(np.abs(B), axis=0), 1e-300)))


def bench_scenario(name: str, repeats: int, jsbsim: bool) -> dict:
    """Interleaved repetitions of the three runs on one scenario; prints its lines."""
    plan = plan_scenario(load_scenario(name))
    controls, how = plan_controls(plan)
    span = plan.t1 - plan.t0
    runs = {
        "in-house": lambda: run_inhouse(plan, controls, generic=False),
        "in-house generic": lambda: run_inhouse(plan, controls, generic=True),
    }
    if jsbsim:
        runs["JSBSim"] = lambda: run_jsbsim(plan, controls)
    walls: dict[str, list[float]] = {k: [] for k in runs}
    cpus: dict[str, list[float]] = {k: [] for k in runs}
    last = {}
    for _ in range(repeats):
        for label, run in runs.items():
            t, c = time.perf_counter(), time.process_time()
            res = run()
            walls[label].append(time.perf_counter() - t)
            cpus[label].append(time.process_time() - c)
            assert res.status == "completed", f"{name} {label}: {res.message}"
            last[label] = res
    n = rhs_calls(plan, controls)
    generic_us, traced_us = per_call_us(plan, controls)
    print(f"{name}: {span:g} s flown open loop, controls: {how}; medians of {repeats}")
    print(f"  {'engine':<18} {'wall [s]':>9} {'CPU [s]':>8} {'x real time':>12} {'rhs calls':>10} {'us/call':>8}")
    med = {k: statistics.median(v) for k, v in walls.items()}
    for label, w in med.items():
        calls = f"{n:10d} {1e6 * w / n:8.1f}" if label.startswith("in-house") else f"{'':10} {'':8}"
        print(f"  {label:<18} {w:9.3f} {statistics.median(cpus[label]):8.3f} {span / w:12.1f} {calls}")
    if jsbsim:
        print(
            f"  in-house / JSBSim real-time factor: {med['JSBSim'] / med['in-house']:.2f} "
            f"(generic evaluation: {med['JSBSim'] / med['in-house generic']:.2f})"
        )
    print(f"  speed-up of the traced right-hand side on the whole run: {med['in-house generic'] / med['in-house']:.2f}")
    print(
        f"  one derivative evaluation: generic {generic_us:.1f} us, traced {traced_us:.1f} us "
        f"({generic_us / traced_us:.0f}x)"
    )
    print(
        f"  max |traced - generic| over the run, relative to each state's peak: "
        f"{max_relative_difference(last['in-house'], last['in-house generic']):.1e}"
    )
    return med


def bench_closed_loop(repeats: int, jsbsim: bool, name: str = "gtm-forward-slip") -> None:
    """The scenario flown with the paper's tracking feedback (controller states integrated with the aircraft)."""
    sc = load_scenario(name)
    plan = plan_scenario(sc)
    c = tracking_controller(
        plan, sc.tracking.lambdas, feedforward_iterate=sc.tracking.feedforward_iterate, saturate=sc.tracking.saturate
    )
    span = plan.t1 - plan.t0
    runs = {
        "in-house": lambda: run_inhouse(plan, c.controls, False, c),
        "in-house generic": lambda: run_inhouse(plan, c.controls, True, c),
    }
    if jsbsim:
        runs["JSBSim"] = lambda: run_jsbsim(plan, c.controls, c)
    walls: dict[str, list[float]] = {k: [] for k in runs}
    for _ in range(repeats):
        for label, run in runs.items():
            t = time.perf_counter()
            res = run()
            walls[label].append(time.perf_counter() - t)
            assert res.status == "completed", f"{name} closed loop {label}: {res.message}"
    print(f"{name} closed loop (tracking feedback, {c.n_states} controller states), medians of {repeats}")
    print(f"  {'engine':<18} {'wall [s]':>9} {'x real time':>12}")
    for label, w in walls.items():
        m = statistics.median(w)
        print(f"  {label:<18} {m:9.3f} {span / m:12.1f}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS))
    ap.add_argument("--no-jsbsim", action="store_true", help="skip the JSBSim runs")
    ap.add_argument("--no-closed-loop", action="store_true", help="skip the closed-loop forward slip")
    args = ap.parse_args(argv)
    for name in args.scenarios:
        bench_scenario(name, args.repeats, not args.no_jsbsim)
    if not args.no_closed_loop:
        bench_closed_loop(max(1, args.repeats // 2), not args.no_jsbsim)


if __name__ == "__main__":
    main()
