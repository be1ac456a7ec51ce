"""The collocation benchmark's NLP: the full model's equations hold at the Radau points, the flat
outputs and prescribed inputs are met, the controls fly."""

from __future__ import annotations

import numpy as np
import pytest

from .conftest import benchmark_module

ca = pytest.importorskip("casadi")

from gna import eom  # noqa: E402
from gna.atmosphere import ISA  # noqa: E402
from planners.scenario import load_scenario  # noqa: E402


@pytest.fixture(scope="module")
def bc():
    with benchmark_module("bench_collocation", "bench_collocation") as mod:
        yield mod


def test_symbolic_isa_matches_isa(bc):
    h = ca.SX.sym("h")
    f = ca.Function("rho", [h], [bc.SymbolicISA().density(h)])
    for alt in (-500.0, 0.0, 1000.0, 10999.0, 11001.0, 15000.0):
        assert float(f(alt)) == pytest.approx(float(ISA().density(alt)), rel=1e-14)
    assert float(bc.SymbolicISA().density(500.0)) == float(ISA().density(500.0))


def test_radau_matrices_differentiate_cubics(bc):
    tau, D = bc.radau_matrices(3)
    assert tau[0] == 0.0 and tau[-1] == pytest.approx(1.0)
    p = np.poly1d([0.3, -1.2, 0.7, 2.0])
    assert np.allclose(p(tau) @ D, p.deriv()(tau), atol=1e-12)
    w = bc.radau_weights(tau[1:])
    q = np.poly1d([1.0, -2.0, 0.5, 3.0, 1.0])  # degree 4: exact
    assert w @ q(tau[1:]) == pytest.approx(q.integ()(1.0) - q.integ()(0.0), rel=1e-13)


# 10 intervals each (0.8 s on the 8 s roll, 12 s on the 120 s forward slip).
@pytest.mark.parametrize("name, factor", [("gtm-aileron-roll", 1.6), ("gtm-forward-slip", 2.0)])
def test_collocation_meets_equations_and_flat_outputs(bc, name, factor):
    sc = load_scenario(name)
    pb = sc.problem()
    prob = bc.CollocationProblem(sc, factor, bc.planner_guess(sc))
    sol = prob.solve()
    assert sol.success, sol.status
    t, X, U = sol.t, sol.states, sol.controls
    # Flat outputs, fourth flat output and prescribed inputs at every point.
    for i, f in enumerate((pb.x, pb.y, pb.z)):
        assert np.allclose(X[i], f(t), rtol=0, atol=1e-9)
    zeta = np.broadcast_to(pb.zeta.value(t), t.shape)
    if pb.zeta.kind in ("beta", "mu"):
        assert np.allclose(X[eom.STATE_NAMES.index(pb.zeta.kind)], zeta, atol=1e-12)
    elif pb.zeta.kind == "F":
        assert np.allclose(U[0], zeta, atol=1e-12)
    assert np.allclose(U[1], pb.eta(t), atol=1e-12)
    # Dynamics defect at the Radau points, recomputed on floats with gna.eom (not through CasADi).
    tau, D = bc.radau_matrices(3)
    n, d = prob.n_intervals, 3
    defect = 0.0
    for k in range(n):
        idx = k * d + np.arange(d + 1)
        h = prob.breaks[k + 1] - prob.breaks[k]
        rates = X[:, idx] @ D[:, 1:] / h
        f = np.stack(eom.derivatives(pb.aircraft, pb.env, eom.State(*X[:, idx[1:]]), eom.Controls(*U[:, idx[1:]])))
        scale = np.maximum(1.0, np.abs(f))
        defect = max(defect, float(np.max(np.abs(rates - f) / scale)))
    assert defect < 1e-7
    # The controls between the points are the piecewise cubics through them.
    assert np.allclose(sol.control_function.evaluate(t), U, atol=1e-9)
    assert np.allclose(sol.control_function(t[5]), U[:, 5], atol=1e-9)


