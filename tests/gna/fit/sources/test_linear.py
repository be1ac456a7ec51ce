"""Linear derivative models (Twin Otter format)."""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pytest

from gna.aero import AeroState
from gna.errors import InputError
from gna.fit.sources.linear import LinearDerivativeModel, parse_derivative, vehicle_values

CSV = resources.files("gna") / "data" / "sources" / "twin_otter" / "aircraft_dat_clean.csv"


def test_twin_otter_coefficients_by_hand():
    m = LinearDerivativeModel.from_csv(CSV, {})
    a, q, de = math.radians(4.0), 0.01, math.radians(-3.0)
    c = m.coefficients(AeroState(a, 0.02, 0.03, q, -0.01, 0.05, de, -0.04))
    CX = -0.0488 + 0.223 * a + 1.659 * a * a
    CZ = -0.360 - 5.660 * a - 19.97 * q - 0.608 * de
    assert float(c.CD) == pytest.approx(-(CX * math.cos(a) + CZ * math.sin(a)), rel=1e-14)
    assert float(c.CL) == pytest.approx(CX * math.sin(a) - CZ * math.cos(a), rel=1e-14)
    assert float(c.Cm) == pytest.approx(0.040 - 1.310 * a - 34.2 * q - 1.740 * de, rel=1e-14)
    assert float(c.CY) == pytest.approx(-0.6 * 0.02 - 0.2 * 0.03 + 0.4 * -0.01 + 0.15 * -0.04, rel=1e-14)
    assert float(c.Cl) == pytest.approx(
        -0.08 * 0.02 - 0.5 * 0.03 + 0.06 * -0.01 - 0.15 * 0.05 + 0.015 * -0.04, rel=1e-14
    )
    assert float(c.Cn) == pytest.approx(
        0.1 * 0.02 - 0.06 * 0.03 - 0.18 * -0.01 - 0.001 * 0.05 - 0.125 * -0.04, rel=1e-14
    )


def test_vectorised_over_arrays():
    m = LinearDerivativeModel.from_csv(CSV, {})
    a = np.linspace(-0.1, 0.2, 7)
    c = m.coefficients(AeroState(a, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert np.shape(c.CL) == (7,) and np.all(np.diff(c.CL) > 0)


def test_vehicle_rows():
    v = vehicle_values(CSV)
    assert v["Weight"] == (10141.0, "lb") and v["bw"] == (65.0, "ft")


def test_bad_input():
    with pytest.raises(InputError, match="unknown suffix 'zz'"):
        parse_derivative("CZ_zz", 1.0)
    assert parse_derivative("Weight", 1.0) is None
    with pytest.raises(InputError, match="not found"):
        LinearDerivativeModel.from_csv("/nonexistent/model.csv", {})
    d = parse_derivative("Cm_a", -1.0)
    with pytest.raises(InputError, match="given twice"):
        LinearDerivativeModel([d, d], {})
