"""The domain's height test (ground effect only): gna.trajectory.domain_bounds, domain_margins, ground_violation."""

from __future__ import annotations

import math

import numpy as np

from gna.atmosphere import ISA, Environment
from gna.ground_effect import GroundEffect
from gna.trajectory import (
    DOMAIN,
    DOMAIN_TESTS,
    GROUND_TEST,
    domain_bounds,
    domain_margins,
    domain_violation,
    first_domain_violation,
    ground_violation,
)

GE = Environment(ISA(), ground_effect=GroundEffect(elevation=-5.0))
STATE = [0.0, 0.0, 4.0, 50.0, 0.0, 0.0, 0.05, 0.0, 0.0, 0.0, 0.0, 0.0]  # 1 m above a ground at -5 m


def test_free_air_bounds_have_no_height_test_but_the_atmosphere_range():
    free = domain_bounds(None)
    assert free == domain_bounds(Environment(ISA())) and free.ground is None
    assert (free.h_min, free.h_max) == (-2000.0, 20000.0)  # the ISA's validity (kind 5 of issue 24)
    assert DOMAIN.ground is None and DOMAIN_TESTS[GROUND_TEST][0] == "z"
    deep = STATE[:2] + [1e4] + STATE[3:]  # 10 km below sea level: no ground test, but outside the ISA
    assert domain_margins(deep, free)[GROUND_TEST] == math.inf
    assert domain_violation(1.0, deep) is None and ground_violation(1.0, 1e4) is None  # the chart alone
    assert "altitude below -2000 m" in domain_violation(1.0, deep, free)


def test_height_test_with_ground_effect():
    b = domain_bounds(GE)
    assert b.ground == -5.0 and b.V_min == DOMAIN.V_min
    assert domain_margins(STATE, b)[GROUND_TEST] == 1.0
    assert domain_violation(0.0, STATE, b) is None
    below = STATE[:2] + [5.25] + STATE[3:]
    msg = (
        "left the physical domain at t = 2.5 s: height above the ground at or below 0 (ground at -5 m altitude; "
        "no ground contact is modelled) (h = -0.25 m, z = 5.25 m)"
    )
    assert domain_violation(2.5, below, b) == msg == ground_violation(2.5, 5.25, b)
    X = np.array([STATE, STATE, below]).T
    assert first_domain_violation([0.0, 1.0, 2.5], X, b) == msg
    assert first_domain_violation([0.0, 1.0, 2.5], X) is None
