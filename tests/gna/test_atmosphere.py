"""ISA density: standard values, continuity at the tropopause, series across layers."""

from __future__ import annotations

import numpy as np
import pytest

from gna.atmosphere import ISA, ConstantDensity, Environment
from gna.errors import InputError
from planners.series import Series


def test_standard_values():
    isa = ISA()
    # U.S. Standard Atmosphere 1976 (geopotential altitude): 1.2250, 0.36392, 0.088035 kg/m^3
    np.testing.assert_allclose(isa.density(np.array([0.0, 11000.0, 20000.0])), [1.2250, 0.36392, 0.088035], rtol=2e-4)


def test_continuous_at_tropopause():
    isa = ISA()
    assert isa.density(11000.0 - 1e-6) == pytest.approx(isa.density(11000.0 + 1e-6), rel=1e-9)


def test_series_across_the_tropopause_match_pointwise():
    h = Series.variable(np.array([10000.0, 10900.0, 11100.0, 15000.0]), 4)
    rho = ISA().density(h)
    np.testing.assert_allclose(np.real(rho.constant_term), ISA().density(np.real(h.constant_term)), rtol=1e-14)
    d = 1e-3
    fd = (ISA().density(np.real(h.constant_term) + d) - ISA().density(np.real(h.constant_term) - d)) / (2 * d)
    np.testing.assert_allclose(np.real(rho.coeffs[:, 1]), fd, rtol=1e-6)


def test_bad_values_refused():
    with pytest.raises(InputError):
        ConstantDensity(-1.0)
    with pytest.raises(InputError):
        Environment(g=float("nan"))
