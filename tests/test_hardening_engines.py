"""Hardening of the model, the engines and the planners against bad input and runs that leave the domain.

Each test names its kind (``test_k<kind>_...``): 6 altitude and absurd plans, 7 Python API arguments,
8 divergence alike on both engines, 9 continuous angles on JSBSim, 10 planning cost, 11 controls and
trim parameters, 12 the JSBSim fitting source.
"""

from __future__ import annotations

import logging
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gna.aircraft import load_aircraft
from gna.atmosphere import Environment
from gna.errors import DomainError, InputError
from gna.simulate import envelope_warnings, simulate
from gna.trajectory import DOMAIN, domain_violation, output_grid
from gna.trim import trim, trim_level
from gna.units import FT, HP, KT
from harness.cli import main
from harness.engines import InHouseEngine, JSBSimEngine
from planners.scenario import load_scenario

ROLL = Path(__file__).resolve().parents[1] / "planners" / "scenarios" / "gtm-aileron-roll.toml"


@pytest.fixture(scope="module")
def f16():
    a = load_aircraft("f16c")
    tr = trim_level(a, 150.0, 3000.0)
    return a, np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)


def _scenario_file(tmp_path, *replacements) -> Path:
    text = ROLL.read_text()
    for old, new in replacements:
        assert old in text
        text = text.replace(old, new)
    p = tmp_path / "roll.toml"
    p.write_text(text)
    return p


# --------------------------------------------------------------------------- 6: altitude and absurd plans


@pytest.mark.parametrize("altitude", [25000.0, 1e7, -5000.0])
def test_k6_trim_refuses_altitudes_outside_the_isa(altitude):
    with pytest.raises(DomainError, match=r"altitude .* outside the ISA model.*-2000 to 20000 m") as exc:
        trim_level(load_aircraft("f16c"), 150.0, altitude)
    assert exc.value.variable == "altitude" and exc.value.value == altitude


def test_k6_constant_environment_from_an_isa_altitude_is_range_checked():
    assert Environment.constant(3000.0).density(0.0) == pytest.approx(0.909, rel=1e-3)
    with pytest.raises(DomainError, match="altitude 25000 m"):
        Environment.constant(25000.0)


def test_k6_cli_trim_at_1e7_m_is_one_clear_line(capsys):
    assert main(["trim", "f16c", "--speed", "150", "--altitude", "1e7"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "altitude 1e+07 m" in err[0] and "density" not in err[0]


def test_k6_plan_at_100_km_is_refused_naming_the_altitude(tmp_path):
    sc = load_scenario(_scenario_file(tmp_path, ("h_apex = 1000.0", "h_apex = 100000.0")))
    from planners.generalized import plan_scenario

    with pytest.raises(DomainError, match=r"altitude 99969.4 m at t = -2.5 s .* outside the ISA model"):
        plan_scenario(sc)


def test_k6_plan_leaving_the_domain_by_orders_of_magnitude_is_infeasible(tmp_path, capsys):
    # At 100 km in constant density (ISA 100 km: 5.6e-7 kg/m^3) the plan needs absurd angles: the cause is
    # named first (the stage-2 determinant is 1e-12 of ordinary flight's: the forces barely depend on the
    # angles), the departure from the domain it leads to is in the warnings.
    p = _scenario_file(
        tmp_path, ("h_apex = 1000.0", "h_apex = 100000.0"), ('density = "isa"', 'density = "constant"\nrho = 5.6e-7')
    )
    assert main(["plan", str(p), "--J", "1", "--out", str(tmp_path / "out")]) == 1
    cap = capsys.readouterr()
    last = cap.err.strip().splitlines()[-1]
    assert last.startswith("gflat plan: the plan is not feasible: stage 2 of the flat parametrization is singular")
    assert "stalling_cond" in last and "too little aerodynamic force" in last
    assert "iterate j = 1: left the physical domain at t = " in cap.out


# --------------------------------------------------------------------------- 7: Python API arguments


@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(dt_out=0.0), "dt_out must be a positive"),
        (dict(dt_out=-1.0), "dt_out must be a positive"),
        (dict(dt_out=float("nan")), "dt_out must be a positive"),
        (dict(dt_out=0.3), r"dt_out = 0.3 s does not divide the span \[0, 1\] s"),
        (dict(t_eval=[0.0, 0.5, 2.0]), r"t_eval must lie in t_span \[0, 1\] s"),
        (dict(t_eval=[0.5, 0.2]), "increasing"),
        (dict(model="weird"), "model must be 'full' or 'simple'"),
    ],
)
def test_k7_simulate_refuses_bad_arguments(f16, kw, message):
    a, x0, u0 = f16
    with pytest.raises(InputError, match=message):
        simulate(a, u0, (0.0, 1.0), x0, **kw)


