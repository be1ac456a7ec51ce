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
    d = json.loads(out)                               # stdout is one JSON object and nothing else
    assert d["feasible"] is True
    assert d["planning_time_s"] > 0
    res = d["equation_residual_per_iterate"]
    assert len(res) == d["J"] + 1 and all(math.isfinite(r) for r in res)
    assert res[-1] < res[0]                           # generalized flatness reduces the neglected terms' residual
    err = d["open_loop_max_position_error_m"]
    assert 0 < err < 0.02, err                        # full model flown open loop from the plan's initial state
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
