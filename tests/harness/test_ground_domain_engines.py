"""Both engines stop a flight that reaches the ground when ground effect is on (no ground contact is modelled).

A level trim 3 m above the ground, thrust cut: the aircraft sinks into the ground at t = 4.33 s.  With ground
effect the run ends there with status "domain" (in-house: the crossing located by the integrator's dense
output; JSBSim: the first step at or below it); in free air there is no ground and the same flight completes.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.atmosphere import ISA, Environment
from gna.errors import InputError
from gna.ground_effect import GroundEffect
from gna.simulate import simulate
from gna.trim import trim_level
from harness.engines import fly

AC = load_aircraft("twin-otter")
GE = Environment(ISA(), ground_effect=GroundEffect(elevation=0.0))
FREE = Environment(ISA())
TEXT = "height above the ground at or below 0 (ground at 0 m altitude; no ground contact is modelled) (h = "


def _glide():
    t = trim_level(AC, 45.0, altitude=3.0, env=GE)
    u = [float(v) for v in t.controls]
    u[0] = 0.0  # thrust cut: it sinks
    return np.array(t.state, dtype=float), u


def test_flight_into_the_ground_stops_on_both_engines():
    x0, u = _glide()
    runs = fly(("inhouse", "jsbsim"), AC, x0, u, (0.0, 10.0), env=GE, dt_out=0.05)
    for name, r in runs.items():
        assert r.status == "domain", (name, r.message)
        m = re.match(r"left the physical domain at t = ([0-9.]+) s: " + re.escape(TEXT) + r"(\S+) m, z = ", r.message)
        assert m, r.message
        t_hit, h = float(m.group(1)), float(m.group(2))
        assert 4.2 < t_hit < 4.45 and -0.01 < h <= 0.0, r.message
        assert float(-r.df.z.iloc[-1]) > -1e-9  # nothing kept below the ground
    # The in-house engine locates the crossing (h = 0 to 1e-12 m); JSBSim stops at its first step there.
    assert abs(runs["inhouse"].t_end - 4.3276) < 1e-3
    assert runs["jsbsim"].t_end <= runs["inhouse"].t_end


def test_free_air_has_no_ground():
    x0, u = _glide()
    runs = fly(("inhouse", "jsbsim"), AC, x0, u, (0.0, 6.0), env=FREE, dt_out=0.05)
    for r in runs.values():
        assert r.status == "completed" and float(-r.df.z.iloc[-1]) < -5.0


def test_initial_state_below_the_ground_is_refused():
    x0, u = _glide()
    x0[2] = 0.5  # 0.5 m below the ground
    with pytest.raises(
        InputError,
        match="initial state is outside the physical domain: left the physical domain "
        "at t = 0 s: height above the ground at or below 0",
    ):
        simulate(AC, u, (0.0, 1.0), x0, env=GE)