@pytest.mark.parametrize("engine", [InHouseEngine(), JSBSimEngine()], ids=["inhouse", "jsbsim"])
@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(dt_out=0.0), "dt_out must be a positive"),
        (dict(dt_out=-1.0), "dt_out must be a positive"),
        (dict(dt_out=0.3), "does not divide the span"),
        (dict(t_eval=[0.0, 2.0]), "t_eval must lie in t_span"),
    ],
)
def test_k7_both_engines_share_the_output_checks(f16, engine, kw, message):
    a, x0, u0 = f16
    with pytest.raises(InputError, match=message):
        engine.simulate(a, u0, (0.0, 1.0), x0, **kw)


def test_k7_state_and_control_shapes_are_input_errors(f16):
    a, x0, u0 = f16
    with pytest.raises(InputError, match="12 wind-frame values"):
        simulate(a, u0, (0.0, 1.0), x0[:5])
    with pytest.raises(InputError, match="must return 5 values"):
        simulate(a, lambda t: u0[:3], (0.0, 1.0), x0)
    with pytest.raises(InputError, match="must return 5 values"):
        JSBSimEngine().simulate(a, lambda t: u0[:3], (0.0, 1.0), x0)


def test_k7_a_dividing_dt_out_is_honoured_exactly():
    assert np.array_equal(output_grid(0.0, 1.0, 0.25), [0.0, 0.25, 0.5, 0.75, 1.0])
    assert output_grid(0.0, 1.0, 0.1).size == 11


def test_k7_trim_model_and_plan_step_are_input_errors(f16):
    from planners.generalized import plan_scenario

    with pytest.raises(InputError, match="model must be 'full' or 'simple', got 'weird'"):
        trim(f16[0], {"V": 150.0, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0}, model="weird")
    plan = plan_scenario(load_scenario("gtm-aileron-roll"), J=0)
    for step in (0.0, -1.0, float("inf"), "x"):
        with pytest.raises(InputError, match="step must be"):
            plan.to_dataframe(step=step)
    span = plan.t1 - plan.t0
    df = plan.to_dataframe(step=0.3 * span)  # does not divide the span: stops at t1 or before
    assert df.index[-1] <= plan.t1 and np.allclose(np.diff(df.index), 0.3 * span)


# --------------------------------------------------------------------------- 8: divergence alike on both engines


def test_k8_the_domain_test_names_time_variable_and_value():
    x = np.zeros(12)
    x[3] = 0.016
    assert "airspeed V below the domain's 1 m/s" in domain_violation(2.0, x) and "t = 2 s" in domain_violation(2.0, x)
    x[3] = 3.5e44
    assert "above the domain's 3000 m/s (V = 3.5e+44 m/s)" in domain_violation(2.0, x)
    x[3], x[6] = 100.0, math.pi
    assert "|alpha| above the domain's 90 deg" in domain_violation(2.0, x)
    x[6] = 0.1
    assert domain_violation(2.0, x) is None
    x[10] = float("inf")
    assert "non-finite state (q = inf)" in domain_violation(2.0, x)


def _both(a, u, x0, span):
    return {e.name: e.simulate(a, u, span, x0, dt_out=0.05) for e in (InHouseEngine(), JSBSimEngine())}


def test_k8_a_blow_up_ends_alike_and_keeps_only_valid_rows(f16):
    a, x0, u0 = f16

    def boom(t):
        u = u0.copy()
        if t > 0.5:
            u[0] = 1e8
        return u

    runs = _both(a, boom, x0, (0.0, 30.0))
    for name, r in runs.items():
        assert r.status == "domain", name
        assert r.message.startswith("left the physical domain at t = 0.7") and "airspeed V above" in r.message
        assert float(r.message.split("t = ")[1].split(" s")[0]) == pytest.approx(0.77, abs=0.005)
        assert "partial result kept up to t = " in r.message
        assert r.df["V"].max() <= DOMAIN.V_max and np.isfinite(r.df.to_numpy()).all()


