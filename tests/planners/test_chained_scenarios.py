"""Scenario files of the chained systems (planners.systems.scenario) and `gflat plan FILE` on them."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gna.errors import InputError
from gna.schema import read_toml
from planners.scenario import list_scenarios
from planners.systems.first_order_lag import lag_exact, lag_reference
from planners.systems.scenario import (
    SPECS,
    chained_scenario_from_dict,
    is_chained_scenario,
    list_chained_scenarios,
    load_chained_scenario,
    plan_chained_scenario,
)


def test_bundled_chained_scenarios_load_and_are_not_aircraft_scenarios():
    assert set(list_chained_scenarios()) == {"first-order-lag", "car-two-trailers"}
    assert not set(list_chained_scenarios()) & set(list_scenarios())
    for name in list_chained_scenarios():
        assert is_chained_scenario(name)
        sc = load_chained_scenario(name)
        assert sc.name == name and sc.system_name in SPECS and sc.system.name == name
    assert not is_chained_scenario("gtm-aileron-roll") and not is_chained_scenario("no-such.toml")
    lag = load_chained_scenario("first-order-lag")
    assert lag.J == 12 and lag.parameters == {"eps": 0.1} and len(lag.t_nodes) == 13
    assert load_chained_scenario("first-order-lag", J=3).J == 3


def test_lag_scenario_matches_the_exact_operator_relation():
    """The planned y against (1 + eps d/dt)^-1 x' to 1e-10: the Laplace-integral reference agrees with the
    closed form for a sinusoid, and with the exact operator relation on an exponential-polynomial x."""
    sc = load_chained_scenario("first-order-lag")
    check = sc.spec.check(plan_chained_scenario(sc), sc)
    assert check["max |y - (1 + eps d/dt)^-1 x'| at the nodes"] < 1e-10
    tn = sc.t_nodes
    assert np.max(np.abs(lag_exact(sc.flat_outputs["x"], 0.1, tn) - lag_reference((1.0, 0.0), 0.1, 1.0)(tn))) < 1e-13
    # x = t e^(l t), l = 1/2: x' = (1 + l t) e^(l t) and (1 + eps D)(q e^(l t)) = ((1 + eps l) q + eps q') e^(l t),
    # so y = (1 - eps l/(1 + eps l) + l t) e^(l t) / (1 + eps l) exactly
    raw = read_toml(sc.path)
    raw["flat_outputs"]["x"] = "t*exp(t/2)"
    raw["generalized"]["J"] = 14
    ex = chained_scenario_from_dict(raw, "exp-poly")
    lam, eps = 0.5, 0.1
    exact = (1 - eps * lam / (1 + eps * lam) + lam * tn) * np.exp(lam * tn) / (1 + eps * lam)
    assert np.max(np.abs(lag_exact(ex.flat_outputs["x"], eps, tn) - exact)) < 1e-12
    assert ex.spec.check(plan_chained_scenario(ex), ex)["max |y - (1 + eps d/dt)^-1 x'| at the nodes"] < 1e-10


def test_car_scenario_open_loop_error_and_newton():
    sc = load_chained_scenario("car-two-trailers")
    key = "open-loop error of the exact off-axle model [m]"
    fixed = sc.spec.check(plan_chained_scenario(sc), sc)[key]
    newton = sc.spec.check(plan_chained_scenario(sc, method="newton"), sc)[key]
    assert fixed < 1e-4 and newton < 2e-5
    flat = sc.spec.check(plan_chained_scenario(sc, J=0), sc)[key]
    assert 0.2 < flat < 1.0  # the on-axle (flat) approximation alone


@pytest.mark.parametrize(
    "change, message",
    [
        ({"parameters": {"epss": 0.1}}, r"\[parameters\]: unknown key 'epss' \(did you mean 'eps'\?\)"),
        ({"generalized": {"JJ": 2}}, r"unknown key 'JJ' \(did you mean 'J'\?\)"),
        ({"flat_outputs": {"x": "sin(t)", "y": "t"}}, r"\[flat_outputs\]: unknown key 'y'"),
        ({"system": "unicycle"}, r"system"),
        ({"time": {"t0": 0.0, "t1": 1.0, "step": 0.3}}, r"step 0.3 s must divide"),
        ({"flat_outputs": {"x": "sin(t"}}, r"\[flat_outputs\] x: cannot parse"),
        ({"generalized": {"method": "bisection"}}, r"method"),
        ({"constants": {"pi": 3.0}}, r"shadow"),
        ({"frobnicate": 1}, r"unknown key 'frobnicate'"),
    ],
)
def test_bad_files_are_refused_with_one_clear_line(change, message):
    raw = read_toml(load_chained_scenario("first-order-lag").path)
    raw.update(change)
    with pytest.raises(InputError, match=message):
        chained_scenario_from_dict(raw, "bad.toml")


def test_gflat_plan_runs_a_chained_scenario_file(tmp_path, capsys):
    from pathlib import Path

    from harness.cli import main

    text = Path(load_chained_scenario("car-two-trailers").path).read_text(encoding="utf-8")
    path = tmp_path / "my-car.toml"
    path.write_text(
        text.replace('name = "car-two-trailers"', 'name = "my-car"').replace("d2 = 0.6", "d2 = 0.0"), encoding="utf-8"
    )
    assert is_chained_scenario(str(path))
    assert main(["plan", str(path), "--J", "2", "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "my-car" in out and "open-loop error of the exact off-axle model" in out
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["J"] == 2 and summary["parameters"]["d2"] == 0.0 and summary["system"] == "car-two-trailers"
    assert summary["checks"]["open-loop error of the exact off-axle model [m]"] < 0.05


def test_a_plan_that_is_not_a_solution_of_the_exact_model_exits_1(tmp_path, capsys):
    """A lag whose series diverges (eps w = 1.5) and a car whose exact model jack-knifes open loop: one line
    on stderr naming why, exit 1, no traceback."""
    from pathlib import Path

    import planners.systems
    from harness.cli import main

    src = (Path(planners.systems.__file__).parent / "scenarios" / "first-order-lag.toml").read_text()
    lag = tmp_path / "lag.toml"
    lag.write_text(src.replace("eps = 0.1", "eps = 0.5").replace("w = 1.0", "w = 3.0"))
    assert main(["plan", str(lag), "--out", str(tmp_path / "o1")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "converges only where eps" in err[0]
    for flag in (["--verify"], ["--J", "auto"]):
        assert main(["plan", "car-two-trailers", *flag, "--out", str(tmp_path / "o2")]) == 2
        assert "for aircraft scenarios only" in capsys.readouterr().err
