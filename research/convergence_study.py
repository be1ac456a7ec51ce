"""Convergence of generalized flatness: the paper's fixed-point iteration against Newton's method.

For each paper scenario and harder variants of the aileron roll (faster roll, surfaces whose force
contributions are larger, lower speed), writes ``docs/generalized.md``:

* the fixed-point iteration (``method="fixed-point"``): the full-model equation residual at the
  nodes for every iterate j, the digits gained per iteration, the measured contraction factor
  (geometric mean of the residual ratios while they decrease) and the iterate after which the
  residual stops decreasing;
* Newton's method on the fixed point (``method="newton"``) at depth 0 and at the fixed point's
  best depth: the same residual per Newton step, the digits gained per step, ``max |H - G(H)|``;
* model evaluations (counted calls of the aerodynamic model) and wall time (median of
  ``--repeat`` runs) of the fixed point to its best iterate and of Newton to a node residual of
  1e-10;
* the residual of the assembled plan *between* the nodes (midpoints, two-sided formula with its
  exact derivatives), which the node residual does not see;
* the controls at the report time per iterate for both methods (the paper's aileron-roll table).

Usage: ``python research/convergence_study.py [--jmax 10] [--repeat 3] [--out docs/generalized.md]``
(about 5 minutes on one core; ``--quick`` runs the three paper scenarios only, with jmax 8).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's packages, not an installed copy

import argparse
import copy
import time
from dataclasses import replace

import numpy as np

from gna.eom import CONTROL_NAMES, STATE_NAMES, Controls, State, derivatives
from planners.generalized import plan_motion
from planners.generalized_newton import counted
from planners.scenario import load_scenario, scenario_from_dict

PAPER = ("twin-otter-single-engine", "gtm-forward-slip", "gtm-aileron-roll")
TARGET = 1e-10
SURFACES = ("dl", "dm", "dn")


def scaled_surface_forces(aircraft, factor: float):
    """The aircraft with its surface terms in the force coefficients CD, CY, CL multiplied by ``factor``.

    These terms are the part of the neglected terms H carried by the surfaces; scaling them scales the
    coupling the generalized iteration must resolve (the moment terms, which fix the deflections, are
    left alone).
    """
    from gna.aero import AERO_VARIABLES

    idx = [AERO_VARIABLES.index(s) for s in SURFACES]
    values = {
        t.index: t.value * factor
        for t in aircraft.aero.terms
        if t.coefficient in ("CD", "CY", "CL") and any(t.exponents[i] for i in idx)
    }
    return replace(aircraft, aero=aircraft.aero.with_values(values, source=f"surface force terms x{factor:g}"))


def variants(quick: bool):
    """(label, description, scenario) for the study."""
    out = [(name, "paper scenario", load_scenario(name)) for name in PAPER]
    if quick:
        return out
    roll = load_scenario("gtm-aileron-roll")
    for rate, label in (("pi*t", "2x"), ("2*pi*t", "4x")):
        raw = copy.deepcopy(roll.raw)
        raw["flat_outputs"]["zeta_value"] = rate
        raw["name"] = f"roll {label} faster"
        out.append((raw["name"], f"roll rate {label} the paper's (mu = {rate})", scenario_from_dict(raw)))
    for factor in (4.0, 16.0):
        sc = replace(roll, aircraft=scaled_surface_forces(roll.aircraft, factor), name=f"roll surfaces x{factor:g}")
        out.append((sc.name, f"surface terms of CD, CY, CL x{factor:g}", sc))
    for speed in (80, 65):
        raw = copy.deepcopy(roll.raw)
        raw["flat_outputs"]["x"] = f"{speed}*kmh*t"
        raw["name"] = f"roll at {speed} km/h"
        out.append((raw["name"], f"horizontal speed {speed} km/h (paper: 100)", scenario_from_dict(raw)))
    return out


def node_residuals(plan) -> list[float]:
    """Max full-model equation residual at the nodes, per iterate."""
    out = []
    for j in range(plan.J + 1):
        v = float(plan.equation_residuals("full", j).abs().max().max())
        out.append(v if np.isfinite(v) else float("inf"))
    return out


def midpoint_residual(plan, j: int) -> float:
    """Max full-model equation residual of the assembled plan at the midpoints between nodes."""
    t = 0.5 * (plan.t_nodes[1:] + plan.t_nodes[:-1])
    vals = {n: plan.evaluate(n, t, j) for n in STATE_NAMES + CONTROL_NAMES}
    d = State(*(plan.evaluate(n, t, j, derivative=1) for n in STATE_NAMES))
    f = derivatives(
        plan.aircraft,
        plan.env,
        State(*(vals[n] for n in STATE_NAMES)),
        Controls(*(vals[n] for n in CONTROL_NAMES)),
        "full",
    )
    return float(max(np.max(np.abs(np.asarray(a) - np.asarray(b))) for a, b in zip(d, f)))


def timed(fun, repeat: int):
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fun()
        times.append(time.perf_counter() - t)
    return out, float(np.median(times))


def digits(res: list[float]) -> list[float]:
    return [
        float(np.log10(a / b)) if a > 0 and b > 0 and np.isfinite(a / b) else float("nan") for a, b in zip(res, res[1:])
    ]


def study(label, sc, jmax: int, repeat: int) -> dict:
    pb, tn = sc.problem(), sc.t_nodes
    fp = plan_motion(pb, tn, jmax, name=label)
    r_fp = node_residuals(fp)
    best = int(np.nanargmin(r_fp))
    dec = [b / a for a, b in zip(r_fp[:best], r_fp[1 : best + 1])]
    contraction = float(np.exp(np.mean(np.log(dec)))) if dec else float("nan")
    grows = best < jmax
    # cost of the fixed point to its best iterate: plan_motion with J = best
    cpb, ctr = counted(pb)
    fp_best = plan_motion(cpb, tn, best)
    fp_evals = ctr.calls
    _, fp_time = timed(lambda: plan_motion(pb, tn, best), repeat)
    out = {
        "label": label,
        "nodes": len(tn),
        "fp_res": r_fp,
        "best": best,
        "contraction": contraction,
        "grows": grows,
        "fp_evals": fp_evals,
        "fp_time": fp_time,
        "fp_mid": midpoint_residual(fp_best, -1),
        "fp": fp,
        "newton": {},
    }
    for depth in sorted({0, best}):
        cpb, ctr = counted(pb)
        nplan = plan_motion(cpb, tn, depth, method="newton", name=label)
        evals = ctr.calls
        _, n_time = timed(lambda: plan_motion(pb, tn, depth, method="newton"), repeat)  # noqa: B023
        r_n = node_residuals(nplan)
        out["newton"][depth] = {
            "res": r_n,
            "h_res": nplan.generalized["residual"],
            "evals": evals,
            "time": n_time,
            "mid": midpoint_residual(nplan, -1),
            "plan": nplan,
            "reached": bool(r_n[-1] <= TARGET),
            "failures": len(nplan.newton_failure_records),
            "status": nplan.generalized["status"],
            "damping": nplan.generalized["damping"],
        }
    return out


def fmt(x: float, spec: str = ".1e") -> str:
    return "—" if not np.isfinite(x) else format(x, spec)


def report(results: list[dict], descriptions: dict, jmax: int, repeat: int, roll_times) -> str:
    L = []
    L.append("# Generalized flatness: the fixed point and Newton's method\n")
    L.append(
        "Written by `python research/convergence_study.py` "
        f"(jmax = {jmax}, medians of {repeat} runs); do not edit by hand.\n"
    )
    L.append(INTRO)
    L.append("## Summary\n")
    L.append(
        "| scenario | variant | nodes | fixed point: contraction / iteration | best iterate | best node residual "
        "| after it | Newton (depth 0): status, steps to 1e-10 | final node residual | evals FP→best / Newton | "
        "time FP→best / Newton [s] |"
    )
    L.append("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        n0 = r["newton"][0]
        steps = next((i for i, v in enumerate(n0["res"]) if v <= TARGET), None)
        L.append(
            f"| {r['label']} | {descriptions[r['label']]} | {r['nodes']} | {fmt(r['contraction'], '.3f')} "
            f"| j = {r['best']} | {fmt(r['fp_res'][r['best']])} | "
            f"{'grows' if r['grows'] else 'still decreasing at jmax'} | "
            f"{n0['status']}, {steps if steps is not None else 'not reached'} | {fmt(n0['res'][-1])} | "
            f"{r['fp_evals']} / {n0['evals']} | {r['fp_time']:.2f} / {n0['time']:.2f} |"
        )
    L.append("")
    L.append("## Full-model node residual per iterate and digits gained\n")
    L.append(
        "Max over nodes and the 12 equations of `d/dt state - f(state, controls)` (SI units per "
        'second), `plan.equation_residuals("full", j)`.  *digits* = `log10(r_j / r_(j+1))`.\n'
    )
    for r in results:
        L.append(f"### {r['label']}\n")
        hdr = "| method | " + " | ".join(f"j={j}" for j in range(jmax + 1)) + " |"
        L.append(hdr)
        L.append("|---" * (jmax + 2) + "|")
        L.append("| fixed point: residual | " + " | ".join(fmt(v) for v in r["fp_res"]) + " |")
        L.append("| fixed point: digits | — | " + " | ".join(fmt(v, ".2f") for v in digits(r["fp_res"])) + " |")
        for depth, n in r["newton"].items():
            pad = [""] * (jmax + 1 - len(n["res"]))
            L.append(f"| Newton depth {depth}: residual | " + " | ".join([fmt(v) for v in n["res"]] + pad) + " |")
            L.append(
                f"| Newton depth {depth}: digits | — | "
                + " | ".join([fmt(v, ".2f") for v in digits(n["res"])] + pad)
                + " |"
            )
            L.append(
                f"| Newton depth {depth}: max \\|H − G(H)\\| | " + " | ".join([fmt(v) for v in n["h_res"]] + pad) + " |"
            )
        L.append("")
        for depth, n in r["newton"].items():
            damped = [f"{d:g}" for d in n["damping"] if d < 1]
            L.append(
                f"Newton depth {depth}: {n['status']}, {n['evals']} model evaluations, {n['time']:.2f} s, "
                f"residual between nodes {fmt(n['mid'])}"
                + (f", damped steps (factor {', '.join(damped)})" if damped else "")
                + (f", {n['failures']} stage-Newton failure record(s)" if n["failures"] else "")
                + ".  "
            )
        L.append(
            f"Fixed point with J = {r['best']} (its best iterate; same output orders as Newton): "
            f"{r['fp_evals']} model evaluations, {r['fp_time']:.2f} s, residual between nodes "
            f"{fmt(r['fp_mid'])}.\n"
        )
    if roll_times is not None:
        L.append("## The paper's aileron-roll table, both methods\n")
        L.append(roll_times)
    L.append(NOTES)
    return "\n".join(L) + "\n"


def open_loop_section(sc, best: int) -> str:
    """Open-loop flight of the full model with each plan's controls (the test of docs/planning.md)."""
    from gna.simulate import simulate

    L = [
        "Open loop: the full model flown from the plan's initial state with its controls (`gna.simulate`), "
        "maximum deviation from the plan over the manoeuvre (the quantity of test 8(c), docs/planning.md):\n",
        "| method | J or depth | node residual | between nodes | position [m] | angles [rad] |",
        "|---|---|---|---|---|---|",
    ]
    for method, J in sorted(
        {
            ("fixed-point", 4),
            ("fixed-point", sc.J),
            ("fixed-point", best),
            ("newton", 0),
            ("newton", 2),
            ("newton", 4),
            ("newton", best),
        }
    ):
        plan = plan_motion(sc.problem(), sc.t_nodes, J, method=method)
        r = simulate(
            sc.aircraft, plan.control_function(-1), (plan.t0, plan.t1), plan.initial_state(-1), env=sc.env, dt_out=0.1
        )
        ref = plan.to_dataframe(r.df.index.values, j=-1)
        pos = float(
            np.sqrt((r.df["x"] - ref["x"]) ** 2 + (r.df["y"] - ref["y"]) ** 2 + (r.df["z"] - ref["z"]) ** 2).max()
        )
        ang = max(float((r.df[k] - ref[k]).abs().max()) for k in ("alpha", "beta", "mu", "gamma", "chi"))
        L.append(
            f"| {method} | {J} | {node_residuals(plan)[-1]:.1e} | {midpoint_residual(plan, -1):.1e} | "
            f"{pos:.3g} | {ang:.3g} |"
        )
    return "\n".join(L) + "\n"


