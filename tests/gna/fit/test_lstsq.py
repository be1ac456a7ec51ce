"""Least-squares core: exact recovery, statistics, standard errors and singular problems."""

from __future__ import annotations

import numpy as np
import pytest

from gna.aero import AERO_VARIABLES, AeroState, Coefficients, TermTable
from gna.errors import InputError
from gna.fit.lstsq import Samples, SingularFitError, fit_coefficient, fit_table, statistics
from gna.fit.pipeline import gna45_structure


def _states(n, seed=0, fixed=()):
    rng = np.random.default_rng(seed)
    cols = [np.zeros(n) if v in fixed else rng.uniform(-0.3, 0.3, n) for v in AERO_VARIABLES]
    return AeroState(*cols)


def _samples_of(model, state):
    return Samples.from_source(model, state)


def test_recovers_the_parameters_of_a_model_in_the_structure():
    truth = gna45_structure().with_values(np.random.default_rng(1).normal(size=45))
    smp = _samples_of(truth, _states(400, seed=2))
    res = fit_table(
        gna45_structure(),
        {c: smp for c in ("CD", "CY", "CL", "Cl", "Cm", "Cn")},
        {c: {"test": _samples_of(truth, _states(100, seed=3))} for c in ("CD", "CL")},
    )
    got = np.array([t.value for t in res.table.terms])
    want = np.array([t.value for t in truth.terms])
    assert np.max(np.abs(got - want)) < 1e-9
    for c, s in res.stats.items():  # noqa: B007
        assert s["fit"].rms < 1e-10 and s["fit"].r2 > 1 - 1e-12
    assert res.stats["CD"]["test"].n == 100 and res.stats["CD"]["test"].rms < 1e-10
    assert all(se < 1e-8 for se in res.std_errors().values())


def test_statistics_against_hand_computed_values():
    y = np.array([1.0, 2.0, 3.0, 4.0])
    m = np.array([1.5, 2.0, 3.0, 3.5])
    s = statistics(m, y)
    assert s.rms == pytest.approx(np.sqrt(0.5 / 4))
    assert s.max_abs == pytest.approx(0.5)
    assert s.r2 == pytest.approx(1 - 0.5 / 5.0)
    assert s.range == pytest.approx(3.0)


def test_standard_errors_match_the_textbook_formula():
    rng = np.random.default_rng(7)
    table = TermTable.from_records(
        [
            {"coef": "Cm", "monomial": "1", "value": 0},
            {"coef": "Cm", "monomial": "alpha", "value": 0},
            {"coef": "Cm", "monomial": "dm", "value": 0},
        ]
    )
    n = 200
    st = _states(n, seed=8)
    y = 0.1 - 0.8 * st.alpha - 1.2 * st.dm + 0.01 * rng.normal(size=n)
    zeros = np.zeros(n)
    f = fit_coefficient(table, "Cm", Samples(st, Coefficients(zeros, zeros, zeros, zeros, y, zeros)))
    X = np.column_stack([np.ones(n), st.alpha, st.dm])
    theta, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ theta
    cov = (r @ r) / (n - 3) * np.linalg.inv(X.T @ X)
    assert np.allclose(f.values, theta, rtol=0, atol=1e-12)
    assert np.allclose(f.std_errors, np.sqrt(np.diag(cov)), rtol=1e-9)


def test_too_few_samples_is_refused():
    st = _states(10)
    with pytest.raises(SingularFitError, match="10 samples for 10 terms"):
        fit_coefficient(gna45_structure(), "CD", _samples_of(gna45_structure(), st))


def test_constant_regressor_is_refused_and_named():
    st = _states(200, fixed=("beta",))
    with pytest.raises(SingularFitError, match=r"theta11 \(CY: beta\) is constant"):
        fit_coefficient(gna45_structure(), "CY", _samples_of(gna45_structure(), st))


def test_dependent_regressors_are_refused_and_named():
    table = TermTable.from_records(
        [
            {"theta": 1, "coef": "CL", "monomial": "alpha", "value": 0},
            {"theta": 2, "coef": "CL", "monomial": "alpha", "value": 0},
        ]
    )
    with pytest.raises(SingularFitError, match="linearly dependent.*theta1.*theta2|linearly dependent.*theta2.*theta1"):
        fit_coefficient(table, "CL", _samples_of(table, _states(50)))


def test_samples_reject_non_finite_source_values():
    st = _states(3)
    bad = np.array([0.0, np.nan, 0.0])
    zeros = np.zeros(3)
    with pytest.raises(InputError, match="source returned CL = nan at sample 1"):
        Samples(st, Coefficients(zeros, zeros, bad, zeros, zeros, zeros))


def test_missing_fit_set_is_an_error():
    with pytest.raises(InputError, match="no samples to fit"):
        fit_table(gna45_structure(), {})
