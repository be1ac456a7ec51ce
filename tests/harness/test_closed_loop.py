"""Closed-loop validation cases: the tracking feedback flown on the in-house engine and JSBSim."""

from __future__ import annotations

import json
import pickle

import pytest

from harness.cli import main
from harness.validation import ValidationCase, run_case


@pytest.fixture(scope="module")
def twin_otter_closed():
    return run_case(ValidationCase("twin-otter-single-engine", loop="closed"))


def test_closed_loop_from_the_plan_stays_on_the_flat_outputs_and_engines_agree(twin_otter_closed):
    r = twin_otter_closed
    v = r.verdict()
    assert v["pass"] and v["loop"] == "closed"
    for label in ("inhouse", "jsbsim"):
        assert v["runs"][label]["status"] == "completed"
        # Started on the plan: the feedback only corrects the generalized plan's residual error
        # (measured 5.5e-5 m in-house, 4.9e-4 m on JSBSim over 60 s).
        assert v["runs"][label]["max_position_error_m"] < 1e-2
    assert v["differences"]["jsbsim"]["max_position_m"] <= 1e-2
    # The feedback acted through its integral states, reported on the output grid.
    states = r.runs["inhouse"].controller_states
    assert list(states.columns) == list(r.closed_loop.controller.state_names)
    assert r.open_loop is not None and r.open_loop.completed  # the paper's cyan curve
    pickle.dumps(r.closed_loop.controller)  # campaigns ship it to workers


def test_roll_closed_loop_agrees_across_engines():
    v = run_case(ValidationCase("gtm-aileron-roll", loop="closed")).verdict()
    assert v["pass"], v
    assert v["differences"]["jsbsim"]["max_position_m"] <= 1e-2  # measured 1.7e-5 m
    assert max(r["max_position_error_m"] for r in v["runs"].values()) < 1e-2  # measured 8.4e-4 m


def test_compare_json_contract(tmp_path, capsys):
    code = main(["compare", "twin-otter-single-engine", "--loop", "closed", "--json", "--out", str(tmp_path / "out")])
    d = json.loads(capsys.readouterr().out)
    assert code == 0 and d["pass"] is True
    assert set(d) == {
        "scenario",
        "loop",
        "runs",
        "differences",
        "delta_pct_definition",
        "pass",
        "failures",
        "verdicts",
        "recorded",
        "settings",
        "self_convergence",
        "out",  # the run folder and its report (index.html)
        "report",
    }
    assert set(d["runs"]) == {"inhouse", "jsbsim"} and set(d["differences"]) == {"jsbsim"}
    v = d["verdicts"]
    assert set(v) == {"flyable", "tracking", "engines_agree"} and all("pass" in x for x in v.values())
    # the paper's single-engine path asks the live engine for more than its rating: recorded by the scenario
    (thrust,) = v["flyable"]["violations"]
    assert {"name", "limit", "worst", "time", "fraction"} <= set(thrust) and thrust["name"] == "thrust[1]"
    assert thrust["worst"] == pytest.approx(5857, abs=1) and thrust["limit"] == pytest.approx(5632.4, abs=0.1)
    assert thrust["time"] == pytest.approx(60.0) and thrust["known"] is True and v["flyable"]["pass"] is False
    assert d["failures"] == [] and d["recorded"][0]["failure"] == "flyable: thrust[1]"
    assert v["tracking"]["pass"] is True and v["tracking"]["max_error_after_settle_m"] < 1.0
    assert v["engines_agree"]["pass"] is True
    assert set(d["runs"]["jsbsim"]) == {
        "status",
        "max_position_error_m",
        "max_position_error_after_5s_m",
        "saturated_s",
    }
    assert set(d["differences"]["jsbsim"]) == {"max_position_m", "max_angle_rad", "delta_pct"}
    assert (tmp_path / "out" / "tracking.png").is_file() and (tmp_path / "out" / "summary.json").is_file()


def test_open_loop_json_has_the_same_keys(tmp_path, capsys):
    code = main(["compare", "gtm-aileron-roll", "--json", "--out", str(tmp_path / "out")])
    d = json.loads(capsys.readouterr().out)
    assert code == 0 and d["loop"] == "open"
    assert all(r["saturated_s"] == 0.0 for r in d["runs"].values())


def test_compare_tracking_lqr_is_flown_and_recorded(tmp_path, capsys):
    out = tmp_path / "roll-lqr"
    code = main(["compare", "gtm-aileron-roll", "--loop", "closed", "--tracking", "lqr", "--json", "--out", str(out)])
    d = json.loads(capsys.readouterr().out)
    assert code == 0 and d["pass"] is True, d
    assert json.loads((out / "summary.json").read_text())["tracking"] == "lqr"
    assert json.loads((out / "report.json").read_text())["closed_loop"]["design"] == "lqr"
    assert [c["tracking"] for c in json.loads((out / "manifest.json").read_text())["cases"]] == ["lqr"]


def test_tracking_flag_refuses_an_unknown_design(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["compare", "gtm-aileron-roll", "--loop", "closed", "--tracking", "pid", "--out", str(tmp_path / "o")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "argument --tracking: invalid choice: 'pid'" in err
    assert not (tmp_path / "o").exists()


def test_the_case_and_campaign_carry_the_tracking_design():
    from gna.errors import InputError
    from harness.campaign.spec import load_campaign

    assert ValidationCase("gtm-aileron-roll", loop="closed", tracking="lqr").tracking == "lqr"
    with pytest.raises(InputError, match="tracking: the tracking design must be 'paper' or 'lqr', got 'x'"):
        ValidationCase("gtm-aileron-roll", loop="closed", tracking="x")
    camp = load_campaign("paper-dispersions")
    assert camp.with_tracking(None) is camp and camp.tracking is None
    lqr = camp.with_tracking("lqr")
    assert lqr.tracking == "lqr" and {c.case.tracking for c in lqr.cases} == {"lqr"}
    assert lqr.tasks(1)[0].parameters()["tracking"] == "lqr"
    assert "tracking" not in camp.tasks(1)[0].parameters()
