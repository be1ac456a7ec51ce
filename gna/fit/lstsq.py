"""Least-squares fit of a term table to samples of a source model, and fit statistics.

Each coefficient (CD, CY, CL, Cl, Cm, Cn) is fitted separately by ordinary
linear least squares on the monomials of its terms::

    C_k(x_i) ~ sum_j theta_j m_j(x_i),     i = 1..n

The regressor columns are scaled to unit RMS before the singular value
decomposition, so the rank test is independent of units.  The problem is
refused (:class:`SingularFitError`) when there are fewer samples than terms,
when a regressor other than the constant ``1`` does not vary over the samples
(the design holds its variable fixed), or when the scaled regressor matrix is
rank deficient (two terms that the samples cannot tell apart).

Statistics (:class:`CoefficientStats`) are computed on any sample set: RMS and
maximum absolute error, coefficient of determination
``R^2 = 1 - SS_res / SS_tot`` (``SS_tot`` about the mean of the source values)
and the range of the source values.  Parameter standard errors are the usual
``s^2 (X^T X)^-1`` with ``s^2 = SS_res / (n - p)``; with deterministic
(noise-free) samples they measure how much of the source the structure cannot
represent, as in Grauer & Morelli's identification.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..aero import COEFFICIENTS, AeroState, Coefficients, TermTable
from ..errors import InputError

#: Smallest accepted ratio of the smallest to the largest singular value of the
#: column-scaled regressor matrix.
RANK_TOLERANCE = 1e-10


class SingularFitError(InputError):
    """The least-squares problem has no unique solution (too few samples, constant or dependent regressors)."""


@dataclass(frozen=True)
class Samples:
    """Evaluations of a source model: states and the six coefficients, 1-D arrays of equal length.

    Parameters
    ----------
    state : AeroState
        The eight aerodynamic variables, arrays of shape (n,) [rad / nondimensional].
    coefficients : Coefficients
        The six coefficients at those states, arrays of shape (n,).

    Raises
    ------
    InputError
        Fields not all 1-D of one length, or a non-finite coefficient (the message names the sample).
    """

    state: AeroState
    coefficients: Coefficients

    def __post_init__(self):
        n = {np.shape(v) for v in (*self.state, *self.coefficients)}
        if len(n) != 1 or len(next(iter(n))) != 1:
            raise InputError(f"samples must be 1-D arrays of one length, got shapes {sorted(n)}")
        for name, v in zip(COEFFICIENTS, self.coefficients):
            bad = ~np.isfinite(np.asarray(v, dtype=float))
            if np.any(bad):
                i = int(np.argmax(bad))
                where = ", ".join(f"{k} = {float(s[i]):.6g}" for k, s in zip(AeroState._fields, self.state))
                raise InputError(f"source returned {name} = {v[i]} at sample {i} ({where})")

    def __len__(self) -> int:
        return int(np.shape(self.state.alpha)[0])

    def take(self, index) -> Samples:
        """A subset of the samples.

        Parameters
        ----------
        index : slice or array_like of int or bool
            Which samples (numpy indexing of the 1-D arrays).

        Returns
        -------
        Samples
            The selected states and coefficients.
        """
        return Samples(
            AeroState(*(np.asarray(v)[index] for v in self.state)),
            Coefficients(*(np.asarray(v)[index] for v in self.coefficients)),
        )

    @classmethod
    def from_source(cls, source, state: AeroState) -> Samples:
        """Evaluate a source model at states.

        Parameters
        ----------
        source : object
            The source model: ``source.coefficients(AeroState)`` returns the six coefficients.
        state : AeroState
            The states (fields broadcast together, then flattened to shape (n,)).

        Returns
        -------
        Samples
            The flattened states and the source's coefficients, broadcast to shape (n,).

        Raises
        ------
        InputError
            A non-finite coefficient from the source (:class:`Samples`).
        """
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in state))
        st = AeroState(*(np.ravel(a).copy() for a in arrays))
        c = source.coefficients(st)
        n = len(st.alpha)
        return cls(st, Coefficients(*(np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy() for v in c)))


@dataclass(frozen=True)
class CoefficientStats:
    """Agreement of a fitted coefficient with the source on one sample set.

    Parameters
    ----------
    n : int
        Number of samples.
    rms : float
        Root-mean-square error (model minus source).
    max_abs : float
        Largest absolute error.
    r2 : float
        Coefficient of determination ``1 - SS_res / SS_tot``.
    range : float
        Peak-to-peak range of the source values.
    """

    n: int
    rms: float
    max_abs: float
    r2: float
    range: float

    def to_dict(self) -> dict:
        """The statistics as plain data (the ``[fit.statistics]`` tables of an aircraft file).

        Returns
        -------
        dict
            ``n``, ``rms``, ``max_abs``, ``r2``, ``range``.
        """
        return {"n": self.n, "rms": self.rms, "max_abs": self.max_abs, "r2": self.r2, "range": self.range}


def statistics(model: np.ndarray, source: np.ndarray) -> CoefficientStats:
    """RMS, max abs error, R^2 and range of ``source`` for the predictions ``model``.

    Parameters
    ----------
    model : ndarray, shape (n,)
        Predicted coefficient values (the fitted table).
    source : ndarray, shape (n,)
        The source model's values at the same states, n >= 1.

    Returns
    -------
    CoefficientStats
        ``R^2 = 1 - SS_res / SS_tot`` about the mean of ``source``; when the source is constant, 1 for an
        exact model and ``-inf`` otherwise.
    """
    y = np.asarray(source, dtype=float)
    e = np.asarray(model, dtype=float) - y
    ss_res = float(np.sum(e * e))
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else (1.0 if ss_res == 0 else -math.inf)
    return CoefficientStats(
        n=len(y), rms=math.sqrt(ss_res / len(y)), max_abs=float(np.max(np.abs(e))), r2=r2, range=float(np.ptp(y))
    )


@dataclass(frozen=True)
class CoefficientFit:
    """Least-squares solution for one coefficient."""

    coefficient: str
    values: tuple[float, ...]
    std_errors: tuple[float, ...]
    condition: float
    n: int


def fit_coefficient(structure: TermTable, coefficient: str, samples: Samples) -> CoefficientFit:
    """Fit the terms of ``coefficient`` to ``samples`` by ordinary least squares (SVD of unit-RMS columns).

    Parameters
    ----------
    structure : TermTable
        Terms to fit (their values are ignored).
    coefficient : str
        One of :data:`gna.aero.COEFFICIENTS`.
    samples : Samples
        States and source coefficients.

    Returns
    -------
    CoefficientFit
        Values and standard errors of the coefficient's terms (in table order), the condition number of
        the column-scaled regressor matrix and the number of samples.

    Raises
    ------
    InputError
        The structure has no term for ``coefficient``.
    SingularFitError
        Too few samples, a constant non-intercept regressor, or a rank-deficient
        regressor matrix; the message names the terms involved.
    """
    idx = [i for i, t in enumerate(structure.terms) if t.coefficient == coefficient]
    if not idx:
        raise InputError(f"the structure has no term for {coefficient}")
    terms = [structure.terms[i] for i in idx]
    label = [f"theta{t.index} ({coefficient}: {t.monomial})" for t in terms]
    n, p = len(samples), len(terms)
    if n < p + 1:
        raise SingularFitError(
            f"{coefficient}: {n} samples for {p} terms; a least-squares fit needs at least "
            f"{p + 1} (more samples, or fewer terms)"
        )
    mons = structure.monomials(samples.state)
    X = np.column_stack([np.broadcast_to(np.asarray(mons[i], dtype=float), (n,)) for i in idx])
    y = np.asarray(getattr(samples.coefficients, coefficient), dtype=float)
    scale = np.sqrt(np.mean(X * X, axis=0))
    for j, t in enumerate(terms):
        col = X[:, j]
        if t.monomial != "1" and (scale[j] == 0 or np.ptp(col) <= 1e-12 * scale[j]):
            raise SingularFitError(
                f"{coefficient}: regressor {label[j]} is constant (= {col[0]:.6g}) over the "
                f"{n} samples; the sampling design must vary its variables"
            )
    Xs = X / scale
    U, s, Vt = np.linalg.svd(Xs, full_matrices=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    if not s[-1] > RANK_TOLERANCE * s[0]:
        v = Vt[-1]
        involved = [label[j] for j in np.argsort(-np.abs(v)) if abs(v[j]) > 0.1 * np.max(np.abs(v))]
        raise SingularFitError(
            f"{coefficient}: the regressors are linearly dependent over the samples "
            f"(condition number {cond:.3g}); involved: {', '.join(involved)}"
        )
    beta_s = Vt.T @ ((U.T @ y) / s)
    theta = beta_s / scale
    resid = y - X @ theta
    dof = n - p
    s2 = float(resid @ resid) / dof
    cov_diag = np.sum((Vt.T / s) ** 2, axis=1) / scale**2
    se = np.sqrt(s2 * cov_diag)
    return CoefficientFit(coefficient, tuple(float(v) for v in theta), tuple(float(v) for v in se), cond, n)


@dataclass(frozen=True)
class FitResult:
    """A fitted term table with its statistics.

    Attributes
    ----------
    table : TermTable
        The structure with fitted values.
    fits : dict
        Coefficient name -> :class:`CoefficientFit`.
    stats : dict
        Coefficient name -> {sample-set name -> :class:`CoefficientStats`}.
    """

    table: TermTable
    fits: Mapping[str, CoefficientFit]
    stats: Mapping[str, Mapping[str, CoefficientStats]]

    def std_errors(self) -> dict[int, float]:
        """Standard error of each term's value, by term index.

        Returns
        -------
        dict of int to float
            Term index (theta number) -> standard error ``sqrt(s^2 (X^T X)^-1_jj)``.
        """
        out = {}
        for coef, f in self.fits.items():
            for t, se in zip(self.table.terms_of(coef), f.std_errors):
                out[t.index] = se
        return out


def fit_table(
    structure: TermTable,
    fit_sets: Mapping[str, Samples],
    validation_sets: Mapping[str, Mapping[str, Samples]] | None = None,
    source: str = "least-squares fit",
) -> FitResult:
    """Fit every coefficient of ``structure``.

    Parameters
    ----------
    structure : TermTable
        Terms to fit (their values are ignored).
    fit_sets : mapping
        Coefficient name -> samples to fit it on (a coefficient may have its
        own sample set, e.g. the longitudinal plane for CD, CL, Cm).
    validation_sets : mapping, optional
        Coefficient name -> {set name -> samples}: held-out sets on which the
        fitted coefficient is evaluated, besides its own fit set (``"fit"``).
    source : str
        Text stored as each fitted term's ``source``.

    Returns
    -------
    FitResult
        The fitted table, the per-coefficient fits and their statistics on ``"fit"`` and each validation set.

    Raises
    ------
    InputError
        A coefficient of ``structure`` without a fit set.
    SingularFitError
        A coefficient's least-squares problem has no unique solution (:func:`fit_coefficient`).
    """
    coefs = [c for c in COEFFICIENTS if structure.terms_of(c)]
    missing = [c for c in coefs if c not in fit_sets]
    if missing:
        raise InputError(f"no samples to fit {', '.join(missing)}")
    fits = {c: fit_coefficient(structure, c, fit_sets[c]) for c in coefs}
    values = {}
    for c in coefs:
        for t, v in zip(structure.terms_of(c), fits[c].values):
            values[t.index] = v
    table = structure.with_values(values, source=source)
    stats: dict[str, dict[str, CoefficientStats]] = {}
    for c in coefs:
        sets = {"fit": fit_sets[c], **dict((validation_sets or {}).get(c, {}))}
        stats[c] = {}
        for name, smp in sets.items():
            pred = np.broadcast_to(np.asarray(getattr(table.coefficients(smp.state), c), dtype=float), (len(smp),))
            stats[c][name] = statistics(pred, getattr(smp.coefficients, c))
    return FitResult(table, fits, stats)