def roll_table(res: dict, t: float = -1.9) -> str:
    fp = res["fp"]
    tab = fp.convergence_table(("F", "dl", "dm", "dn"), [t])
    cols = list(tab.columns)
    L = [
        f"Controls at t = {t} s (F [N], surfaces [rad]); fixed point iterates J = 0..{fp.J}, then the last "
        "Newton iterate at each depth.\n",
        "| variable | " + " | ".join(cols) + " | " + " | ".join(f"Newton depth {d}" for d in res["newton"]) + " |",
        "|---" * (len(cols) + len(res["newton"]) + 1) + "|",
    ]
    for v in ("F", "dl", "dm", "dn"):
        row = [f"{x:.6g}" for x in tab.loc[(t, v)].to_numpy()]
        row += [f"{float(n['plan'].evaluate(v, t)):.6g}" for n in res["newton"].values()]
        L.append(f"| {v} | " + " | ".join(row) + " |")
    return "\n".join(L) + "\n"


INTRO = """\
The paper's `GeneralizedFlatParametrization` (section "From calibration to time varying controls")
re-runs the flat parametrization J times, each time with the neglected terms H = (p, q, r, dl, dm, dn)
of the force coefficients taken from the previous iterate: a fixed-point iteration H := G(H) that
loses two series orders per step.  `planners.generalized_newton` solves the same fixed point by
Newton's method (`plan_scenario(sc, method="newton")` or `[generalized] method = "newton"`): at the
starting order kappa = e + 4 + 2J of the fixed point with J iterations (*depth* J), `G` is padded with
zero coefficients to keep its order, and `F(H) = H - G(H)` is solved node by node on the 6 (kappa - 1)
Taylor coefficients with the exact series Jacobian (a second-order linear differential operator with
series coefficients, composed from the complex-step partials of stages 2, 3 and 4).  The paper's
iterate j equals the j-th iterate of the padded iteration on every coefficient it keeps, so the Newton
solution at depth J is the limit of the paper's iteration started at that order.
"""

