"""Shared planning fixtures: a small F-16 manoeuvre (fast) used across planner tests."""

from __future__ import annotations

import pytest

from planners.scenario import scenario_from_dict

WEAVE = {
    "name": "f16-weave",
    "aircraft": "f16c",
    "time": {"t0": 0.0, "t1": 30.0, "step": 0.5},
    "flat_outputs": {
        "x": "150*t",
        "y": "200*sin(t/20)",
        "z": "-3000 + 50*sin(t/15)",
        "zeta": "beta",
        "zeta_value": "0",
    },
    "generalized": {"J": 4},
}


def make_scenario(**changes):
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in WEAVE.items()}
    for key, value in changes.items():
        if isinstance(value, dict):
            data.setdefault(key, {}).update(value)
        else:
            data[key] = value
    return scenario_from_dict(data, where="test scenario")


@pytest.fixture(scope="session")
def weave_plan():
    from planners.generalized import plan_scenario

    sc = make_scenario()
    return sc, plan_scenario(sc)
