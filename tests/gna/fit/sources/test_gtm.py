"""GTM database evaluator: NASA's reference points, Kalviste blending, conventions, envelope."""

from __future__ import annotations

import csv
import math
from importlib import resources

import numpy as np
import pytest

from gna.aero import AeroState
from gna.errors import InputError
from gna.fit.design import standard_design
from gna.fit.sources.gtm import SURFACES, GTMAeroDatabase, GTMSource, kalviste

REF = resources.files("gna") / "data" / "sources" / "gtm" / "reference_points.csv"
INPUTS = ("alpha_deg", "beta_deg", "p_rad_s", "q_rad_s", "r_rad_s", "V_ft_s")
OUTPUTS = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")


@pytest.fixture(scope="module")
def db():
    return GTMAeroDatabase.load()


@pytest.fixture(scope="module")
def rows():
    with REF.open() as fh:
        all_rows = list(csv.DictReader(fh))
    # The four damage-case rows exercise the damaged-aircraft path, which the project does not use.
    return [r for r in all_rows if int(r["damage_case"]) == 0]


def test_reference_points_vectorised(db, rows):
    assert len(rows) == 30
    x = {k: np.array([float(r[k]) for r in rows]) for k in (*INPUTS, *SURFACES)}
    c = db.body_coefficients(*(x[k] for k in INPUTS), {k: x[k] for k in SURFACES})
    ref = np.array([[float(r[k]) for k in OUTPUTS] for r in rows])
    assert np.max(np.abs(c - ref)) <= 1e-12


def test_reference_points_one_at_a_time(db, rows):
    for r in rows:
        c = db.body_coefficients(*(float(r[k]) for k in INPUTS), {k: float(r[k]) for k in SURFACES})
        ref = np.array([float(r[k]) for k in OUTPUTS])
        assert np.max(np.abs(c - ref)) <= 1e-12, r["note"]


def test_kalviste_cases_match_the_reference_intermediates(rows):
    for r in rows:
        _, p_osc, q_osc, r_osc, case = kalviste(
            float(r["alpha_deg"]), float(r["beta_deg"]), float(r["p_rad_s"]), float(r["q_rad_s"]), float(r["r_rad_s"])
        )
        assert int(case) == int(r["kalviste_case"]), r["note"]
    cases = {int(r["kalviste_case"]) for r in rows}
    assert cases == {1, 2, 3}


def test_project_conventions_and_signs():
    src = GTMSource()
    a = math.radians(4.0)
    base = AeroState(a, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    body = src.body_coefficients(base)
    c = src.coefficients(base)
    assert float(c.CL) == pytest.approx(body[0] * math.sin(a) - body[2] * math.cos(a), abs=1e-15)
    assert float(c.CD) == pytest.approx(-(body[0] * math.cos(a) + body[2] * math.sin(a)), abs=1e-15)
    assert 0.3 < float(c.CL) < 0.7 and 0.0 < float(c.CD) < 0.1
    d = math.radians(5.0)
    assert float(src.coefficients(base._replace(dl=d)).Cl - c.Cl) < 0  # right aileron down rolls left
    assert float(src.coefficients(base._replace(dm=d)).Cm - c.Cm) < 0  # elevator down pitches down
    assert float(src.coefficients(base._replace(dn=d)).Cn - c.Cn) < 0  # rudder left yaws left
    assert float(src.coefficients(base._replace(beta=d)).CY - c.CY) < 0


def test_nondimensional_rates_do_not_depend_on_the_reference_speed():
    st = AeroState(
        np.radians([3.0, 8.0]),
        np.radians([2.0, -5.0]),
        np.array([0.05, -0.02]),
        np.array([0.004, -0.003]),
        np.array([0.03, 0.06]),
        0.0,
        0.0,
        0.0,
    )
    a = GTMSource(V_ref=30.0).body_coefficients(st)
    b = GTMSource(V_ref=90.0).body_coefficients(st)
    assert np.max(np.abs(a - b)) < 1e-12


def test_design_outside_the_database_is_refused():
    src = GTMSource()
    r = {
        "alpha": (-0.05, 1.2),
        "beta": (-0.2, 0.2),
        "phat": (-0.1, 0.1),
        "qhat": (-0.005, 0.005),
        "rhat": (-0.1, 0.1),
        "dl": (-0.3, 0.3),
        "dm": (-0.5, 0.3),
        "dn": (-0.5, 0.5),
    }
    with pytest.raises(InputError, match=r"alpha = 68.75 deg .* outside \[-5, 50\] deg"):
        src.check_design(standard_design(r))
    with pytest.raises(InputError, match="reference speed must exceed 1 kt"):
        GTMSource(V_ref=0.1)


def test_unknown_surface_is_refused(db):
    with pytest.raises(InputError, match="unknown GTM surface 'FLAP'"):
        db.body_coefficients(2.0, 0.0, 0.0, 0.0, 0.0, 120.0, {"FLAP": 1.0})