NOTES = """\
## Reading the tables

* **Node residual.** Iterate j of the fixed point leaves at the nodes the mismatch between the H it
  used (iterate j - 1) and the rates and surfaces it produced; its decrease per iteration is the
  contraction factor: 0.08 per iteration (1.1 digits) for the Twin Otter, 0.15 for the forward slip,
  0.28 for the roll (0.55 digits, falling to 0.4 after j = 3).  The two slow manoeuvres keep
  converging to j = 10 (5.8e-14 and 3.8e-10).  The roll and all its variants *stop*: iterate j uses
  Taylor coefficients of order up to 2j of the previous iterates, the coefficients grow with the
  order (a fast manoeuvre has a small radius of convergence), and the iteration behaves like the
  partial sums of an asymptotic series (the paper's `x' = y + eps y'` example:
  `y = sum (-eps d/dt)^i x'`), best truncated near the smallest term -- the paper's own remark about
  smallest-term truncation (Ramis).  On the roll the residual bottoms out at 1.9e-6 (j = 8) and
  grows after: the fixed point cannot reach 1e-10 there, whatever J; the faster, slower or
  stronger-surface rolls stop earlier (j = 1-4) and diverge.
* **Newton** converges quadratically (about 3, then 5-7 digits per step, until rounding) to the
  exact fixed point of the truncated iteration: 2-4 steps to 1e-10 and below where the fixed point
  stalls or diverges (faster roll, lower speed, surfaces x4 at depth 0).  Its node residual is then
  zero to rounding *by construction* (at a fixed point, H at the nodes is the plan's own rates and
  surfaces), whatever the depth.  Where no fixed point is near (surfaces x16; x4 at depth 1) Newton
  stagnates even with its per-node step halving, and says so (`plan.generalized["status"]`, a plan
  warning).
* **Between the nodes** (midpoints; the plan assembled by the two-sided formula, its derivative exact)
  the residual is not the node residual: the controls are order-1 series and neighbouring nodes'
  series must agree.  On the slow paper scenarios (Twin Otter, forward slip) Newton at the fixed
  point's depth and the fixed point give the same value.  On the roll and its variants the fixed
  point stopped at its best iterate is 5-60 times better there than Newton at that depth: Newton
  solves the truncated fixed-point equations exactly, which sums the growing tail of the asymptotic
  series together with its useful terms -- the node residual vanishes but the series of
  neighbouring nodes agree less.  For a divergent asymptotic expansion the best approximation is the
  one stopped near its smallest term, which is what the fixed point does at its best J; Newton at
  depth 0 (no tail at all, but no correction of the higher coefficients either) is worse still.
* **Open loop** (the roll table below) is what matters for flying the plan: Newton at depth >= 2-4
  flies as close to its plan as the fixed point at J = 7-8 (the paper's J), Newton at depth 0 ten
  times worse.  The deviation is dominated by the order-1 control series blended between nodes.
* **So**: Newton answers the paper's question (the fixed point is reached in 2-4 steps, to rounding,
  where the iteration stalls or diverges, and tells when there is none), and it is the cheaper way
  to a given *node* residual; as a way to a better *trajectory* it needs a depth of a few iterations,
  and on fast manoeuvres the paper's iteration stopped at its best J is as good or better.
* **Cost.** One Newton step costs one flat parametrization plus one linearization (three batched
  complex-step evaluations: 4 + 6, 3 + 3 and 13 directions) and a dense solve of size 6 (kappa - 1)
  per node; a fixed-point iteration costs one flat parametrization at a decreasing order.  Model
  evaluations are counted calls of the aerodynamic model (`planners.generalized_newton.counted`),
  each one batched over all nodes (and complex-step directions).
"""


