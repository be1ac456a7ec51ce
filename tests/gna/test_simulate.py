"""Simulation: DataFrame output, domain exits with partial results, envelope warnings."""

from __future__ import annotations

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.atmosphere import Environment
from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.errors import InputError
from gna.simulate import simulate
from gna.trim import trim_level


@pytest.fixture(scope="module")
def f16_trim():
    a = load_aircraft("f16c")
    return a, trim_level(a, 152.4, 3048.0)


def test_trimmed_flight_stays_trimmed(f16_trim):
    a, t = f16_trim
    r = simulate(
        a,
        np.array(t.controls, dtype=float),
        (0.0, 10.0),
        np.array(t.state, dtype=float),
        env=Environment.constant(3048.0),
    )
    assert r.completed and r.message == ""
    df = r.df
    assert list(df.columns[:17]) == list(STATE_NAMES) + list(CONTROL_NAMES)
    assert df.index.name == "t" and df.index[-1] == pytest.approx(10.0)
    np.testing.assert_allclose(df["V"], 152.4, rtol=1e-9)
    np.testing.assert_allclose(df["x"].iloc[-1], 1524.0, rtol=1e-9)
    np.testing.assert_allclose(df["nz"], np.cos(t.values["alpha"]), rtol=1e-7)
    assert {"qbar", "rho", "nx", "ny", "nz", "X", "Y", "Z", "L", "M", "N", "CL"} <= set(df.columns)
    assert r.settings["method"] == "DOP853" and r.settings["rtol"] == 1e-10


def test_domain_exit_keeps_partial_result(f16_trim):
    """Full nose-down elevator and no thrust: the dive reaches cos(gamma) = 0 or leaves the domain."""
    a, t = f16_trim
    u = np.array(t.controls, dtype=float)
    u[0], u[3] = 0.0, 0.4
    r = simulate(a, u, (0.0, 60.0), np.array(t.state, dtype=float))
    assert r.status == "domain"
    assert "t = " in r.message and "partial result kept" in r.message or "non-finite" in r.message
    assert r.df.index[-1] == pytest.approx(r.t_end)
    assert 0 < r.t_end < 60.0
    assert np.all(np.isfinite(r.df[list(STATE_NAMES)].to_numpy()))


def test_speed_zero_event():
    a = load_aircraft("a7")
    t = trim_level(a, 150.0, 1000.0)
    x0 = np.array(t.state, dtype=float)
    x0[4] = 1.4  # almost vertical climb, no thrust: speed decays to zero or gamma reaches pi/2
    r = simulate(a, [0.0, 0.0, 0.0, float(t.values["dm"]), 0.0], (0.0, 60.0), x0)
    assert r.status == "domain" and ("V" in r.message or "gamma" in r.message)


def test_envelope_warning(f16_trim):
    a, t = f16_trim
    u = np.array(t.controls, dtype=float)
    u[3] = -0.5
    r = simulate(a, u, (0.0, 20.0), np.array(t.state, dtype=float))
    assert any(
        w.startswith("control dm beyond its limit 25.0 deg from t = 0 to") and "worst" in w for w in r.warnings
    ), r.warnings


def test_simple_model_and_callable_controls(f16_trim):
    a, t = f16_trim
    u0 = np.array(t.controls, dtype=float)
    r = simulate(
        a,
        lambda tt: u0 + np.array([0, 0, 0.01 * np.sin(tt), 0, 0]),
        (0.0, 5.0),
        np.array(t.state, dtype=float),
        model="simple",
        dt_out=0.5,
    )
    assert r.completed and len(r.df) == 11
    assert r.df["dl"].iloc[2] == pytest.approx(u0[2] + 0.01 * np.sin(1.0))


def test_controller_correction_applied(f16_trim):
    a, t = f16_trim
    u0 = np.array(t.controls, dtype=float)
    r = simulate(
        a,
        u0,
        (0.0, 2.0),
        np.array(t.state, dtype=float),
        controller=lambda tt, x: np.array([0.0, 0.0, 0.0, -0.5 * x[10], 0.0]),
    )
    assert r.completed


