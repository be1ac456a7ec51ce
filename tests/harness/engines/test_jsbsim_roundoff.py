"""JSBSim's inertial-position round-off on the flat-earth sphere, and its correction (harness.engines.jsbsim.roundoff).

A steady climb is the worst case: JSBSim adds the same vertical increment every step to an inertial x of about
1e11 ft, whose doubles are 2^-16 ft apart, so the climb rate flown is the nearest multiple of 2^-16 ft / dt.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gna import units
from gna.aircraft import load_aircraft
from gna.atmosphere import Environment
from gna.trim import trim
from harness.cli import main
from harness.engines import InHouseEngine, JSBSimEngine
from harness.engines.jsbsim.export import PLANET_RADIUS_FT
from harness.engines.jsbsim.roundoff import POSITION_WEIGHTS, PositionRoundoff

KT = 1852.0 / 3600.0


class _FakeJSBSim:
    """JSBSim's position integration in doubles (``FGPropagate::Integrate``), with its exact counterpart."""

    def __init__(self, integrator, dt, r0, velocities):
        self.w = POSITION_WEIGHTS[integrator]
        self.dt, self.vs = dt, velocities
        self.r = list(r0)
        self.exact = [0.0, 0.0, 0.0]  # the increments summed exactly (math.fsum of every term)
        self._terms = [[], [], []]
        self.k = 0
        self.hist = [velocities[0]] * max(len(self.w), 1)  # InitializeDerivatives: the initial velocity

    def step(self):
        self.hist = [self.vs[self.k]] + self.hist[:-1]  # the velocity before the step, pushed first
        for a in range(3):
            inc = self.dt * sum(w * v[a] for w, v in zip(self.w, self.hist))
            self.r[a] += inc  # rounded to the spacing of doubles near r
            self._terms[a].append(inc)
            self.exact[a] = math.fsum(self._terms[a])
        self.k += 1

    def readers(self):
        return [lambda a=a: self.r[a] for a in range(3)], [lambda a=a: self.vs[self.k][a] for a in range(3)]


@pytest.mark.parametrize("integrator", sorted(POSITION_WEIGHTS))
def test_replayed_increments_are_jsbsims_and_the_error_its_rounding(integrator):
    rng = np.random.default_rng(3)
    dt, n = 1.0 / 480.0, 300
    vs = [tuple(v) for v in (np.array([4.92126, 180.0, -3.0]) + 0.5 * rng.standard_normal((n + 1, 3)))]
    fake = _FakeJSBSim(integrator, dt, (PLANET_RADIUS_FT + 984.25, 0.0, 0.0), vs)
    pos, vel = fake.readers()
    rc = PositionRoundoff(pos, vel, integrator, dt)
    for k in range(n):
        fake.step()
        rc.advance()
        if k < 8 or k == n - 1:  # the start-up steps (history still holding v_0) and the end
            d = rc.displacement()
            assert d == pytest.approx(fake.exact, rel=1e-12, abs=1e-12)
            err, r = rc.error()
            truth = [(ri - r0i) - ei for ri, r0i, ei in zip(fake.r, rc.r0, fake.exact)]
            assert err == pytest.approx(truth, abs=1e-11)
    if integrator != "none":
        # The vertical (x) increments are rounded to 2^-16 ft; the horizontal ones, near 0, are not.
        assert abs(err[0]) > 1e-5 and abs(err[1]) < 1e-11 and abs(err[2]) < 1e-11
        assert abs(err[0]) <= n * math.ulp(fake.r[0]) / 2


def test_correct_maps_the_error_to_altitude_latitude_and_longitude():
    R, h = PLANET_RADIUS_FT, 984.25
    r = [R + h, 0.0, 0.0]
    vel = [lambda: 0.0] * 3
    rc = PositionRoundoff([lambda a=a: r[a] for a in range(3)], vel, "AB4", 1.0 / 480.0)
    # JSBSim's position is 2^-5 ft too high, 2^-6 ft too far north and 2^-7 ft too far east of the replayed one
    # (latitude, longitude 0; steps of 2^-16 ft, exact on the sphere).
    up, north, east = 2.0**-5, 2.0**-6, 2.0**-7
    r[:] = [R + h + up, east, north]
    lat, lon, hh = north / (R + h), east / (R + h), h + up
    out = rc.correct([lat, lon, hh, "rest"], R)
    assert out[3] == "rest"
    assert out[2] == h
    assert out[0] == pytest.approx(0.0, abs=1e-20) and out[1] == pytest.approx(0.0, abs=1e-20)
    assert rc.largest == pytest.approx(math.sqrt(up**2 + north**2 + east**2), rel=1e-12)
    with pytest.raises(ValueError, match="no position weights"):
        PositionRoundoff([lambda: 0.0] * 3, vel, "Buss2", 0.01)