def test_k8_a_stalled_vertical_climb_ends_alike(f16):
    a, x0, u0 = f16
    x1 = x0.copy()
    x1[4] = 1.4
    u1 = u0.copy()
    u1[0] = 0.0
    runs = _both(a, u1, x1, (0.0, 30.0))
    ends = {}
    for name, r in runs.items():
        assert r.status == "domain" and "cos(gamma) below" in r.message, (name, r.message)
        assert r.df["V"].min() > DOMAIN.V_min and (r.df["alpha"].abs() < DOMAIN.alpha_max).all()
        ends[name] = float(r.message.split("t = ")[1].split(" s")[0])
    assert ends["inhouse"] == pytest.approx(ends["jsbsim"], abs=0.02)


# --------------------------------------------------------------------------- 9: continuous angles on JSBSim


def test_k9_jsbsim_mu_is_continuous_at_a_coarse_output_grid():
    a = load_aircraft("f16c")
    t = trim_level(a, 200.0, 3000.0)
    x0, u0 = np.array(t.state, dtype=float), np.array(t.controls, dtype=float)

    def u(tt):
        tt = np.asarray(tt, dtype=float)
        return (u0[0] + 0 * tt, u0[1] + 0 * tt, -0.35 * np.minimum(tt / 2.0, 1.0), u0[3] + 0 * tt, u0[4] + 0 * tt)

    ref = InHouseEngine().simulate(a, u, (0.0, 10.0), x0, dt_out=1.0)
    r = JSBSimEngine().simulate(a, u, (0.0, 10.0), x0, dt_out=1.0)
    assert r.completed and ref.completed
    assert ref.df["mu"].iloc[-1] > 6 * math.pi  # several turns, > pi between samples
    np.testing.assert_allclose(r.df["mu"].to_numpy(), ref.df["mu"].to_numpy(), atol=0.05)
    np.testing.assert_allclose(r.df["chi"].to_numpy(), ref.df["chi"].to_numpy(), atol=0.05)


# --------------------------------------------------------------------------- 10: planning cost


def test_k10_a_huge_plan_is_refused_at_once_with_the_override_named():
    from planners.generalized import MAX_PLAN_COST, plan_cost, plan_motion
    from planners.generalized_newton import counted

    sc = load_scenario("gtm-aileron-roll")
    nodes = np.linspace(sc.t0, sc.t1, 10001)
    assert plan_cost(10001, 30) > 50 * MAX_PLAN_COST
    problem, counter = counted(sc.problem())
    with pytest.raises(InputError, match=r"J = 30 on 10001 nodes costs 4.79e\+08 .*--max-cost"):
        plan_motion(problem, nodes, J=30)
    assert counter.calls == 0  # refused before the aircraft's model is evaluated once
    assert plan_cost(len(sc.t_nodes), 7) < MAX_PLAN_COST / 40  # the paper's plans are far below


def test_k10_cli_max_cost(tmp_path, capsys):
    assert main(["plan", "gtm-aileron-roll", "--J", "1", "--max-cost", "10", "--out", str(tmp_path / "out")]) == 2
    assert "above the bound 10" in capsys.readouterr().err


def test_k10_long_plans_log_their_progress_per_iterate(monkeypatch, caplog):
    import planners.generalized as gen

    monkeypatch.setattr(gen, "PROGRESS_COST", 0.0)
    sc = load_scenario("gtm-aileron-roll")
    with caplog.at_level(logging.INFO, logger="planners.generalized"):
        gen.plan_motion(sc.problem(), sc.t_nodes[:11], J=1, name="roll")
    text = caplog.text
    assert "plan roll: J = 1 on 11 nodes" in text
    assert "iterate j = 0 of 1 (order 7)" in text and "iterate j = 1 of 1 (order 5)" in text


# --------------------------------------------------------------------------- 11: controls and trim parameters


def test_k11_eta_outside_its_range_is_refused(capsys):
    assert main(["trim", "twin-otter", "--speed", "72", "--eta", "5"]) == 2
    assert "eta = 5 is outside [-1, 1]" in capsys.readouterr().err
    with pytest.raises(InputError, match="one engine on the symmetry plane"):
        trim_level(load_aircraft("f16c"), 150.0, 3000.0, eta=0.5)


