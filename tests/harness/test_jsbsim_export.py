"""JSBSim exporter: committed files current, deterministic, loading without warnings, any term structure."""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from gna import units
from gna.aero import AERO_VARIABLES, AeroState, Term, TermTable
from gna.aircraft import Propulsion, list_aircraft, load_aircraft
from harness.cli import main
from harness.engines import load_fdm
from harness.engines.jsbsim import export as jx
from harness.engines.jsbsim import files as jf

AIRCRAFT = list_aircraft()
ROOT = jf.default_root()


@pytest.mark.parametrize("name", AIRCRAFT)
def test_committed_file_is_current(name):
    path = jf.xml_path(ROOT, name)
    assert path.is_file(), f"{path} missing: run 'gflat export-jsbsim --all'"
    assert path.read_bytes() == jx.aircraft_xml(load_aircraft(name)).encode("utf-8"), (
        f"{path} is stale: run 'gflat export-jsbsim --all'"
    )


def test_no_file_for_unknown_aircraft():
    extra = sorted(p.name for p in ROOT.iterdir() if p.is_dir() and p.name not in AIRCRAFT)
    assert not extra, f"aircraft_xml/ holds files of aircraft that no longer exist: {extra}"


def test_cli_reproduces_committed_files_byte_for_byte(tmp_path, capsys):
    assert main(["export-jsbsim", "--all", "--out", str(tmp_path / "out")]) == 0
    for name in AIRCRAFT:
        assert jf.xml_path(tmp_path / "out", name).read_bytes() == jf.xml_path(ROOT, name).read_bytes()
    assert main(["export-jsbsim", "--all", "--out", str(ROOT), "--check"]) == 0
    assert f"{len(AIRCRAFT)} JSBSim file(s) current" in capsys.readouterr().out


def test_cli_check_detects_stale_file_and_errors_are_one_line(tmp_path, capsys):
    name = AIRCRAFT[0]
    assert main(["export-jsbsim", name, "--out", str(tmp_path / "out")]) == 0
    path = jf.xml_path(tmp_path / "out", name)
    path.write_text(path.read_text().replace("<J2> 0 </J2>", "<J2> 0.001 </J2>"))
    capsys.readouterr()
    assert main(["export-jsbsim", name, "--out", str(tmp_path / "out"), "--check"]) == 1
    assert "differs from a fresh export" in capsys.readouterr().err
    assert main(["export-jsbsim"]) == 2
    assert main(["export-jsbsim", "concorde"]) == 2
    err = capsys.readouterr().err
    assert "name the aircraft" in err and "unknown aircraft 'concorde'" in err


def test_output_is_deterministic_and_path_free():
    a = load_aircraft(AIRCRAFT[0])
    text = jx.aircraft_xml(a)
    assert text == jx.aircraft_xml(load_aircraft(AIRCRAFT[0]))
    assert str(Path(__file__).resolve().parents[2]) not in text
    assert a.path not in text


@pytest.mark.parametrize("name", AIRCRAFT)
def test_file_loads_without_warnings_and_units_are_exact(name):
    a = load_aircraft(name)
    text = jf.xml_path(ROOT, name).read_text()
    fdm, problems, capture = load_fdm(text, name)
    assert problems == []
    with capture:
        fdm["ic/u-fps"] = 400.0
        assert fdm.run_ic()
    assert capture.problems() == []
    # JSBSim's own reading of the mass and geometry, converted back with the exact factors.
    assert fdm["inertia/mass-slugs"] * units.SLUG == pytest.approx(a.mass.mass, rel=1e-15)
    assert fdm["metrics/Sw-sqft"] * units.FT2 == pytest.approx(a.geometry.S, rel=1e-15)
    assert fdm["metrics/bw-ft"] * units.FT == pytest.approx(a.geometry.b, rel=1e-15)
    assert fdm["metrics/cbarw-ft"] * units.FT == pytest.approx(a.geometry.cbar, rel=1e-15)
    root = ET.fromstring(text)
    mb = root.find("mass_balance")
    assert mb.get("negated_crossproduct_inertia") == "false"
    for tag, val in (("ixx", a.mass.Ixx), ("iyy", a.mass.Iyy), ("izz", a.mass.Izz), ("ixz", a.mass.Ixz)):
        el = mb.find(tag)
        assert el.get("unit") == "SLUG*FT2"
        assert float(el.text) * units.SLUG_FT2 == pytest.approx(val, rel=1e-15, abs=1e-12)
    cg = mb.find("location")
    assert float(cg.find("x").text) * units.IN == pytest.approx(a.geometry.x_cg, rel=1e-15, abs=1e-15)
    # Only English units, never JSBSim's truncated SI factors.
    assert {e.get("unit") for e in root.iter() if e.get("unit")} <= {
        "FT",
        "FT2",
        "IN",
        "LBS",
        "SLUG*FT2",
        "RAD/SEC",
        "FT3/SEC2",
    }


