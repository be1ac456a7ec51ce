"""``gflat fit jsbsim NAME`` with its defaults (real JSBSim): surfaces from the flight-control system, the
alpha/beta box within the tables, the engines measured; an aircraft the model cannot represent in one line."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from gna.aircraft import load_aircraft
from gna.fit.sources import jsbsim_xml as jx
from gna.fit.sources.jsbsim_aero import JSBSimAeroSource
from gna.fit.sources.jsbsim_engines import _time_constant, measure_engines
from harness.cli import main

pytest.importorskip("jsbsim")


@pytest.mark.parametrize("name", ["c172x", "737", "f15"])
def test_the_default_fit_needs_no_option(name, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["fit", "jsbsim", name, "--out", f"{name}.toml"]) == 0
    ac = load_aircraft(str(tmp_path / f"{name}.toml"))
    doc = tomllib.loads((tmp_path / f"{name}.toml").read_text())
    src = JSBSimAeroSource(name)
    # the fit's box is the default one clipped to the tables' data, recorded as the aircraft's validity box
    lo, hi = src.envelope.get("alpha", (-math.inf, math.inf))
    assert max(math.radians(-5), lo) == pytest.approx(ac.envelope.alpha_min, abs=1e-9)
    assert min(math.radians(20), hi) == pytest.approx(ac.envelope.alpha_max, abs=1e-9)
    if src.mach_range is not None:
        assert (ac.envelope.mach_min, ac.envelope.mach_max) == pytest.approx(src.mach_range)
        assert src.mach_range[0] <= src.mach
    # the regenerating command names the defaults it used
    assert f"--mach {src.mach:g} --altitude 1000" in doc["provenance"]["regenerate"]
    # engines: a lag and the thrust line's offset below the CG, as the JSBSim file places it
    assert ac.propulsion.thrust_lag > 0
    thr = jx.engines(src._xml)[0]
    assert ac.propulsion.thrust_line_offset == pytest.approx((src.cg_in[2] - thr.z) * 0.0254, rel=1e-3)
    if name == "c172x":  # piston engine and propeller: rated against speed, torque measured
        assert src.surface_map["dl"] == ("fcs/effective-aileron-pos", -1.0)
        assert len(ac.propulsion.thrust_curve) == 7 and ac.propulsion.torque_arm != 0
        assert ac.propulsion.max_thrust == pytest.approx(max(t for _, t in ac.propulsion.thrust_curve))
    else:
        assert ac.propulsion.thrust_curve == () and ac.propulsion.torque_arm == 0.0


@pytest.mark.parametrize(
    ("name", "why"),
    [
        ("T38", "read fcs/elevator-pos-norm, a normalised elevator position"),
        ("F450", "no elevator property (fcs/elevator-pos-rad) and none that the elevator command"),
        ("wrightFlyer1903", "the aileron command fcs/aileron-cmd-norm moves 2 properties"),
    ],
)
def test_an_aircraft_it_cannot_represent_is_one_line(name, why, tmp_path, capsys):
    assert main(["fit", "jsbsim", name, "--out", str(tmp_path / "x.toml")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert f"JSBSim {name} is not representable: " in err and why in err
    assert not (tmp_path / "x.toml").exists()


def test_the_engine_measurement_against_jsbsim_run_directly():
    src = JSBSimAeroSource("c172x")
    m = measure_engines(src)
    # The rating at the reference speed: the same engine run 20 s at full throttle, state held, by hand.
    from gna.fit.sources.jsbsim_aero import load_model

    fdm, _ = load_model(src.model, src.aircraft_dir, src.root)
    fdm.set_dt(1 / 120)
    fdm["simulation/models/FGFCS/enabled"] = 0
    fdm["ic/h-sl-ft"] = 1000 / 0.3048
    fdm["ic/u-fps"] = src.V_fps
    fdm.run_ic()
    fdm["simulation/models/FGPropagate/enabled"] = 0
    fdm["propulsion/set-running"] = -1
    fdm["fcs/throttle-pos-norm[0]"] = fdm["fcs/mixture-pos-norm[0]"] = 1.0
    for _ in range(2400):
        fdm.run()
    assert m.thrust[4] == pytest.approx(fdm["propulsion/engine[0]/thrust-lbs"] * 4.4482216152605, rel=0.01)
    # a propeller loses thrust with speed beyond the reference speed
    assert m.thrust[-1] < m.thrust[5] < m.thrust[4]
    assert 0.2 < m.lag < 5.0


def test_the_time_constant_of_a_first_order_step():
    t = np.arange(0, 10, 0.01)
    T = 100 + 50 * (1 - np.exp(-t / 0.8))
    assert _time_constant(t, T, 100.0, 150.0) == pytest.approx(0.8, abs=1e-4)
    assert _time_constant(t, np.full_like(t, 5.0), 5.0, 5.0) == 0.0