def chained_section() -> str:
    """The generic almost chained system API on the paper's x' = y + eps y' (planners.chained)."""
    from planners.chained import ChainedSystem, Stage, generalized_parametrization
    from planners.generalized_newton import newton_parametrization
    from planners.systems import first_order_lag, lag_reference

    eps, w = 0.1, 1.0
    tn = np.linspace(0.0, 3.0, 13)
    ref = lag_reference((w, 0.0), eps, w)
    zeta = {"x": lambda t: np.sin(w * t)}
    L = [
        "## The generic almost chained system: `first-order-lag`\n",
        "`planners.chained` runs the paper's algorithm on any system of the form eq. chained-sys "
        "(`ChainedSystem` of `Stage`s, each a residual written once for series); "
        "`planners.systems.first_order_lag(eps)` is the paper's `x' = y + eps y'` with x as generalized "
        f"flat output (eps = {eps:g} s, x = sin(t), 13 nodes on [0, 3] s).  Error of y at the nodes against "
        "the exact `y = (1 + eps d/dt)^-1 x' = (x' - eps x'')/(1 + eps^2 w^2)`:\n",
        "| J (depth) | fixed point, iterate J | Newton at depth J | Newton steps | max \\|X^ − G(X^)\\| |",
        "|---|---|---|---|---|",
    ]
    for J in (0, 2, 4, 8, 12):
        fp = generalized_parametrization(first_order_lag(eps), tn, zeta, J=J)
        nw = newton_parametrization(first_order_lag(eps), tn, zeta, J=J)
        ef = float(np.max(np.abs(np.real(fp.iterates[-1]["y"].constant_term) - ref(tn))))
        en = float(np.max(np.abs(np.real(nw.iterates[-1]["y"].constant_term) - ref(tn))))
        L.append(f"| {J} | {ef:.1e} | {en:.1e} | {len(nw.residuals) - 1} | {nw.residuals[-1]:.1e} |")
    nl = ChainedSystem(
        "nonlinear-lag",
        {"x": 1},
        (
            Stage(("y",), lambda v: [v["x'"] - v["y"] - 0.1 * np.sin(v["y1"])], ("y1",), 2),
            Stage(("y1",), lambda v: [v["y'"] - v["y1"]]),
        ),
    )
    nw = newton_parametrization(nl, tn, {"x": np.sin}, J=4)
    L.append("")
    L.append(
        "The fixed point gains one digit per iteration (eps w = 0.1: the paper's geometric series); Newton "
        "solves the linear fixed point in one step, and at depth J it equals the fixed point's limit at that "
        "starting order.  On the nonlinear `x' = y + 0.1 sin(y')` Newton converges quadratically: "
        "max |X^ − G(X^)| = " + ", ".join(f"{r:.1e}" for r in nw.residuals) + ".\n"
    )
    L.append(car_section())
    return "\n".join(L) + "\n"