def test_thrust_geometry_of_a_twin_with_tilted_engines():
    a = load_aircraft(AIRCRAFT[0])
    twin = dataclasses.replace(a, propulsion=Propulsion(count=2, y_p=1.8, epsilon=math.radians(3.0)))
    root = ET.fromstring(jx.aircraft_xml(twin))
    forces = root.find("external_reactions").findall("force")
    assert [f.get("name") for f in forces] == ["engine1", "engine2"]
    for f, sign in zip(forces, (-1.0, 1.0)):
        assert f.get("frame") == "BODY"
        loc = f.find("location")
        assert loc.get("unit") == "IN"
        assert float(loc.find("y").text) == pytest.approx(sign * 1.8 / units.IN, rel=1e-15)
        d = f.find("direction")
        assert (float(d.find("x").text), float(d.find("y").text), float(d.find("z").text)) == pytest.approx(
            (math.cos(math.radians(3.0)), 0.0, -math.sin(math.radians(3.0))), rel=1e-15
        )


def _odd_table():
    """A structure unlike GNA's: empty, single-term and high-power coefficients over every variable."""
    terms, i = [], 1
    rng = np.random.default_rng(7)
    layout = {
        "CD": [(0,) * 8, (2, 0, 0, 0, 0, 0, 0, 0), (0, 2, 0, 0, 0, 0, 0, 0), (0, 0, 0, 0, 0, 0, 2, 0)],
        "CY": [(0, 1, 0, 0, 0, 0, 0, 0)],  # one term
        "CL": [(0,) * 8, (1, 0, 0, 0, 0, 0, 0, 0), (5, 0, 0, 0, 0, 0, 0, 0), (1, 1, 1, 1, 1, 1, 1, 1)],
        "Cl": [],  # no term
        "Cm": [(0,) * 8, (0, 0, 0, 1, 0, 0, 0, 0), (3, 0, 0, 1, 0, 0, 1, 0)],
        "Cn": [(0, 1, 0, 0, 0, 0, 0, 0), (0, 0, 1, 0, 1, 0, 0, 1), (0, 0, 0, 0, 0, 0, 0, 0)],
    }
    for coef, monos in layout.items():
        for m in monos:
            terms.append(Term(i, coef, m, float(rng.uniform(-2, 2))))
            i += 1
    return TermTable(tuple(terms), "test-odd")


def test_any_term_structure_exports_and_evaluates():
    base = load_aircraft(AIRCRAFT[0])
    a = dataclasses.replace(base, id="odd", aero=_odd_table())
    fdm, problems, capture = load_fdm(jx.aircraft_xml(a), a.id)
    assert problems == []
    rng = np.random.default_rng(11)
    worst = 0.0
    with capture:
        for _ in range(25):
            V = rng.uniform(60, 200) / units.FT
            al, be = rng.uniform(-0.2, 0.4), rng.uniform(-0.3, 0.3)
            p, q, r = rng.uniform(-1, 1, 3)
            dl, dm, dn = rng.uniform(-0.3, 0.3, 3)
            fdm["ic/u-fps"] = V * math.cos(al) * math.cos(be)
            fdm["ic/v-fps"] = V * math.sin(be)
            fdm["ic/w-fps"] = V * math.sin(al) * math.cos(be)
            fdm["ic/p-rad_sec"], fdm["ic/q-rad_sec"], fdm["ic/r-rad_sec"] = p, q, r
            fdm["ctrl/delta-l-rad"], fdm["ctrl/delta-m-rad"], fdm["ctrl/delta-n-rad"] = dl, dm, dn
            assert fdm.run_ic()
            g = a.geometry
            Vs = V * units.FT
            ref = a.aero.coefficients(
                AeroState(al, be, p * g.b / (2 * Vs), q * g.cbar / (2 * Vs), r * g.b / (2 * Vs), dl, dm, dn)
            )
            for name, val in zip(("CD", "CY", "CL", "Cl", "Cm", "Cn"), ref):
                got = fdm[jx.COEFFICIENT_PROPERTIES[name]]
                worst = max(worst, abs(got - val) / max(abs(val), 1e-3))
    assert capture.problems() == []
    assert worst <= 1e-12
    assert len(AERO_VARIABLES) == 8