def test_k11_the_twin_otters_live_engine_is_checked_against_its_own_rating():
    a = load_aircraft("twin-otter")
    p = a.propulsion
    assert p.engine_power == pytest.approx(680.0 * HP) and "PT6A-27" in p.engine_source
    assert p.engine_thrust_limit(140 * KT) == pytest.approx(0.8 * 680.0 * HP / (140 * KT))
    t = trim(a, {"V": 140 * KT, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0}, altitude=1000 * FT, eta=1.0)
    w = [x for x in t.warnings if x.startswith("engine 1 thrust")]
    assert len(w) == 1 and "above its rating 5632.4 N" in w[0] and "PT6A-27" in w[0]
    # Both engines sharing the same thrust stay within their ratings.
    t2 = trim(a, {"V": 140 * KT, "gamma": 0.0, "chi_dot": 0.0, "beta": 0.0}, altitude=1000 * FT)
    assert not [x for x in t2.warnings if "rating" in x]


def test_k11_trajectories_are_checked_per_engine():
    a = load_aircraft("twin-otter")
    n = 5
    df = pd.DataFrame(
        {
            "alpha": np.zeros(n),
            "beta": np.zeros(n),
            "F": np.full(n, 5900.0),
            "eta": np.ones(n),
            "dl": np.zeros(n),
            "dm": np.zeros(n),
            "dn": np.zeros(n),
            "V": np.full(n, 140 * KT),
        },
        index=pd.Index(np.arange(n, dtype=float), name="t"),
    )
    w = [x for x in envelope_warnings(a, df) if "rating" in x]
    assert len(w) == 1 and w[0].startswith("engine 1 thrust 5900.0 N at t = 0 s") and "(100 % of the run)" in w[0]


# --------------------------------------------------------------------------- 12: the JSBSim fitting source


def test_k12_the_f104s_normalised_elevator_follows_the_elevator():
    from gna.aero import AeroState
    from gna.fit.sources.jsbsim_aero import JSBSimAeroSource

    src = JSBSimAeroSource("f104", mach=0.5, altitude=3000.0)
    assert src.surface_copies == {"fcs/elevator-pos-norm": ("fcs/elevator-pos-rad", "aerosurface_scale")}
    assert float(src.coefficients(AeroState(0.05, 0, 0, 0, 0, 0, -0.3, 0)).CD) == pytest.approx(0.0592, abs=2e-4)
    assert "fcs/elevator-pos-norm follows fcs/elevator-pos-rad" in src.provenance()["source_model"]


def test_k12_sampling_does_not_run_the_aircrafts_output_directives(tmp_path):
    import jsbsim

    from gna.aero import AeroState
    from gna.fit.sources.jsbsim_aero import JSBSimAeroSource

    pkg = Path(jsbsim.__file__).parent
    root = tmp_path / "jsbsim"
    (root / "aircraft").mkdir(parents=True)
    shutil.copytree(pkg / "aircraft" / "global5000", root / "aircraft" / "global5000")
    for d in ("engine", "systems"):
        (root / d).symlink_to(pkg / d)
    src = JSBSimAeroSource("global5000", mach=0.5, altitude=3000.0, root=root)
    src.coefficients(AeroState(0.05, 0, 0, 0, 0, 0, -0.1, 0))
    assert not list(root.glob("*.csv")) and not list(root.rglob("global5000.csv"))


def test_k12_surface_properties_can_be_given_explicitly():
    from gna.fit.sources.jsbsim_aero import JSBSimAeroSource
    from harness.commands.fit import _surface_overrides, _surface_property

    found = JSBSimAeroSource("c172x", mach=0.15, altitude=1000.0)  # the property its FCS drives, found
    assert found.surface_map["dl"] == ("fcs/effective-aileron-pos", -1.0)
    over = _surface_overrides(
        [_surface_property("dl=fcs/effective-aileron-pos"), _surface_property("dm=fcs/elevator-pos-deg")]
    )
    assert over == {"dl": ("fcs/effective-aileron-pos", -1.0), "dm": ("fcs/elevator-pos-deg", 180.0 / math.pi)}
    src = JSBSimAeroSource("c172x", mach=0.15, altitude=1000.0, surfaces={"dl": over["dl"]})
    assert src.surface_map["dl"] == ("fcs/effective-aileron-pos", -1.0)
    assert _surface_property("dm=fcs/elevator-pos-norm:-2.5") == ("dm", ("fcs/elevator-pos-norm", -2.5))