def car_section() -> str:
    """The car with two off-axle trailers: open-loop error of the exact model per iterate."""
    from planners.chained import generalized_parametrization
    from planners.generalized_newton import newton_parametrization
    from planners.systems import CarTrailers, car_two_trailers, simulate_car_two_trailers

    g = CarTrailers()
    V, A, w = 5.0, 2.0, 0.5
    zeta = {"x2": lambda t: V * t, "y2": lambda t: A * np.sin(w * t)}
    tn, te = np.linspace(0.0, 12.0, 49), np.linspace(0.0, 12.0, 241)

    def err(plan):
        x0 = [plan.evaluate(n, 0.0) for n in ("x2", "y2", "theta2", "theta1", "theta0")]
        X = simulate_car_two_trailers(g, lambda t: plan.evaluate("v0", t), lambda t: plan.evaluate("phi", t), x0, te)
        return float(np.max(np.hypot(X[:, 0] - zeta["x2"](te), X[:, 1] - zeta["y2"](te))))

    L = [
        "### `car-two-trailers`\n",
        f"`planners.systems.car_two_trailers`: car (wheelbase {g.l0:g} m) towing two trailers hitched off-axle "
        f"(d1 = {g.d1:g} m, L1 = {g.L1:g} m, d2 = {g.d2:g} m, L2 = {g.L2:g} m; not flat, Rouchon et al. 1993), "
        "planned by generalized flatness from the on-axle (flat) approximation with the last trailer's axle as "
        f"flat output x2 = {V:g} t, y2 = {A:g} sin({w:g} t) (a weave at {V:g} m/s), 49 nodes on [0, 12] s, "
        "order-3 controls.  The exact model flown open loop with the planned speed and steering (RK45, "
        "rtol 1e-10): max distance of the last trailer from the plan:\n",
        "| plan | open-loop error [m] |",
        "|---|---|",
    ]
    for J in (0, 1, 2, 4, 6):
        plan = generalized_parametrization(car_two_trailers(g, V), tn, zeta, J=J, e=3)
        L.append(f"| fixed point J = {J}{' (on-axle approximation)' if J == 0 else ''} | {err(plan):.2e} |")
    plan = newton_parametrization(car_two_trailers(g, V), tn, zeta, J=4, e=3)
    L.append(
        f"| Newton depth 4 ({len(plan.residuals) - 1} steps, max \\|X^ − G(X^)\\| = "
        f"{plan.residuals[-1]:.1e}) | {err(plan):.2e} |"
    )
    L.append("")
    L.append(
        "`gflat plan first-order-lag`, `gflat plan car-two-trailers [--J N]` and `gflat plan my-system.toml` "
        "run the chained-system scenario files (`planners/systems/scenarios/*.toml`, read by "
        "`planners.systems.scenario`: `system`, `[parameters]`, `[constants]`, `[time]`, `[flat_outputs]`, "
        "`[generalized]` J, e, method; `planners.systems.demos`: the plan, its check against the exact "
        "reference, `plan.csv` and `summary.json`).  Python API: "
        "`planners.chained.generalized_parametrization` / `planners.generalized_newton.newton_parametrization` "
        "with `planners.systems.SYSTEMS`.  The aircraft is the instance `planners.flat.aircraft_system(problem)` "
        "(r = 4, Z_1 = {x, y, z}, Z_3 = {zeta}, H = H_2(p, q, r, dl, dm, dn)): `planners.generalized.plan_motion` "
        "is the generic planner run on it; the tracking feedback (`planners.tracking.tracking_controller`) runs "
        "on a chained system's explicit model as on the aircraft's (docs/tracking.md).\n"
    )
    return "\n".join(L) + "\n"


