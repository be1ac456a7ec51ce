"""Aircraft catalogue, unit conversion and input validation."""

from __future__ import annotations

import dataclasses
import math

import pytest

from gna import units
from gna.aircraft import Geometry, MassProperties, Propulsion, aircraft_from_dict, list_aircraft, load_aircraft
from gna.errors import InputError, UnknownAircraftError


def test_catalogue_has_published_gna_aircraft():
    names = list_aircraft()
    assert {"f16c", "a7"} <= set(names)
    for n in names:
        a = load_aircraft(n)
        assert a.id == n
        assert a.provenance.get("source") and a.provenance.get("date")


def test_english_units_converted_exactly():
    a = load_aircraft("f16c")
    assert a.mass.mass == pytest.approx(20500 * 0.45359237, rel=1e-15)
    assert a.mass.Ixx == pytest.approx(9496 * 14.593902937206364 * 0.3048**2, rel=1e-14)
    assert a.geometry.S == pytest.approx(300 * 0.09290304, rel=1e-15)
    assert a.geometry.x_ref - a.geometry.x_cg == pytest.approx(0.10 * 11.32 * 0.3048, rel=1e-12)
    assert units.SLUG == pytest.approx(14.593902937206364, rel=1e-15)


def test_unknown_aircraft_lists_known():
    with pytest.raises(UnknownAircraftError) as exc:
        load_aircraft("concorde")
    assert "concorde" in str(exc.value) and "f16c" in str(exc.value)


def test_bad_numbers_refused():
    with pytest.raises(InputError, match="mass must be positive"):
        MassProperties(mass=-1.0, Ixx=1, Iyy=1, Izz=1, Ixz=0)
    with pytest.raises(InputError, match="triangle"):
        MassProperties(mass=1.0, Ixx=1, Iyy=1, Izz=5, Ixz=0)
    with pytest.raises(InputError, match="S must be positive"):
        Geometry(S=0.0, b=1.0, cbar=1.0)
    with pytest.raises(InputError, match="engine count"):
        Propulsion(count=3)


def test_malformed_file_messages(tmp_path):
    good = {
        "id": "x",
        "mass": {"mass_kg": 100.0, "Ixx_kgm2": 10.0, "Iyy_kgm2": 20.0, "Izz_kgm2": 25.0},
        "geometry": {"S_m2": 1.0, "b_m": 2.0, "cbar_m": 0.5},
        "aero": {"terms": [{"coef": "CL", "monomial": "alpha", "value": 5.0}]},
    }
    a = aircraft_from_dict(good)
    assert a.mass.mass == 100.0 and len(a.aero) == 1
    bad = dict(good, mass={"Ixx_kgm2": 10.0, "Iyy_kgm2": 20.0, "Izz_kgm2": 25.0})
    with pytest.raises(InputError, match="missing 'mass'"):
        aircraft_from_dict(bad)
    bad = dict(good, mass=dict(good["mass"], mass_kg=float("nan")))
    with pytest.raises(InputError, match="nan"):
        aircraft_from_dict(bad)
    p = tmp_path / "broken.toml"
    p.write_text("id = [")
    with pytest.raises(InputError, match="not valid TOML"):
        load_aircraft(p)


def test_envelope_violations_named():
    a = load_aircraft("f16c")
    v = a.envelope.violations(math.radians(50.0), 0.0)
    assert v and "alpha" in v[0]
    assert a.envelope.violations(0.1, 0.0) == []
    assert dataclasses.replace(a, name="y").name == "y"


def test_declared_structure_must_have_its_terms(tmp_path):
    import tomllib

    src = load_aircraft("f16c").path
    data = tomllib.loads(open(src, encoding="utf-8").read())
    data["aero"]["terms"] = [t for t in data["aero"]["terms"] if t.get("theta") not in (7, 30)]
    assert data["aero"]["structure"] == "gna45"
    with pytest.raises(InputError, match=r"structure = 'gna45' has 45 terms .* the file gives 43: missing theta 7, 30"):
        aircraft_from_dict(data, where="f16c-44.toml")
    data["aero"]["structure"] = "custom"  # a custom structure may have any terms
    assert len(aircraft_from_dict(data, where="custom.toml").aero) == 43