@pytest.fixture(scope="module")
def climb():
    """The Twin Otter trimmed at 110 kt climbing at 1.5 m/s from 300 m (constant density: a steady state)."""
    a = load_aircraft("twin-otter")
    env = Environment.constant(300.0)
    V = 110 * KT
    tr = trim(a, {"V": V, "gamma": math.asin(1.5 / V), "beta": 0.0, "chi_dot": 0.0}, altitude=300.0, env=env)
    x0, u0 = np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)
    ref = InHouseEngine().simulate(a, u0, (0.0, 60.0), x0, env=env, dt_out=1.0).df
    return a, env, x0, u0, ref


def test_steady_climb_agrees_with_the_in_house_engine(climb):
    a, env, x0, u0, ref = climb
    raw = JSBSimEngine(compensate_roundoff=False).simulate(a, u0, (0.0, 60.0), x0, env=env, dt_out=1.0)
    fixed = JSBSimEngine().simulate(a, u0, (0.0, 60.0), x0, env=env, dt_out=1.0)
    dz_raw = raw.df["z"].to_numpy() - ref["z"].to_numpy()
    dz = fixed.df["z"].to_numpy() - ref["z"].to_numpy()
    # Uncorrected: the climb flown at 672 quanta of 2^-16 ft / (1/480 s) = 1.500188 m/s instead of 1.5 m/s.
    q = math.ulp(PLANET_RADIUS_FT) / raw.settings.dt * units.FT
    predicted = -60.0 * (q * round(1.5 / q) - 1.5)
    assert predicted == pytest.approx(-0.01125, rel=1e-3)
    assert dz_raw[-1] == pytest.approx(predicted, abs=5e-4)  # -1.144 cm: beyond the 1 cm tolerance
    assert abs(dz).max() < 2e-5  # corrected: 1e-5 m
    assert raw.settings.extra["position_roundoff"] == {"corrected": False, "largest_m": None}
    assert fixed.settings.extra["position_roundoff"]["corrected"] is True
    largest = fixed.settings.extra["position_roundoff"]["largest_m"]
    assert largest == pytest.approx(-dz_raw[-1], rel=0.05)
    for col in ("V", "gamma", "alpha", "q"):  # the dynamics are untouched
        assert np.array_equal(raw.df[col].to_numpy(), fixed.df[col].to_numpy())


def test_the_feedback_sees_the_corrected_position(climb):
    a, env, x0, u0, ref = climb
    seen = []

    def zero(t, x):
        seen.append((t, x[2]))
        return np.zeros(5)

    open_loop = JSBSimEngine().simulate(a, u0, (0.0, 60.0), x0, env=env, dt_out=1.0)
    closed = JSBSimEngine().simulate(a, u0, (0.0, 60.0), x0, env=env, dt_out=1.0, controller=zero)
    np.testing.assert_array_equal(closed.df[["x", "y", "z"]].to_numpy(), open_loop.df[["x", "y", "z"]].to_numpy())
    t_last, z_last = seen[-1]
    assert t_last == pytest.approx(60.0)
    assert z_last == pytest.approx(float(ref["z"].iloc[-1]), abs=2e-5)


def test_the_new_users_climb_scenario_passes(tmp_path, capsys):
    scen = tmp_path / "twin-otter-climb.toml"
    scen.write_text(
        'name = "twin-otter-climb"\naircraft = "twin-otter"\n'
        "[time]\nt0 = 0.0\nt1 = 60.0\nstep = 2.0\n"
        '[flat_outputs]\nx = "110*kt*t"\ny = "0"\nz = "-300.0 - 1.5*t"\nzeta = "beta"\nzeta_value = "0"\neta = "0"\n'
        "[generalized]\nJ = 6\ne = 1\n"
        '[environment]\ndensity = "isa"\n',
        encoding="utf-8",
    )
    rc = main(["compare", str(scen), "--out", str(tmp_path / "out"), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["verdicts"]["engines_agree"]["pass"] is True
    assert out["differences"]["jsbsim"]["max_position_m"] < 2e-3  # 1.148 cm before the correction
