"""JSBSim aerodynamics through JSBSim: set-up, conventions, alpha-dot removal, envelope, vehicle data."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gna import units
from gna.aero import AeroState
from gna.errors import InputError, UnknownAircraftError
from gna.fit.sources.jsbsim_aero import JSBSimAeroSource, vehicle_sections


@pytest.fixture(scope="module")
def f4n():
    return JSBSimAeroSource("F4N", mach=0.6, altitude=10000 * units.FT)


def _state(**kw):
    base = dict(alpha=math.radians(4.0), beta=0.0, phat=0.0, qhat=0.0, rhat=0.0, dl=0.0, dm=0.0, dn=0.0)
    base.update(kw)
    return AeroState(**base)


def test_unknown_aircraft_names_the_available_ones():
    with pytest.raises(UnknownAircraftError, match="unknown JSBSim aircraft 'NoSuchPlane'.*F4N.*f16"):
        JSBSimAeroSource("NoSuchPlane", mach=0.5, altitude=1000.0)


def test_configuration_surfaces_and_removed_terms(f4n):
    assert f4n.surface_map == {
        "dm": ("fcs/elevator-pos-rad", 1.0),
        "dl": ("fcs/left-aileron-pos-rad", -1.0),
        "dn": ("fcs/rudder-pos-rad", 1.0),
    }
    assert f4n.configuration["gear/gear-pos-norm"] == 0.0 and "systems/BLC/active" in f4n.configuration
    assert [f.name for f in f4n.removed] == ["aero/coefficient/Cmadot"]
    assert f4n.V_ref == pytest.approx(0.6 * 1077.40 * units.FT, rel=1e-4)


def test_state_is_imposed_exactly(f4n):
    st = _state(beta=0.1, phat=0.05, qhat=0.01, rhat=-0.03, dl=0.1, dm=-0.05, dn=0.08)
    f4n.coefficients(st)
    fdm = f4n._fdm
    assert fdm["aero/alpha-rad"] == pytest.approx(st.alpha, abs=1e-13)
    assert fdm["aero/beta-rad"] == pytest.approx(0.1, abs=1e-13)
    assert fdm["velocities/mach"] == pytest.approx(0.6, abs=1e-12)
    assert fdm["fcs/elevator-pos-rad"] == -0.05 and fdm["fcs/left-aileron-pos-rad"] == -0.1
    assert fdm["gear/gear-pos-norm"] == 0.0


def test_derivatives_of_the_xml_model(f4n):
    """Cm_q = -18 and Cm_de = -0.55 at Mach 0.6 (F4N.xml), once alpha-dot is removed; project signs."""
    h = 1e-4
    c0 = f4n.coefficients(_state())
    dq = (float(f4n.coefficients(_state(qhat=h)).Cm) - float(f4n.coefficients(_state(qhat=-h)).Cm)) / (2 * h)
    assert dq == pytest.approx(-18.0, rel=2e-3)
    de = (float(f4n.coefficients(_state(dm=h)).Cm) - float(f4n.coefficients(_state(dm=-h)).Cm)) / (2 * h)
    assert de == pytest.approx(-0.55, rel=3e-2)
    assert float(f4n.coefficients(_state(dl=0.05)).Cl - c0.Cl) < 0  # project: +dl rolls left
    assert float(f4n.coefficients(_state(dn=0.05)).Cn - c0.Cn) < 0


def test_evaluation_is_repeatable_and_order_independent(f4n):
    rng = np.random.default_rng(3)
    st = AeroState(*(rng.uniform(-0.1, 0.1, 20) for _ in range(8)))
    a = f4n.body_coefficients(st)
    b = f4n.body_coefficients(AeroState(*(v[::-1] for v in st)))[::-1]
    assert np.max(np.abs(a - b)) < 1e-12


def test_lift_axis_alpha_dot_term_is_removed_with_its_moment():
    """c172p has CLadot in the LIFT axis: after removal, Cm and CL do not depend on JSBSim's
    (spurious, state-dependent) alpha-dot; check against the sum of the remaining lift functions."""
    src = JSBSimAeroSource("c172p", mach=0.12, altitude=1000.0)
    assert {f.name for f in src.removed} == {"aero/coefficient/CLadot", "aero/coefficient/Cmadot"}
    st = _state(alpha=math.radians(3.0), qhat=0.01)
    c = src.coefficients(st)
    fdm = src._fdm
    lift = sum(
        fdm[n]
        for n in ("aero/coefficient/CLwbh", "aero/coefficient/CLq", "aero/coefficient/CLDe", "aero/coefficient/CLDf")
    )
    assert float(c.CL) == pytest.approx(lift / (fdm["aero/qbar-psf"] * src.S), rel=1e-9)


def test_envelope_from_tables_and_flight_controls(f4n):
    env = f4n.envelope
    assert env["alpha"] == pytest.approx((-0.2, 1.3))
    assert env["dm"] == pytest.approx((-0.35, 0.30))
    assert env["dl"] == pytest.approx((-0.35, 0.35))
    assert "CLalpha" in f4n.envelope_origin["alpha"]


def test_vehicle_sections(f4n):
    s = vehicle_sections(f4n)
    assert s["engines"]["count"] == 2 and s["engines"]["y_p_in"] == 20.0
    assert s["engines"]["max_thrust_lbf"] == 2 * 15800.0
    assert s["mass"]["mass_slug"] == pytest.approx(41000 / 32.174049, rel=1e-6)
    assert s["geometry"]["x_cg_in"] == s["geometry"]["x_ref_in"]


def test_bad_reference_condition(tmp_path):
    with pytest.raises(InputError, match="reference Mach"):
        JSBSimAeroSource("F4N", mach=-1.0, altitude=0.0)
    misplaced = tmp_path / "plane.xml"
    misplaced.write_text("<fdm_config/>")
    with pytest.raises(InputError, match="JSBSim expects an aircraft file as <dir>/<name>/<name>.xml"):
        JSBSimAeroSource(str(misplaced), mach=0.5, altitude=0.0)


def test_f16_surfaces_are_detected():
    src = JSBSimAeroSource("f16", mach=0.6, altitude=10000 * units.FT)
    assert src.surface_map["dl"] == ("fcs/aileron-pos-rad", -1.0)
    assert src.configuration == {
        "fcs/flaperon-mix-rad": 0.0,
        "fcs/lef-pos-rad": 0.0,
        "fcs/speedbrake-pos-rad": 0.0,
        "gear/gear-pos-norm": 0.0,
    }
    assert src.removed == []
