"""Ground effect in both engines: a low pass at 0.3 span, in-house and JSBSim agree as in free air.

The environment option (gna.ground_effect) is written into the exported JSBSim file as functions of
JSBSim's ``aero/h_b-cg-ft``; the free-air file is unchanged.  Measured numbers: docs/ground_effect.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna import units
from gna.aircraft import list_aircraft, load_aircraft
from gna.atmosphere import ISA, Environment
from gna.eom import Controls, State, loads
from gna.ground_effect import GroundEffect
from gna.trim import trim_level
from harness.engines import fly, load_fdm
from harness.engines.jsbsim import export as jx
from harness.engines.jsbsim.fdm import Integrators, prepare
from harness.engines.jsbsim.ground import GROUND_EFFECT_PROPERTIES

AC = load_aircraft("twin-otter")
H = 0.3 * AC.geometry.b  # 5.94 m: a low pass at 0.3 span
V = 45.0
FREE = Environment(ISA())
GE = Environment(ISA(), ground_effect=GroundEffect(elevation=0.0))
#: The cross-engine tolerances of the paper plans (tests/harness/test_cross_engine.py).
POSITION_TOL, ANGLE_TOL = 1e-2, 1e-4


def _difference(env, trim_env, t1=8.0):
    """Fly the level trim of ``trim_env`` at 0.3 span in ``env``, fixed controls; in-house minus JSBSim."""
    t = trim_level(AC, V, altitude=H, env=trim_env)
    x0, u0 = np.array(t.state, dtype=float), [float(v) for v in t.controls]
    runs = fly(("inhouse", "jsbsim"), AC, x0, u0, (0.0, t1), env=env, dt_out=0.05)
    for r in runs.values():
        assert r.status == "completed", r.message
    a, j = runs["inhouse"].df, runs["jsbsim"].df
    pos = float(np.max(np.sqrt((a.x - j.x) ** 2 + (a.y - j.y) ** 2 + (a.z - j.z) ** 2)))
    ang = max(float(np.max(np.abs(a[k] - j[k]))) for k in ("gamma", "chi", "alpha", "beta", "mu"))
    return pos, ang, a, runs


def test_low_pass_at_0p3_span_agrees_as_in_free_air():
    # Trimmed in ground effect and flown in ground effect: both engines hold the height.
    pos_g, ang_g, a_g, runs = _difference(GE, GE)
    pos_f, ang_f, a_f, _ = _difference(FREE, FREE)
    assert float(np.ptp(a_g.z)) < 1e-5  # the in-ground-effect trim holds 0.3 span
    assert "ground effect" in runs["jsbsim"].settings.environment
    assert "ground effect" in runs["inhouse"].settings.environment
    # Free-air trim flown in ground effect (extra lift: it balloons, h/b varies 0.30 -> 0.36) and the
    # ground-effect trim flown in free air (it sinks): a dynamic pass in both environments.
    pos_gd, ang_gd, a_gd, _ = _difference(GE, FREE)
    pos_fd, ang_fd, a_fd, _ = _difference(FREE, GE)
    assert -a_gd.z.iloc[-1] - H > 1.0 and -a_fd.z.iloc[-1] - H < -1.0
    # Same tolerances as free air; measured 4.7e-6 m / 4.7e-6 m (trimmed), 1.9e-4 m / 6.4e-5 m (dynamic).
    for pos, ang in ((pos_g, ang_g), (pos_f, ang_f), (pos_gd, ang_gd), (pos_fd, ang_fd)):
        assert pos <= POSITION_TOL and ang <= ANGLE_TOL
    assert pos_g <= 2 * pos_f + 1e-6 and ang_g <= 2 * ang_f + 1e-8
    assert pos_gd <= 10 * pos_fd + 1e-4


def test_jsbsim_lift_change_matches_formula():
    t = trim_level(AC, V, altitude=H, env=FREE)
    x0 = np.array(t.state, dtype=float)
    fdm, problems, capture = load_fdm(jx.aircraft_xml(AC, jx.FlatPlanet(h_ref=H), GE.ground_effect), AC.id)
    assert problems == []
    with capture:
        prepare(fdm, Integrators(), 1 / 480, GE, x0)
        for prop, v in zip(jx.THRUST_PROPERTIES, (0.5 * t.values["F"] / units.LBF,) * 2):
            fdm[prop] = v
        for k, prop in jx.CONTROL_PROPERTIES.items():
            fdm[prop] = t.values[k]
        assert fdm.run_ic()
        got = {k: fdm[p] for k, p in GROUND_EFFECT_PROPERTIES.items()}
        CL, CD = fdm[jx.COEFFICIENT_PROPERTIES["CL"]], fdm[jx.COEFFICIENT_PROPERTIES["CD"]]
    assert capture.problems() == []
    A = AC.geometry.b**2 / AC.geometry.S
    # JSBSim's aero/h_b-cg-ft is the in-house h/b up to the altitude quantisation of the 1e11 ft planet
    # (8 ulp of its radius: 3.7e-5 ft); measured 3.0e-8 (0.6 micrometre).
    assert got["h_b"] == pytest.approx(0.3, abs=8 * np.spacing(jx.PLANET_RADIUS_FT) * units.FT / AC.geometry.b)
    x2 = (16 * got["h_b"]) ** 2
    phi = x2 / (1 + x2)
    K = 2 * math.pi / (math.pi * 0.8 * A)
    kL = (1 + K) / (1 + K * phi)
    assert got["phi"] == pytest.approx(phi, rel=1e-14)
    assert got["k_L"] == pytest.approx(kL, rel=1e-14)
    assert got["CL"] == pytest.approx(kL * CL, rel=1e-14)
    assert got["CD"] == pytest.approx(CD + (phi * kL * kL - 1) * CL * CL / (math.pi * 0.8 * A), rel=1e-12)
    ld = loads(AC, GE, State(*x0), Controls(*t.controls))
    assert ld.force_coeffs.CL == pytest.approx(got["CL"], rel=1e-8)  # measured 1.6e-9 (the h quantisation)


def test_free_air_export_unchanged_and_ground_file_differs_only_by_ground_effect():
    for name in list_aircraft():
        a = load_aircraft(name)
        assert jx.aircraft_xml(a) == jx.aircraft_xml(a, ground_effect=None)
    free, ge = jx.aircraft_xml(AC), jx.aircraft_xml(AC, ground_effect=GroundEffect(elevation=12.5))
    assert "h_b-cg-ft" not in free and "aero/h_b-cg-ft" in ge
    assert "<property> aero/gflat/ground/CL </property>" in ge
    assert "<property> aero/gflat/CL </property>" in ge


def test_source_engine_refuses_ground_effect():
    from gna.errors import InputError
    from harness.engines.jsbsim.source import JSBSimSourceEngine

    with pytest.raises(InputError, match="ground effect"):
        JSBSimSourceEngine().simulate(
            load_aircraft("f16-jsbsim"),
            [1.0, 0, 0, 0, 0],
            (0, 1),
            np.array([0, 0, -H, 150.0, 0, 0, 0.05, 0, 0, 0, 0, 0]),
            env=GE,
        )