def test_roll_open_loop_accuracy(bc):
    sc = load_scenario("gtm-aileron-roll")
    prob = bc.CollocationProblem(sc, 1.6, bc.planner_guess(sc))
    assert prob.n_intervals == 10
    sol = prob.solve()
    err = bc.open_loop_error_of(sc, sol.control_function, sol.initial_state)
    # 10 intervals of 0.8 s on the 8 s roll: about 1.4 cm (0.34 mm on 20 intervals).
    assert 1e-4 < err < 0.05


def test_mixed_fourth_output(bc):
    from tests.planners.conftest import make_scenario

    sc = make_scenario(
        flat_outputs={"zeta": "mix", "zeta_value": "0.01", "f1": "1", "f2": "0.5 + 0.1*sin(t/7)"}, generalized={"J": 1}
    )
    pb = sc.problem()
    prob = bc.CollocationProblem(sc, 4.0, bc.planner_guess(sc))
    sol = prob.solve()
    assert sol.success, sol.status
    t, X = sol.t, sol.states
    beta, mu = X[eom.STATE_NAMES.index("beta")], X[eom.STATE_NAMES.index("mu")]
    assert np.allclose(pb.zeta.f1(t) * beta + pb.zeta.f2(t) * mu, 0.01, atol=1e-9)
    assert sol.constraint_violation < 1e-8


def test_trim_guess_kinematics_and_trim(bc):
    sc = load_scenario("gtm-forward-slip")
    guess = bc.trim_guess(sc)
    t = np.linspace(sc.t0, sc.t1, 7)
    X, U = guess(t)
    pb = sc.problem()
    for i, f in enumerate((pb.x, pb.y, pb.z)):
        assert np.allclose(X[i], f(t), atol=1e-9)
    # V, gamma, chi: the velocity (x', y', z') of the flat outputs, here by central differences.
    e = 1e-5
    vel = np.stack([(f(t + e) - f(t - e)) / (2 * e) for f in (pb.x, pb.y, pb.z)])
    V, gam, chi = X[3], X[4], X[5]
    assert np.allclose(
        vel, V * np.stack([np.cos(gam) * np.cos(chi), np.cos(gam) * np.sin(chi), -np.sin(gam)]), atol=1e-6
    )
    # The rest held at one trim: steady straight flight along the initial velocity, no sideslip.
    tr = guess.trim
    assert tr.fixed == pytest.approx({"V": V[0], "gamma": gam[0], "chi_dot": 0.0, "beta": 0.0})
    assert np.allclose(X[6:], np.array([tr.values[k] for k in ("alpha", "beta", "mu", "p", "q", "r")])[:, None])
    assert np.allclose(U[[0, 2, 3, 4]], np.array([tr.values[k] for k in ("F", "dl", "dm", "dn")])[:, None])


def test_trim_guess_smoke(bc):
    """The trim guess on one small grid, through the benchmark's own loop (one repetition, one graph)."""
    res = bc.bench_scenario(
        "twin-otter-single-engine", factors=(8.0,), repeat=1, finer=(), graphs=("SX",), log=lambda *a: None
    )
    assert set(res["guesses"]) == {"plan-j0", "trim"}
    for gname, gres in res["guesses"].items():
        (g,) = gres["grids"]
        assert g["success"], (gname, g["status"])
        assert g["domain"] is None and 0 < g["iterations"] < 20
        # constr_viol_tol: the equations met to round-off, not to IPOPT's default 1e-4 (2e-8 from the trim).
        assert g["constraint_violation"] < 1e-10
        assert 1e-3 < g["accuracy_m"] < 0.1  # 4 intervals of 16 s: about 3 cm
        assert g["accuracy_one_piece_m"] == pytest.approx(g["accuracy_m"], rel=1e-3)  # 3 kinks only
        tt = g["times"]["SX"]
        # The guess is counted: re-solved = guess + solve, built from scratch >= guess + build + solve.
        assert tt["resolve_wall_s"] >= tt["guess_wall_s"] > 0
        assert gres["counted_in_times"] and gres["matched"] is None
        # No grid reaches the planner: the most accurate one is reported with its cost over the planner's.
        best = gres["most_accurate"]
        assert best["factor"] == 8.0 and best["accuracy_m"] == g["accuracy_m"]
        assert best["resolve_over_planner_wall"] == pytest.approx(tt["resolve_wall_s"] / res["planner"]["time_wall_s"])
    # The planner's controls fly to the same figure in one piece (planners.verify) and by pieces.
    assert res["planner"]["accuracy_one_piece_m"] == pytest.approx(res["planner"]["accuracy_m"], rel=1e-2)
    both = res["guesses"]
    assert both["plan-j0"]["grids"][0]["accuracy_m"] == pytest.approx(both["trim"]["grids"][0]["accuracy_m"], rel=1e-3)
    text = bc.markdown_table([res])
    assert "guess trim" in text and "guess plan-j0" in text and "trim (" in text
    assert "none; most accurate: 8x" in text


