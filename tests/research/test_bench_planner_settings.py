"""research/bench_planner_settings.py: a row per setting, the plan's own figures, bad settings refused."""

from __future__ import annotations

import dataclasses

import pytest

from planners.generalized import plan_scenario
from planners.scenario import load_scenario
from planners.verify import open_loop_error

from .conftest import research_module


@pytest.fixture(scope="module")
def bps():
    with research_module("bench_planner_settings", "bench_planner_settings") as mod:
        yield mod


def test_a_setting_gives_the_plan_of_that_setting(bps):
    sc = load_scenario("twin-otter-single-engine")
    row = bps.measure(sc, 4.0, 2, 2, repeat=1)
    assert row["nodes"] == 16 and row["wall_s"] > 0 and row["cpu_s"] > 0
    plan = plan_scenario(dataclasses.replace(sc, step=4.0, e=2), J=2)
    assert row["accuracy_m"] == open_loop_error(plan).max_position_error_m


def test_a_setting_that_cannot_be_planned_is_a_row_with_its_reason(bps, capsys):
    # J = 30 on the roll: the iteration diverges past its floor (docs/performance.md, Planner settings)
    bps.main(["gtm-aileron-roll", "--J", "30", "--repeat", "1"])
    out = capsys.readouterr().out
    assert "cannot be planned" in out


@pytest.mark.parametrize(
    "argv, message",
    [
        (["nope"], "unknown scenario 'nope'"),
        (["gtm-aileron-roll", "--step", "0"], "--step: positive numbers"),
        (["gtm-aileron-roll", "--e", "x"], "--e: comma-separated numbers"),
        (["gtm-aileron-roll", "--J", "-1"], "--J: whole numbers from 0 to 30"),
        (["gtm-aileron-roll", "--J", "31"], "--J: whole numbers from 0 to 30"),
        (["gtm-aileron-roll", "--e", "100"], "--e: whole numbers from 0 to 10"),
        (["gtm-aileron-roll", "--step", "1e-9"], "makes 8e+09 nodes"),
        (["gtm-aileron-roll", "--step", "0.3"], "does not divide the 8 s span"),
        (["gtm-aileron-roll", "--step", "1000"], "longer than the 8 s span"),
        (["gtm-aileron-roll", "--repeat", "0"], "--repeat: at least 1"),
    ],
)
def test_bad_settings_are_one_line_and_exit_2(bps, capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        bps.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1]
