"""``gflat paper [--out DIR] [--J N]``: the main job.

Plans the paper's three manoeuvres (single-engine Twin Otter, GTM forward slip,
GTM aileron roll in a zero-g parabola) by flatness and generalized flatness,
flies each plan open loop on the in-house model and on JSBSim from the same
initial state, and writes the plans, figures and difference tables.
"""

from __future__ import annotations

import time
from pathlib import Path

from planners.scenario import load_scenario

from ._args import nonnegative_int
from .compare import compare_scenario

PAPER_SCENARIOS = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")


def register(sub) -> None:
    p = sub.add_parser("paper", help="plan the paper's three manoeuvres and fly them on both engines",
                       description=__doc__.split("\n\n")[1])
    p.add_argument("--out", default="reports/out/paper", metavar="DIR", help="output folder")
    p.add_argument("--J", type=nonnegative_int, default=None, help="iterations (default: each scenario's)")
    p.set_defaults(func=run)


def run(args) -> int:
    from .plan import run as run_plan

    out = Path(args.out)
    rows, passed = [], []
    for name in PAPER_SCENARIOS:
        print(f"=== {name}")
        t0 = time.perf_counter()
        run_plan(type("Args", (), {"scenario": name, "J": args.J, "out": str(out / name / "plan")})())
        summary = compare_scenario(name, args.J, "inhouse,jsbsim", out / name / "compare", quiet=True)
        passed.append(summary["passed"])
        sc = load_scenario(name, J=args.J)
        first = summary["tables"]["jsbsim"]["first 10 s"]
        whole = summary["tables"]["jsbsim"]["whole span"]
        get = lambda tab, v: next(r["max_abs"] for r in tab if r["variable"] == v)  # noqa: E731
        ang = lambda tab: max(get(tab, v) for v in ("gamma", "chi", "alpha", "beta", "mu"))  # noqa: E731
        rows.append((name, sc.aircraft.id, summary["J"], get(first, "position"), ang(first), get(whole, "position"),
                     ang(whole), time.perf_counter() - t0))
        print(f"  in-house vs JSBSim (open loop, J = {summary['J']}): first 10 s {get(first, 'position'):.2e} m, "
              f"{ang(first):.2e} rad; whole span {get(whole, 'position'):.2e} m, {ang(whole):.2e} rad")
        print(f"  figures and tables: {out / name / 'compare'}/")
    failed = [r[0] for r, ok in zip(rows, passed) if not ok]
    print("\nsummary: in-house vs JSBSim, open loop with the generalized-flatness controls")
    print(f"  {'scenario':<26} {'aircraft':<10} {'J':>2} {'pos 10 s [m]':>12} {'ang 10 s [rad]':>14} "
          f"{'pos all [m]':>11} {'ang all [rad]':>13} {'time [s]':>8}")
    for r in rows:
        print(f"  {r[0]:<26} {r[1]:<10} {r[2]:>2} {r[3]:>12.2e} {r[4]:>14.2e} {r[5]:>11.2e} {r[6]:>13.2e} {r[7]:>8.1f}")
    if failed:
        print(f"gflat paper: engines disagree beyond the tolerances for {', '.join(failed)}: FAIL")
        return 1
    return 0