def theorem1_section() -> str:
    """Measured ranks and relative singular values of the Theorem 1 test (planners.flatness_test)."""
    from gna.aircraft import load_aircraft
    from gna.atmosphere import Environment
    from gna.trim import trim
    from planners.flatness_test import RANK_TOL, flatness_test, lift_maximum, stall_line
    from planners.generalized import plan_scenario

    alt = 1000.0
    ac = load_aircraft("gtm")
    env = Environment.constant(alt)
    rho = float(env.density(-alt))
    a_cl = lift_maximum(ac)
    a_st, V_st = stall_line(ac, alt, env=env)

    def line(alpha, density):
        e = env if density == "constant" else None
        V = trim(
            ac, {"alpha": alpha, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0}, altitude=alt, env=e, check_envelope=False
        ).values["V"]
        data = {
            "name": "line",
            "aircraft": "gtm",
            "time": {"t0": 0.0, "t1": 2.0, "step": 1.0},
            "constants": {"V0": V},
            "environment": {"density": "constant", "rho": rho} if density == "constant" else {"density": "isa"},
            "flat_outputs": {"x": "V0*t", "y": "0", "z": f"-{alt}", "zeta": "beta", "zeta_value": "0"},
            "calibration": {"alpha": alpha, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0, "altitude": alt},
            "generalized": {"J": 0},
        }
        return V, plan_scenario(scenario_from_dict(data), method="newton")

    L = [
        "## Theorem 1 along a plan\n",
        "`planners.flatness_test.flatness_test(plan, j, model=...)`: rank of the Silverman--Meadows matrix "
        "`[M_0 .. M_11]`, `M_0 = B`, `M_(k+1) = A M_k - M_k'`, at every node, from the series of "
        "`planners.tracking.linearize`; relative singular-value tolerance "
        f"{RANK_TOL:g}.  Level straight lines of the GTM at {alt:g} m, planned from scenario dicts "
        "(calibrated at their alpha, Newton method):\n",
        f"The GNA `C_L` polynomial peaks at alpha = {a_cl:.4f} rad; the trimmed lift maximum (minimum of the "
        f"level-flight speed, elevator lift and thrust included) is at alpha = {a_st:.6f} rad, V = {V_st:.4f} m/s "
        "(`planners.flatness_test.stall_line`).\n",
        "| line | alpha [rad] | V [m/s] | density | model | rank | smallest relative singular value | condition |",
        "|---|---|---|---|---|---|---|---|",
    ]
    cases = [
        ("cruise", 0.1, "constant"),
        ("C_L polynomial maximum", a_cl, "constant"),
        ("stall - 1e-4 rad", a_st - 1e-4, "constant"),
        ("stall", a_st, "constant"),
        ("stall + 1e-4 rad", a_st + 1e-4, "constant"),
        ("stall", a_st, "isa"),
    ]
    for label, alpha, dens in cases:
        V, plan = line(alpha, dens)
        for model in ("full", "design"):
            ft = flatness_test(plan, model=model)
            L.append(
                f"| {label} | {alpha:.6f} | {V:.4f} | {dens} | {model} | {int(ft.rank.min())} | "
                f"{float(ft.sigma_min.min()):.2e} | {'holds' if ft.passed else 'fails'} |"
            )
    L.append("")
    L.append("Along the paper's manoeuvres (iterate 0 of J = 5 plans, series of order 11, all blocks exact):\n")
    L.append("| scenario | nodes | rank | smallest relative singular value |")
    L.append("|---|---|---|---|")
    for name in PAPER:
        sc = load_scenario(name)
        plan = plan_motion(sc.problem(), sc.t_nodes, 5)
        ctr = ("F", "dl", "dm", "dn") if sc.eta is not None else ("F", "eta", "dl", "dm")
        ft = flatness_test(plan, 0, controls=ctr)
        L.append(f"| {name} | {len(plan.t_nodes)} | {int(ft.rank.min())} | {float(ft.sigma_min.min()):.2e} |")
    L.append(THEOREM1_NOTES)
    return "\n".join(L) + "\n"


