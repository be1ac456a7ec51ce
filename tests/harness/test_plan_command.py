"""``gflat plan --json`` and ``--verify``: the planner's numbers as one JSON object, and the open-loop check."""

import json
import math

from harness.cli import main
from harness.commands.plan import plan_summary
from planners.generalized import plan_scenario
from planners.scenario import load_scenario
from planners.verify import OpenLoopCheck, open_loop_error


def test_plan_json_verify_prints_one_object_with_the_contract_keys(tmp_path, capsys):
    rc = main(["plan", "twin-otter-single-engine", "--json", "--verify", "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert rc == 0
    d = json.loads(out)  # stdout is one JSON object and nothing else
    assert d["feasible"] is True
    assert d["planning_time_s"] > 0
    res = d["equation_residual_per_iterate"]
    assert len(res) == d["J"] + 1 and all(math.isfinite(r) for r in res)
    assert res[-1] < res[0]  # generalized flatness reduces the neglected terms' residual
    err = d["open_loop_max_position_error_m"]
    assert 0 < err < 0.02, err  # full model flown open loop from the plan's initial state
    assert d["open_loop_status"] == "completed"
    assert d["open_loop_settings"]["rtol"] == 1e-10 and d["open_loop_settings"]["method"] == "DOP853"
    saved = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert saved["open_loop_max_position_error_m"] == err


def test_plan_json_without_verify_has_no_open_loop_keys(tmp_path, capsys):
    assert main(["plan", "gtm-aileron-roll", "--J", "1", "--json", "--out", str(tmp_path / "o")]) == 0
    d = json.loads(capsys.readouterr().out)
    assert "open_loop_max_position_error_m" not in d
    assert len(d["equation_residual_per_iterate"]) == 2


def test_verify_matches_the_python_api_and_a_stopped_flight_is_reported():
    sc = load_scenario("gtm-aileron-roll", J=1)
    plan = plan_scenario(sc)
    check = open_loop_error(plan)
    assert check.status == "completed" and check.t_worst <= plan.t1
    assert check.max_position_error_m == plan_summary(sc, plan, 0.1, check)["open_loop_max_position_error_m"]
    stopped = OpenLoopCheck(float("nan"), 1.0, float("nan"), "domain", "alpha = 1.6 rad at t = 1 s", {})
    s = plan_summary(sc, plan, 0.1, stopped)
    assert s["open_loop_max_position_error_m"] is None and s["open_loop_message"].startswith("alpha")


ROLL = """name = "roll-beta"
aircraft = "gtm"
[time]
t0 = -2.5
t1 = 5.5
step = 0.5
[flat_outputs]
x = "100*kmh*t"
y = "0"
z = "-1000 + 0.5*g0*t**2"
zeta = "{zeta}"
zeta_value = "{value}"
[generalized]
J = 2
e = 2
"""


def test_singular_flat_output_is_one_line_exit_1_and_no_absurd_files(tmp_path, capsys):
    """The aileron roll with zeta = 'beta' (unusable at zero g): the planner names the singular stage 2, the
    verification flight is not made (its keys null, with the reason), and the diverged iterates are not
    written (no plan-j2.parquet, series or convergence table with values beyond 1e+100)."""
    path = tmp_path / "roll-beta.toml"
    path.write_text(ROLL.format(zeta="beta", value="0"))
    out = tmp_path / "out"
    rc = main(["plan", str(path), "--json", "--verify", "--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 1
    err = cap.err.strip().splitlines()
    assert len(err) == 1 and "stage 2 of the flat parametrization is singular" in err[0] and "cond_beta" in err[0]
    d = json.loads(cap.out)
    assert d["feasible"] is False and "stage 2" in d["infeasible_reason"]
    for key in (
        "open_loop_max_position_error_m",
        "open_loop_t_worst_s",
        "open_loop_max_angle_error_rad",
        "open_loop_settings",
    ):
        assert key in d and d[key] is None
    assert d["open_loop_status"] == "not flown"
    assert d["open_loop_message"].startswith("not flown: the plan is not feasible: stage 2")
    assert sorted(p.name for p in out.iterdir()) == [
        "manifest.json",
        "plan-j0.parquet",
        "singularities.parquet",
        "summary.json",
    ]


def test_infeasible_plan_json_verify_carries_the_reason_and_null_open_loop_keys(tmp_path, capsys):
    """Any infeasible plan (here a Newton failure: the same parabola with mu turning 20 rad/s) keeps exit 1;
    with --json --verify the reason is in the JSON and the open_loop_* keys are present as null."""
    path = tmp_path / "roll-fast.toml"
    path.write_text(ROLL.format(zeta="mu", value="20*t"))
    rc = main(["plan", str(path), "--json", "--verify", "--out", str(tmp_path / "o")])
    cap = capsys.readouterr()
    d = json.loads(cap.out)
    assert rc == 1 and d["feasible"] is False
    assert d["infeasible_reason"] and d["open_loop_message"].endswith(d["infeasible_reason"])
    assert d["open_loop_max_position_error_m"] is None and d["open_loop_status"] == "not flown"


def test_feasible_plan_has_a_null_reason(tmp_path, capsys):
    assert main(["plan", "gtm-aileron-roll", "--J", "1", "--json", "--out", str(tmp_path / "o")]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["feasible"] is True and d["infeasible_reason"] is None


def test_compare_table_keys_are_refused_by_plan_too(tmp_path, capsys):
    path = tmp_path / "roll.toml"
    path.write_text(ROLL.format(zeta="mu", value="pi*t/2") + "[compare]\ntolerance = 1.0\n")
    assert main(["plan", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "[compare]: unknown key 'tolerance' (did you mean 'tolerances'?)" in err[0]
    assert not (tmp_path / "o").exists()


def test_J_out_of_range_blames_the_option(capsys):
    import pytest

    with pytest.raises(SystemExit) as exc:
        main(["plan", "gtm-aileron-roll", "--J", "1000"])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert "argument --J: must be between 0 and 30" in err and ".toml" not in err


def test_cost_bound_message_gives_seconds_under_a_minute(capsys):
    assert main(["plan", "gtm-aileron-roll", "--max-cost", "10"]) == 2
    err = capsys.readouterr().err
    assert "(about 0.16 s of planning)" in err and "min of planning" not in err


def test_compare_names_the_singular_stage_2_too(tmp_path, capsys):
    path = tmp_path / "roll-beta.toml"
    path.write_text(ROLL.format(zeta="beta", value="0"))
    assert main(["compare", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "the plan is not feasible, nothing to fly: stage 2 of the flat parametrization is singular" in err


def test_infeasible_bounds_are_one_line_naming_the_binding_limit_and_exit_1(tmp_path, capsys):
    """The bounded forward slip on a GTM whose ailerons move +-5 deg only (its own aircraft file), the descent
    rate free: no descent within [4, 6.5] m/s meets dl, and gflat plan says so in one line naming the binding
    limit and the best value it reaches, exit 1 (the JSON's bounded.infeasible is the same line)."""
    from gna.catalogue import bundled

    text = bundled("gna", "data", "aircraft")["gtm"].read_text(encoding="utf-8")
    assert "\ndl_max_deg = 20.0\n" in text and '\nid = "gtm"\n' in text
    text = text.replace("\ndl_max_deg = 20.0\n", "\ndl_max_deg = 5.0\n").replace('\nid = "gtm"\n', '\nid = "gtm-dl5"\n')
    (tmp_path / "gtm-dl5.toml").write_text(text)
    sc = bundled("planners", "scenarios")["gtm-forward-slip-bounded"].read_text(encoding="utf-8")
    for old, new in (
        ('aircraft = "gtm"', 'aircraft = "gtm-dl5.toml"'),
        ("min = 27.0, max = 32.0", "min = 29.10852587, max = 29.10852587"),  # speed fixed
        ("value = 70.0, min = 0.0, max = 100.0", "value = 0.0, min = 0.0, max = 0.0"),  # no wave
        ("step = 6.0", "step = 30.0"),
        ("J = 8", "J = 1"),
    ):
        assert old in sc
        sc = sc.replace(old, new)
    (tmp_path / "slip-dl5.toml").write_text(sc)
    rc = main(["plan", str(tmp_path / "slip-dl5.toml"), "--json", "-q", "--out", str(tmp_path / "o")])
    cap = capsys.readouterr()
    assert rc == 1
    err = cap.err.strip().splitlines()
    assert len(err) == 1, err
    line = err[0]
    assert line.startswith("gflat plan: infeasible bounds: gtm-forward-slip-bounded: no parameter values")
    assert "binding limit dl: control dl beyond its limit 5.0 deg" in line and "worst -" in line
    assert "at the best parameters (descent = " in line
    d = json.loads(cap.out)["bounded"]
    assert d["feasible"] is False and line.endswith(d["infeasible"]) and d["binding"]["name"] == "dl"
    assert 4.0 <= d["optimum"]["descent"] < 5.983  # less descent, less drag to make: less aileron
    assert abs(d["binding"]["worst"]) < abs(d["binding"]["limit"]) * 27.8 / 5.0  # better than the nominal's