def test_bad_inputs(f16_trim):
    a, t = f16_trim
    x0 = np.array(t.state, dtype=float)
    with pytest.raises(InputError, match="initial speed"):
        simulate(a, np.array(t.controls, dtype=float), (0, 1), np.r_[x0[:3], -1.0, x0[4:]])
    with pytest.raises(InputError, match="non-finite"):
        simulate(a, np.array(t.controls, dtype=float), (0, 1), np.r_[x0[:3], np.nan, x0[4:]])
    with pytest.raises(InputError, match="5 values"):
        simulate(a, [1.0, 2.0], (0, 1), x0)
    with pytest.raises(InputError, match="increasing"):
        simulate(a, np.array(t.controls, dtype=float), (1, 0), x0)


def test_nan_control_stops_with_message(f16_trim):
    a, t = f16_trim
    u0 = np.array(t.controls, dtype=float)
    r = simulate(a, lambda tt: u0 if tt < 1.0 else u0 * np.nan, (0.0, 3.0), np.array(t.state, dtype=float))
    assert r.status == "domain" and "non-finite" in r.message and "control" in r.message
    # the failure is bracketed: the valid run up to t = 1 s is kept
    assert 1.0 - 1e-5 <= r.t_end <= 1.0 + 1e-9 and len(r.df) > 10


def test_controller_states_integrated_with_the_aircraft(f16_trim):
    """A 1-state controller: its state is the integral of its derivative, reported with the feedback."""
    from dataclasses import dataclass

    from gna.controller import StatelessController

    a, t = f16_trim
    u0, x0 = np.array(t.controls, dtype=float), np.array(t.state, dtype=float)

    def static(tt, x):
        return np.array([0.0, 0.0, 0.0, -0.5 * x[10], 0.0])

    # The zero-state case keeps the numbers of a plain callable exactly.
    r1 = simulate(a, u0, (0.0, 2.0), x0, controller=static)
    r2 = simulate(a, u0, (0.0, 2.0), x0, controller=StatelessController(static))
    assert np.array_equal(r1.df.to_numpy(), r2.df.to_numpy())
    assert r1.controller_states.shape[1] == 0 and list(r1.feedback.columns) == list(CONTROL_NAMES)

    @dataclass(frozen=True)
    class Ramp:
        """xc' = 1 (a clock); output adds 10 N per second of thrust."""

        n_states = 1

        def initial_state(self, t0, x0):
            return np.array([0.5])

        def derivative(self, t, x, xc):
            return np.array([1.0])

        def output(self, t, x, xc):
            return np.array([10.0 * (xc[0] - 0.5), 0.0, 0.0, 0.0, 0.0])

    r = simulate(a, u0, (0.0, 2.0), x0, controller=Ramp())
    open_loop = simulate(a, lambda tt: u0 + np.array([10.0 * tt, 0, 0, 0, 0]), (0.0, 2.0), x0)
    assert r.completed and r.settings.controller_states == 1 and "DOP853" in r.settings.controller_scheme
    np.testing.assert_allclose(r.controller_states["xc0"], 0.5 + r.df.index.to_numpy(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.feedback["F"], 10.0 * r.df.index.to_numpy(), rtol=0, atol=1e-10)
    np.testing.assert_allclose(
        r.df[list(STATE_NAMES)].to_numpy(), open_loop.df[list(STATE_NAMES)].to_numpy(), rtol=1e-8, atol=1e-6
    )


def test_a_chattering_feedback_stops_as_stalled_instead_of_creeping():
    """A bang-bang pitch feedback on q (a right-hand side switching at every step) used to keep DOP853
    creeping for hours (a dispersed campaign sample did the same through the tracking feedback's anti-windup)."""
    from gna.aircraft import load_aircraft
    from gna.simulate import simulate
    from gna.trim import trim_level

    a = load_aircraft("f16c")
    tr = trim_level(a, 150.0, 3000.0)
    x0, u0 = np.array(tr.state, float), np.array(tr.controls, float)
    r = simulate(a, u0, (0.0, 20.0), x0, controller=lambda t, x: np.array([0, 0, 0, 0.05 * np.sign(x[10]), 0]))
    assert r.status == "failed" and "stalled" in r.message and r.t_end < 1.0
    assert len(r.df) >= 1 and np.all(np.isfinite(r.df[["V", "alpha"]].to_numpy()))
