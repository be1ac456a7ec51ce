"""A plan whose path reaches the ground between the nodes is not feasible (ground effect: no ground contact).

The nodes' heights are refused before planning (``Environment.check_altitude``); between them the plan's
own interpolation is sampled (:func:`planners.generalized.ground_failures`).  The path below dips 0.3 m below
the ground at every odd second while every node (even seconds) is 0.3 m above it.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import planners
from gna.errors import DomainError
from harness.cli import main
from harness.validation.case import ValidationCase
from harness.validation.run import run_case
from planners.generalized import ground_failures, plan_scenario
from planners.scenario import load_scenario

BUNDLED = Path(planners.__file__).parent / "scenarios" / "twin-otter-single-engine.toml"
#: 0.3 m above the ground at the nodes (t = 0, 2, 4, ...), 0.3 m below it at t = 1, 3, 5, ...
DIPPING = 'z = "5.9436 - 0.3 + 0.6*sin(pi*t/2)**2"'
#: The same height everywhere (0.3 m above the ground): the path never reaches it.
LEVEL = 'z = "5.9436 - 0.3"'


def _path(tmp_path, z: str, ground: bool = True) -> Path:
    text = BUNDLED.read_text(encoding="utf-8").replace('name = "twin-otter-single-engine"', 'name = "to-ge"')
    text = text.replace('z = "0"', z)
    path = tmp_path / "to-ge.toml"
    path.write_text(text + ("\n[environment.ground_effect]\nelevation = -5.9436\n" if ground else ""), encoding="utf-8")
    return path


def test_path_below_the_ground_between_nodes_is_not_feasible(tmp_path):
    plan = plan_scenario(load_scenario(_path(tmp_path, DIPPING), J=2))
    assert not plan.feasible and not plan.newton_failures
    assert len(plan.domain_failures) == plan.J + 1  # every iterate: z is a flat output
    line = plan.domain_failures[-1]
    # The first sample at or below the ground (h = 0 at t = 0.5 s exactly), then the lowest (-0.3 m at t = 1 s).
    assert line.startswith(
        "iterate j = 2: left the physical domain at t = 0.53125 s: height above the ground "
        "at or below 0 (ground at -5.9436 m altitude; no ground contact is modelled) (h = -0.02"
    )
    assert re.search(r"; lowest h = -0\.29\d* m at t = \d*[13579] s$", line)


def test_path_above_the_ground_and_free_air_are_feasible(tmp_path):
    level = plan_scenario(load_scenario(_path(tmp_path, LEVEL), J=2))
    assert level.feasible and ground_failures(level) == []
    free = plan_scenario(load_scenario(_path(tmp_path, DIPPING, ground=False), J=2))
    assert free.feasible and ground_failures(free) == []  # no ground without ground effect: no height test


def test_gflat_plan_exits_1_naming_time_and_height(tmp_path, capsys):
    rc = main(["plan", str(_path(tmp_path, DIPPING)), "--J", "2", "--json", "--verify", "--out", str(tmp_path / "o")])
    cap = capsys.readouterr()
    assert rc == 1
    assert json.loads(cap.out)["feasible"] is False
    assert (
        "gflat plan: the plan is not feasible: iterate j = 2: left the physical domain at t = 0.53125 s: "
        "height above the ground at or below 0"
    ) in cap.err


def test_comparison_refuses_to_fly_it(tmp_path):
    sc = load_scenario(_path(tmp_path, DIPPING), J=2)
    with pytest.raises(
        DomainError,
        match="nothing to fly: iterate j = 2: left the physical domain at t = 0.53125 s: height above the ground",
    ):
        run_case(ValidationCase(str(_path(tmp_path, DIPPING)), J=2), plan=plan_scenario(sc), scenario=sc)