def test_set_guess_resolves_to_the_same_solution(bc):
    sc = load_scenario("twin-otter-single-engine")
    prob = bc.CollocationProblem(sc, 8.0, bc.planner_guess(sc), graph="SX")
    first = prob.solve()
    prob.set_guess(bc.trim_guess(sc))
    again = prob.solve()
    assert again.success and np.allclose(again.controls, first.controls, atol=1e-6)


def test_planner_settings_change_the_compared_problem(bc):
    """--step and --e plan with other settings, and the grids' intervals follow the planner's step."""
    res = bc.bench_scenario(
        "twin-otter-single-engine",
        factors=(8.0,),
        repeat=1,
        finer=(),
        graphs=("SX",),
        guesses=("plan-j0",),
        log=lambda *a: None,
        step=4.0,
        e=2,
    )
    assert res["step_s"] == 4.0 and res["planner"]["settings"] == {"e": 2}
    assert res["planner"]["nodes"] == 16  # 60 s in 4 s steps
    assert res["scenario"] == "twin-otter-single-engine (step 4, e 2)"
    (g,) = res["guesses"]["plan-j0"]["grids"]
    assert g["factor"] == 8.0 and g["intervals"] == 2  # 60 s in intervals of 32 s


def test_planner_settings_are_checked(bc):
    with pytest.raises(SystemExit):
        bc.main(["--step", "0", "--quick"])
    with pytest.raises(SystemExit):
        bc.main(["--e", "-1", "--quick"])


def test_open_loop_flight_restarts_at_every_break(bc, monkeypatch):
    """The collocation controls are flown piece by piece (one integration per interval), to the same
    states as one flight in one piece at a much tighter tolerance."""
    from gna.simulate import simulate

    sc = load_scenario("gtm-aileron-roll")
    prob = bc.CollocationProblem(sc, 1.6, bc.planner_guess(sc), graph="SX")
    sol = prob.solve()
    spans = []

    def recording(*args, **kwargs):
        spans.append(args[2])
        return simulate(*args, **kwargs)

    monkeypatch.setattr(bc, "simulate", recording)
    grid = bc.verification_grid(sc)
    states = bc.fly_by_pieces(sc.problem(), sol.control_function, sol.initial_state, grid)
    assert [s[0] for s in spans] == pytest.approx(prob.breaks[:-1]) and spans[-1][1] == pytest.approx(sc.t1)
    tight = simulate(
        sc.problem().aircraft,
        sol.control_function,
        (grid[0], grid[-1]),
        sol.initial_state,
        env=sc.problem().env,
        t_eval=grid,
        rtol=1e-13,
        atol=1e-13,
    )
    one = tight.df[list(eom.STATE_NAMES)].to_numpy().T
    assert np.max(np.abs(states[:3] - one[:3])) < 1e-7
    err = bc.open_loop_error_of(sc, sol.control_function, sol.initial_state)
    pb = sc.problem()
    flat = np.stack([np.broadcast_to(f(grid), grid.shape) for f in (pb.x, pb.y, pb.z)])
    assert err == pytest.approx(float(np.max(np.linalg.norm(one[:3] - flat, axis=0))), rel=1e-4)