THEOREM1_NOTES = """
* **Where it fails.** At the stall (the fold of the family of level flights, dV/dalpha = 0) the
  Jacobian of the steady-flight equations in everything but the position is singular: a row vector
  w with w [A B] = 0 on those columns exists.  With a constant density the position columns of A
  are zero, so w is a left null vector of the whole [A B]: an uncontrollable mode at lambda = 0, rank
  11 at every node -- the paper's statement, for the full model.  One tenth of a milliradian away the
  rank is 12 again (a V-shaped minimum of the singular value, about 0.5 per rad).
* **ISA.** With the density falling with altitude, the altitude column of A is not zero and keeps
  rank 12, by a relative singular value of ~2e-5 (a climb into thinner air changes the lift): not
  flat in the paper's idealisation, weakly so in the standard atmosphere.
* **The design model** (force coefficients with the rates and surfaces frozen at the plan's values,
  the model the flat parametrization solves) is not singular at the full model's stall: freezing the
  elevator moves its fold; the condition is a property of the model linearized, not of the flat
  outputs.  The singularity of the flat output {x, y, z, beta} (docs: singularity monitor) is a
  different, weaker statement: a chart failing, not the linearized module failing to be free.
* The stall line must start at the stall alpha (the calibration): the flat parametrization's stage 2
  has a double root there and its Newton iteration gives alpha to ~3e-5 only, enough to restore the
  rank (singular value 1.7e-5) -- another face of the same singularity.
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jmax", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "generalized.md"))
    args = ap.parse_args()
    jmax = 8 if args.quick and args.jmax == 10 else args.jmax
    results, descriptions, roll = [], {}, None
    for label, desc, sc in variants(args.quick):
        t = time.perf_counter()
        with np.errstate(all="ignore"):
            r = study(label, sc, jmax, args.repeat)
        descriptions[label] = desc
        results.append(r)
        if label == "gtm-aileron-roll":
            roll = roll_table(r) + "\n" + open_loop_section(sc, r["best"])
        print(
            f"{label}: contraction {r['contraction']:.3f}, best j = {r['best']} ({r['fp_res'][r['best']]:.1e}), "
            f"Newton depth 0 {r['newton'][0]['res'][-1]:.1e} in {len(r['newton'][0]['res']) - 1} steps "
            f"({time.perf_counter() - t:.0f} s)",
            flush=True,
        )
    text = report(results, descriptions, jmax, args.repeat, roll)
    with np.errstate(all="ignore"):
        text += "\n" + theorem1_section() + "\n" + chained_section()
    Path(args.out).write_text(text)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
