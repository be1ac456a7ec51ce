"""Conformance of every registered engine: one suite, parametrized over the registry.

A new simulator is one folder under ``harness/engines/`` plus one registry line; these tests then
run over it: schema, trim hold, a controller with an integral state, the divergence message and
the recorded settings.  The last test flies the same 1-state controller on the in-house engine and
JSBSim and asks for the open-loop agreement (``DEFAULT_TOLERANCES`` over 10 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.trajectory import COLUMNS, UNITS, RunSettings
from gna.trim import trim_level
from harness.engines import Engine, JSBSimEngine, engine_names, get_engine
from harness.metrics import difference_table

ENGINES = engine_names()
ANGLES = ("gamma", "chi", "alpha", "beta", "mu")

#: Trim hold over 3 s: |deviation from straight level flight| bounds (position m, V m/s, angles rad).
TRIM_HOLD = (1e-4, 1e-5, 1e-7)
#: JSBSim's rotating WGS84 Earth (Coriolis, centrifugal change of g, J2) leaves the flat-earth trim:
#: measured 0.16 m, 9e-3 m/s, 7e-4 rad in 3 s at the equator (docs/jsbsim.md section 5).
TRIM_HOLD_ROTATING_EARTH = (0.5, 3e-2, 3e-3)


#: Engines that fly another physics than the GNA set (JSBSim's own aircraft a set was fitted from) need
#: such an aircraft; the trim of the fitted set is then not a trim of the flown physics: the drift
#: measures the fit's bias (measured on jsbsim-source: 38 m after 5 s at 195 m/s, 3000 m), not the engine.
SOURCE_ENGINES = {"jsbsim-source": "f16-jsbsim"}
TRIM_HOLD_OTHER_PHYSICS = (50.0, 3.0, 0.1)


def _trimmed(aircraft_id):
    a = load_aircraft(aircraft_id)
    tr = trim_level(a, 150.0, 3000.0)
    return a, np.array(tr.state, dtype=float), np.array(tr.controls, dtype=float)


@pytest.fixture(scope="module")
def f16():
    return _trimmed("f16c")


@pytest.fixture(scope="module")
def f16_source():
    return _trimmed("f16-jsbsim")


@pytest.fixture
def craft(request, f16, f16_source):
    """The aircraft, trim state and trim controls an engine of the registry is tested with."""
    return f16_source if request.node.callspec.params["name"] in SOURCE_ENGINES else f16


@dataclass(frozen=True)
class AltitudeHold:
    """PI altitude hold with one integral state ``I_z = integral of (z - z_ref) dt`` [m s].

    Elevator ``d_dm = kp (z - z_ref) + ki I_z - kg gamma - kq q`` (positive dm pitches down for this
    sign of the gains) and a proportional speed hold on thrust.
    """

    z_ref: float
    V_ref: float
    kp: float = -2e-3
    ki: float = -4e-4
    kg: float = -0.5
    kq: float = -0.3
    kv: float = 2000.0
    n_states = 1
    state_names = ("I_z",)

    def initial_state(self, t0, x0):
        return np.zeros(1)

    def derivative(self, t, x, xc):
        return np.array([x[2] - self.z_ref])

    def output(self, t, x, xc):
        dm = self.kp * (x[2] - self.z_ref) + self.ki * xc[0] - self.kg * x[4] - self.kq * x[10]
        return np.array([-self.kv * (x[3] - self.V_ref), 0.0, 0.0, dm, 0.0])


def _perturbed(x0):
    x1 = x0.copy()
    x1[2] += 5.0  # 5 m below the reference altitude
    return x1


def test_registry_lists_engines_meeting_the_protocol():
    assert {"inhouse", "jsbsim", "jsbsim-wgs84"} <= set(ENGINES)
    for name in ENGINES:
        e = get_engine(name)
        assert isinstance(e, Engine) and e.name == name


@pytest.mark.parametrize("name", ENGINES)
def test_schema(name, craft):
    a, x0, u0 = craft
    r = get_engine(name).simulate(a, u0, (0.0, 1.0), x0, dt_out=0.1)
    assert r.completed and r.message == ""
    assert list(r.df.columns) == list(COLUMNS)
    assert r.df.index.name == "t" and np.allclose(r.df.index, np.linspace(0.0, 1.0, 11), atol=1e-12, rtol=0)
    assert set(COLUMNS) <= set(UNITS)
    assert np.all(np.isfinite(r.df.to_numpy()))
    assert r.controller_states is None and r.feedback is None  # open loop


@pytest.mark.parametrize("name", ENGINES)
def test_trim_hold(name, craft):
    a, x0, u0 = craft
    r = get_engine(name).simulate(a, u0, (0.0, 3.0), x0, dt_out=0.05)
    assert r.completed
    df, t = r.df, r.df.index.to_numpy()
    pos_tol, v_tol, ang_tol = (
        TRIM_HOLD_ROTATING_EARTH
        if name == "jsbsim-wgs84"
        else TRIM_HOLD_OTHER_PHYSICS
        if name in SOURCE_ENGINES
        else TRIM_HOLD
    )
    straight = np.array([x0[0] + x0[3] * t * math.cos(x0[5]), x0[1] + x0[3] * t * math.sin(x0[5]), x0[2] + 0 * t])
    assert np.max(np.linalg.norm(df[["x", "y", "z"]].to_numpy().T - straight, axis=0)) <= pos_tol
    assert np.max(np.abs(df["V"] - x0[3])) <= v_tol
    for i, v in enumerate(ANGLES):
        assert np.max(np.abs(df[v] - x0[4 + i])) <= ang_tol, v


@pytest.mark.parametrize("name", ENGINES)
def test_controller_with_an_integral_state(name, craft):
    a, x0, u0 = craft
    c = AltitudeHold(float(x0[2]), float(x0[3]))
    r = get_engine(name).simulate(a, u0, (0.0, 10.0), _perturbed(x0), controller=c, dt_out=0.05)
    assert r.completed, r.message
    t = r.df.index.to_numpy()
    # The state is reported on the output grid and is the integral of the altitude error.
    assert list(r.controller_states.columns) == ["I_z"] and np.array_equal(r.controller_states.index, t)
    err = r.df["z"].to_numpy() - c.z_ref
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (err[1:] + err[:-1]) * np.diff(t))])
    tol = 1e-3 if name == "jsbsim-wgs84" else 1e-4
    assert np.max(np.abs(r.controller_states["I_z"].to_numpy() - integral)) <= tol * np.max(np.abs(integral)) + 1e-3
    # Applied controls = reference + feedback, feedback columns are the controls'.
    assert list(r.feedback.columns) == list(CONTROL_NAMES)
    np.testing.assert_allclose(r.df["dm"], u0[3] + r.feedback["dm"], rtol=0, atol=1e-12)
    if name not in SOURCE_ENGINES:  # F is the thrust the source's engine delivers, not the command
        np.testing.assert_allclose(r.df["F"], u0[0] + r.feedback["F"], rtol=1e-15, atol=1e-9)
    assert abs(r.feedback["dm"].iloc[0]) > 1e-3  # the feedback acted
    if name in SOURCE_ENGINES:
        return  # other physics: the hold's gains were chosen for the f16c; its return is not asserted
    # The hold brings the aircraft back to the reference altitude (measured: crosses it at 4.25 s,
    # overshoots to -5.1 m at 8.2 s, -3.9 m at 10 s: a slow, bounded integral loop, enough for a conformance check).
    assert np.any(err[t < 5.0] < 0.0) and np.max(np.abs(err)) < 6.0


@pytest.mark.parametrize("name", ENGINES)
def test_divergence_stops_with_a_message_and_keeps_the_partial_result(name, craft):
    a, x0, u0 = craft

    def nan_after_half_second(t):
        u = u0.copy()
        if t > 0.5:
            u[3] = float("nan")
        return u

    r = get_engine(name).simulate(a, nan_after_half_second, (0.0, 2.0), x0, dt_out=0.05)
    assert r.status == "domain"
    assert "t = 0.5" in r.message and "dm = nan" in r.message, r.message
    assert 0.45 <= r.t_end <= 0.5 + 1e-9 and r.df.index[-1] == pytest.approx(r.t_end)
    assert len(r.df) >= 10 and np.all(np.isfinite(r.df[list(STATE_NAMES)].to_numpy()))


@pytest.mark.parametrize("name", ENGINES)
def test_recorded_settings(name, craft):
    a, x0, u0 = craft
    e = get_engine(name)
    opened = e.simulate(a, u0, (0.0, 0.5), x0, dt_out=0.1)
    closed = e.simulate(a, u0, (0.0, 0.5), x0, dt_out=0.1, controller=AltitudeHold(float(x0[2]), float(x0[3])))
    for r in (opened, closed):
        s = r.settings
        assert isinstance(s, RunSettings) and s.engine == name == s["engine"]
        assert s.method is not None or s.dt is not None  # a named integrator or a fixed step
        assert s.environment and s.g == pytest.approx(9.80665)
        assert dict(s)["engine"] == name and s.as_dict() == dict(s)
    assert opened.settings.controller is None and opened.settings.controller_scheme is None
    assert closed.settings.controller and closed.settings.controller_scheme and closed.settings.controller_states == 1


def test_one_state_controller_agrees_across_engines_as_open_loop(f16):
    a, x0, u0 = f16
    c = AltitudeHold(float(x0[2]), float(x0[3]))
    x1 = _perturbed(x0)
    runs = {n: get_engine(n).simulate(a, u0, (0.0, 10.0), x1, controller=c) for n in ("inhouse", "jsbsim")}
    t = difference_table(runs["inhouse"], runs["jsbsim"])
    assert t.passed, t.format()
    # Measured: 6.5e-5 m, 2.3e-6 m/s, 9e-8 rad.
    assert t.row("position").max_abs <= 1e-3 and max(t.row(v).max_abs for v in ANGLES) <= 1e-6
    dI = runs["jsbsim"].controller_states["I_z"] - runs["inhouse"].controller_states["I_z"]
    assert np.max(np.abs(dI)) <= 1e-3  # measured 1.1e-4 m s (I_z ~ 7 m s)
    assert "AB2" in runs["jsbsim"].settings.controller_scheme
    assert "DOP853" in runs["inhouse"].settings.controller_scheme


def test_a_coarser_controller_rate_is_held_and_recorded(f16):
    a, x0, u0 = f16
    c = AltitudeHold(float(x0[2]), float(x0[3]))
    x1 = _perturbed(x0)
    ref = get_engine("inhouse").simulate(a, u0, (0.0, 10.0), x1, controller=c)
    r = JSBSimEngine(controller_dt=1 / 120).simulate(a, u0, (0.0, 10.0), x1, controller=c)
    s = r.settings
    assert s.controller_dt == pytest.approx(4 * s.dt) and "every 4 steps" in s.controller
    fb = r.feedback["dm"].to_numpy()
    # Held between updates: with outputs every 10 steps, consecutive samples come from distinct updates,
    # but the feedback is piecewise constant on the step grid (first order in the controller step).
    assert np.all(np.isfinite(fb))
    t = difference_table(ref, r)
    assert t.row("position").max_abs <= 1e-2, t.format()  # measured 4.6e-3 m (ZOH: first order)
