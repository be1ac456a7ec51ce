import numpy as np
import pytest

from gna.errors import InputError
from gna.piecewise import PiecewisePolynomial


def _pp():
    rng = np.random.default_rng(3)
    return PiecewisePolynomial(np.array([0.0, 0.5, 1.5, 2.0]), rng.normal(size=(3, 5, 4)))


def test_scalar_and_vector_paths_agree_with_the_definition():
    pp = _pp()
    t = np.linspace(0.0, 2.0, 41)
    many = pp.evaluate(t)
    for n, tt in enumerate(t):
        i = min(np.searchsorted(pp.breaks, tt, side="right") - 1, 2)
        s = tt - pp.breaks[i]
        ref = sum(pp.coeffs[i, :, k] * s**k for k in range(4))
        np.testing.assert_allclose(pp(tt), ref, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(many[:, n], ref, rtol=1e-14, atol=1e-14)
        np.testing.assert_array_equal(pp(tt), many[:, n])  # the same Horner sums, bit for bit


def test_derivatives_are_exact():
    pp = _pp()
    t = np.array([0.1, 0.7, 1.9])
    h = 1e-6
    fd = (pp.evaluate(t + h) - pp.evaluate(t - h)) / (2 * h)
    np.testing.assert_allclose(pp.evaluate(t, derivative=1), fd, rtol=1e-7, atol=1e-7)
    assert np.all(pp.evaluate(t, derivative=4) == 0.0)


def test_bad_input_is_refused_with_a_reason():
    with pytest.raises(InputError, match="increase strictly"):
        PiecewisePolynomial(np.array([0.0, 0.0, 1.0]), np.zeros((2, 1, 2)))
    with pytest.raises(InputError, match="shape"):
        PiecewisePolynomial(np.array([0.0, 1.0]), np.zeros((2, 1, 2)))
    with pytest.raises(InputError, match="finite"):
        PiecewisePolynomial(np.array([0.0, 1.0]), np.full((1, 1, 2), np.nan))
    pp = _pp()
    with pytest.raises(InputError, match="outside the span"):
        pp(2.5)
    with pytest.raises(InputError, match="outside the span"):
        pp.evaluate([-1.0])
    pp(2.0 + 1e-12)  # an integrator's round-off at the end time is accepted
