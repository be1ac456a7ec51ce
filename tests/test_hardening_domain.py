"""Hardening, third round, kind 5: one flight-domain definition shared by trim and both engines.

The altitude enters the domain with the atmosphere model's validity (the ISA's -2 to 20 km,
:func:`gna.trajectory.domain_bounds`): trim refuses outside it, both engines refuse to start outside it
and stop alike when a run leaves it (the message names the time, the variable and the value); a
non-finite control after t0 stops the in-house engine as it stops JSBSim.  Real JSBSim.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.atmosphere import ISA_RANGE, ConstantDensity, Environment
from gna.errors import DomainError, InputError
from gna.trajectory import DOMAIN, domain_bounds, domain_violation
from gna.trim import trim_level
from harness.engines import InHouseEngine, JSBSimEngine

ENGINES = (InHouseEngine(), JSBSimEngine())


@pytest.fixture(scope="module")
def f16():
    return load_aircraft("f16c")


def _trimmed(aircraft, altitude, speed=150.0):
    tr = trim_level(aircraft, speed, altitude)
    return np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)


def _pitch(u0, delta):
    def controls(t):
        u = u0.copy()
        u[3] += delta if t > 0.2 else 0.0
        return u

    return controls


def test_k5_the_domain_carries_the_atmosphere_range_and_trim_uses_it():
    isa = domain_bounds(Environment())
    assert (isa.h_min, isa.h_max) == ISA_RANGE and "ISA" in isa.atmosphere
    assert domain_bounds(None) == isa
    free = domain_bounds(Environment(ConstantDensity(1.0)))  # a constant density holds at any altitude
    assert (free.h_min, free.h_max) == (-math.inf, math.inf)
    assert (DOMAIN.h_min, DOMAIN.h_max) == (-math.inf, math.inf)  # the chart alone
    state = [0.0, 0.0, -20500.0, 150.0, 0.0, 0.0, 0.05, 0.0, 0.0, 0.0, 0.0, 0.0]
    text = domain_violation(3.0, state, isa)
    assert text == (
        "left the physical domain at t = 3 s: altitude above 20000 m, the upper end of the ISA atmosphere "
        "model (altitude = 20500 m, z = -20500 m)"
    )
    assert domain_violation(3.0, state, free) is None
    for altitude in (ISA_RANGE[0] - 1.0, ISA_RANGE[1] + 1.0):
        with pytest.raises(DomainError, match="outside the ISA model"):
            trim_level(load_aircraft("f16c"), 150.0, altitude)


@pytest.mark.parametrize("altitude", [25000.0, -5000.0])
def test_k5_both_engines_refuse_to_start_outside_the_atmosphere_alike(f16, altitude):
    x0, u0 = _trimmed(f16, 3000.0)
    x0[2] = -altitude
    messages = []
    for engine in ENGINES:
        with pytest.raises(InputError) as exc:
            engine.simulate(f16, u0, (0.0, 1.0), x0, dt_out=0.1)
        messages.append(str(exc.value))
    assert messages[0] == messages[1]
    assert f"(altitude = {altitude:g} m, z = {-altitude:g} m)" in messages[0] and "at t = 0 s" in messages[0]


@pytest.mark.parametrize(
    "altitude, speed, delta, words",
    [(-1900.0, 150.0, 0.05, "altitude below -2000 m"), (19900.0, 300.0, -0.02, "altitude above 20000 m")],
    ids=["dive-below-2-km", "climb-above-20-km"],
)
def test_k5_both_engines_stop_alike_when_a_run_leaves_the_atmosphere(f16, altitude, speed, delta, words):
    x0, u0 = _trimmed(f16, altitude, speed)
    runs = {e.name: e.simulate(f16, _pitch(u0, delta), (0.0, 60.0), x0, dt_out=0.1) for e in ENGINES}
    for name, r in runs.items():
        assert r.status == "domain", (name, r.status, r.message)
        assert words in r.message and "the ISA atmosphere model (altitude = " in r.message
        assert r.t_end < 60.0
    ends = [r.t_end for r in runs.values()]
    assert abs(ends[0] - ends[1]) < 0.5  # the same crossing, located within JSBSim's output step


def test_k5_a_non_finite_control_after_t0_stops_both_engines_alike(f16):
    x0, u0 = _trimmed(f16, 3000.0)

    def nan_eta(t):
        u = u0.copy()
        if t > 1.0:
            u[1] = math.nan
        return u

    runs = {e.name: e.simulate(f16, nan_eta, (0.0, 3.0), x0, dt_out=0.1) for e in ENGINES}
    for name, r in runs.items():
        assert r.status == "domain", name
        assert r.message.startswith("non-finite control at t = 1") and "(eta = nan)" in r.message, r.message
        assert r.t_end == pytest.approx(1.0, abs=0.01)
        assert np.isfinite(r.df["eta"].to_numpy()).all()  # no NaN row kept
