"""Aerodynamic coefficient models stored as term tables.

The Grauer--Morelli generic nonlinear aerodynamic (GNA) model (paper eq.
(GNA)) is a sum of polynomial terms ``theta_i * monomial_i``.  Here the model
is *data*: a :class:`TermTable` lists, for each term, the coefficient it
belongs to, the monomial (exponents of the aerodynamic variables) and the
parameter value, so any structure (the 45-term GNA one, or an extended one
produced by ``gflat fit``) evaluates through the same code.

Conventions (see ``docs/conventions.md``):

* ``CD``, ``CL``: drag and lift coefficients in **stability axes** (drag along
  -x_s, lift along -z_s; the stability frame is the body frame rotated by
  alpha about y_b);
* ``CY``, ``Cl``, ``Cm``, ``Cn``: side-force and rolling, pitching, yawing
  moment coefficients in **body axes**, moments about the model's moment
  reference point;
* variables: ``alpha``, ``beta`` [rad]; ``phat = p b / (2V)``,
  ``qhat = q cbar / (2V)``, ``rhat = r b / (2V)``; ``dl``, ``dm``, ``dn``
  aileron, elevator, rudder [rad], positive trailing edge down (right
  aileron) / down / left, which gives ``Cl_dl < 0``, ``Cm_dm < 0``,
  ``Cn_dn < 0``.

Evaluation uses only ``+`` and ``*`` on its inputs, so it runs on floats,
numpy arrays (many states at once) and truncated power series alike.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .errors import InputError

#: The aerodynamic variables a monomial may contain, in this order.
AERO_VARIABLES: tuple[str, ...] = ("alpha", "beta", "phat", "qhat", "rhat", "dl", "dm", "dn")

#: Aerodynamic variables that the flat ("simple") model drops from the force
#: coefficients: rates and surfaces (the paper's H terms).
H_VARIABLES: tuple[str, ...] = ("phat", "qhat", "rhat", "dl", "dm", "dn")

#: Coefficient names, in the order of :class:`Coefficients`.
COEFFICIENTS: tuple[str, ...] = ("CD", "CY", "CL", "Cl", "Cm", "Cn")

#: Largest exponent of a variable in a monomial (the published models use at most 4; a larger one is a
#: typo, and its powers would overflow the series arithmetic long before they mattered).
MAX_EXPONENT = 12

#: Most terms of an aerodynamic table (the paper's structure has 45; every term is a monomial evaluated at
#: every step and node, so thousands are a mistake, not a model).
MAX_TERMS = 1000

#: Named structures a model file may declare: name -> number of terms, indexed theta = 1 .. n
#: (``gna45``: the paper's 45-term model of the GNA aircraft, the structure of every bundled aircraft).
STRUCTURES: dict[str, int] = {"gna45": 45}

#: Other spellings accepted in term tables (Grauer--Morelli use de, da, dr).
_ALIASES = {
    "a": "alpha",
    "b": "beta",
    "de": "dm",
    "da": "dl",
    "dr": "dn",
    "ptilde": "phat",
    "qtilde": "qhat",
    "rtilde": "rhat",
}


class Coefficients(NamedTuple):
    """The six aerodynamic coefficients (any numeric type)."""

    CD: object
    CY: object
    CL: object
    Cl: object
    Cm: object
    Cn: object


class AeroState(NamedTuple):
    """Values of the aerodynamic variables (any numeric type)."""

    alpha: object
    beta: object
    phat: object
    qhat: object
    rhat: object
    dl: object
    dm: object
    dn: object


def parse_monomial(text: str) -> tuple[int, ...]:
    """Parse ``"alpha^2*qhat"`` into exponents over :data:`AERO_VARIABLES`.

    ``"1"`` (or an empty string) is the constant monomial.

    Parameters
    ----------
    text : str
        Product of aerodynamic variables (aliases ``de``, ``da``, ``dr``, ... accepted), each with
        an optional exponent ``^n`` (or ``**n``), ``1 <= n <=`` :data:`MAX_EXPONENT`.

    Returns
    -------
    tuple of int
        The exponent of each of :data:`AERO_VARIABLES`.

    Raises
    ------
    InputError
        Not a string, a malformed factor, an unknown variable, or an exponent above
        :data:`MAX_EXPONENT`.
    """
    if not isinstance(text, str):
        raise InputError(f'monomial must be a string such as "alpha^2*qhat", got {text!r}')
    exps = [0] * len(AERO_VARIABLES)
    text = text.strip().replace(" ", "").replace("**", "^")
    if text in ("", "1"):
        return tuple(exps)
    for factor in text.split("*"):
        m = re.fullmatch(r"([A-Za-z_]+)(?:\^([0-9]{1,6}))?", factor)
        if not m:
            raise InputError(f"malformed monomial {text!r} (factor {factor!r}; write e.g. alpha^2*qhat)")
        name = _ALIASES.get(m.group(1), m.group(1))
        if name not in AERO_VARIABLES:
            raise InputError(
                f"unknown aerodynamic variable {m.group(1)!r} in monomial {text!r}; known: {', '.join(AERO_VARIABLES)}"
            )
        exps[AERO_VARIABLES.index(name)] += int(m.group(2) or 1)
    worst = max(exps)
    if worst > MAX_EXPONENT:
        raise InputError(
            f"monomial {text!r}: exponent {worst} of {AERO_VARIABLES[exps.index(worst)]} exceeds {MAX_EXPONENT}"
        )
    return tuple(exps)


def format_monomial(exponents: Iterable[int]) -> str:
    """Inverse of :func:`parse_monomial`.

    Parameters
    ----------
    exponents : iterable of int
        Exponent of each of :data:`AERO_VARIABLES`.

    Returns
    -------
    str
        ``"alpha^2*qhat"``, or ``"1"`` for the constant monomial.
    """
    parts = []
    for name, e in zip(AERO_VARIABLES, exponents):
        if e == 1:
            parts.append(name)
        elif e > 1:
            parts.append(f"{name}^{e}")
    return "*".join(parts) if parts else "1"


@dataclass(frozen=True)
class Term:
    """One term ``value * monomial`` of a coefficient."""

    index: int
    coefficient: str
    exponents: tuple[int, ...]
    value: float
    source: str = ""

    @property
    def monomial(self) -> str:
        return format_monomial(self.exponents)

    @property
    def is_flat(self) -> bool:
        """True when the monomial involves alpha and beta only."""
        return all(self.exponents[AERO_VARIABLES.index(v)] == 0 for v in H_VARIABLES)


@dataclass(frozen=True)
class TermTable:
    """An aerodynamic model given as a table of polynomial terms.

    Parameters
    ----------
    terms : sequence of Term
    structure : str
        Name of the structure (``"gna45"`` for the paper's 45 terms).
    """

    terms: tuple[Term, ...]
    structure: str = "custom"
    _powers: tuple[int, ...] = field(init=False, repr=False, compare=False)
    _unique: tuple[tuple[int, ...], ...] = field(init=False, repr=False, compare=False)
    _theta: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        for t in self.terms:
            if t.coefficient not in COEFFICIENTS:
                raise InputError(
                    f"term {t.index}: unknown coefficient {t.coefficient!r}; known: {', '.join(COEFFICIENTS)}"
                )
            if not np.isfinite(t.value):
                raise InputError(f"term {t.index} ({t.coefficient}, {t.monomial}): value is {t.value}")
        object.__setattr__(
            self,
            "_powers",
            tuple(max((t.exponents[i] for t in self.terms), default=0) for i in range(len(AERO_VARIABLES))),
        )
        unique = tuple(sorted({t.exponents for t in self.terms}))
        theta = np.zeros((len(COEFFICIENTS), len(unique)))
        for t in self.terms:
            theta[COEFFICIENTS.index(t.coefficient), unique.index(t.exponents)] += t.value
        object.__setattr__(self, "_unique", unique)
        object.__setattr__(self, "_theta", theta)

    @classmethod
    def from_records(
        cls, records: Iterable[Mapping], structure: str = "custom", where: str = "aerodynamic terms"
    ) -> TermTable:
        """Build from mappings with keys ``theta``/``index``, ``coef``, ``monomial``, ``value``, ``source``.

        Parameters
        ----------
        records : iterable of mapping
            One mapping per term (the ``[[aero.terms]]`` tables of an aircraft file).
        structure : str
            Name of the structure.
        where : str
            File and table, for messages.

        Returns
        -------
        TermTable

        Raises
        ------
        InputError
            A record that is not a table, a missing key, a value of the wrong type, a malformed
            monomial: naming ``where``, the term and the key.
        """
        if isinstance(records, (str, bytes, Mapping)) or not isinstance(records, Iterable):
            raise InputError(f"{where}: terms must be a list of tables, got {records!r}")
        terms = []
        for i, r in enumerate(records, start=1):
            at = f"{where} #{i}"
            if not isinstance(r, Mapping):
                raise InputError(f"{at}: a term must be a table (coef, monomial, value), got {r!r}")
            for key in ("monomial", "value"):
                if key not in r:
                    raise InputError(f"{at}: missing key {key!r}")
            index, coef, value = r.get("theta", r.get("index", i)), r.get("coef", r.get("coefficient")), r["value"]
            if isinstance(index, bool) or not isinstance(index, int):
                raise InputError(f"{at}: theta = {index!r} must be a whole number")
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InputError(f"{at}: value = {value!r} must be a number")
            try:
                exponents = parse_monomial(r["monomial"])
            except InputError as exc:
                raise InputError(f"{at}: {exc}") from None
            terms.append(
                Term(
                    index=index,
                    coefficient=str(coef),
                    exponents=exponents,
                    value=float(value),
                    source=str(r.get("source", "")),
                )
            )
        try:
            return cls(tuple(terms), structure)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None

    def check_unique(self, where: str = "aerodynamic terms") -> None:
        """Refuse a table where a term index, or a coefficient/monomial pair, appears twice.

        A model file lists each term once; a repeated pair would be summed silently (the fitting
        code builds such tables on purpose to test rank detection, so the constructor allows them).

        Parameters
        ----------
        where : str
            File and table, for the message.

        Raises
        ------
        InputError
            Naming both terms.
        """
        pairs: dict[tuple[str, tuple[int, ...]], int] = {}
        indices: set[int] = set()
        for t in self.terms:
            if t.index in indices:
                raise InputError(f"{where}: theta = {t.index} is used by an earlier term")
            indices.add(t.index)
            if (t.coefficient, t.exponents) in pairs:
                raise InputError(
                    f"{where}: term {t.index} repeats term {pairs[t.coefficient, t.exponents]} "
                    f"({t.coefficient}, monomial {t.monomial}): give each term once"
                )
            pairs[t.coefficient, t.exponents] = t.index

    def check_structure(self, where: str = "aerodynamic terms") -> None:
        """Refuse a table declaring a named structure (:data:`STRUCTURES`) whose terms do not match it.

        Parameters
        ----------
        where : str
            File and table, for the message.

        Raises
        ------
        InputError
            The declared structure's term count or indices (theta = 1 .. n) do not match, naming
            the missing and the extra indices.
        """
        n = STRUCTURES.get(self.structure)
        if n is None:
            return
        have = {t.index for t in self.terms}
        missing = sorted(set(range(1, n + 1)) - have)
        extra = sorted(have - set(range(1, n + 1)))
        if missing or extra or len(self.terms) != n:
            parts = [
                f"missing theta {', '.join(map(str, missing))}" if missing else "",
                f"unexpected theta {', '.join(map(str, extra))}" if extra else "",
            ]
            raise InputError(
                f"{where}: structure = {self.structure!r} has {n} terms (theta = 1 .. {n}), "
                f"the file gives {len(self.terms)}: "
                + "; ".join(p for p in parts if p)
                + "; give every term (value 0 for an absent one) or declare structure = 'custom'"
            )

    def to_records(self) -> list[dict]:
        """Records suitable for a TOML aircraft file.

        Returns
        -------
        list of dict
            ``theta``, ``coef``, ``monomial``, ``value`` (and ``source``) of each term.
        """
        out = []
        for t in self.terms:
            rec = {"theta": t.index, "coef": t.coefficient, "monomial": t.monomial, "value": t.value}
            if t.source:
                rec["source"] = t.source
            out.append(rec)
        return out

    def with_values(self, values: Mapping[int, float] | Iterable[float], source: str = "") -> TermTable:
        """A copy with new parameter values (by term index, or in table order).

        Parameters
        ----------
        values : mapping of int to float, or iterable of float
            New values by term index (others kept), or one value per term in table order.
        source : str
            Source recorded on the changed terms (default: keep each term's).

        Returns
        -------
        TermTable

        Raises
        ------
        InputError
            If a sequence of values does not have one value per term.
        """
        if isinstance(values, Mapping):
            new = [
                Term(
                    t.index,
                    t.coefficient,
                    t.exponents,
                    float(values.get(t.index, t.value)),
                    source if t.index in values else t.source,
                )
                for t in self.terms
            ]
        else:
            vals = list(values)
            if len(vals) != len(self.terms):
                raise InputError(f"{len(vals)} values for {len(self.terms)} terms")
            new = [
                Term(t.index, t.coefficient, t.exponents, float(v), source or t.source)
                for t, v in zip(self.terms, vals)
            ]
        return TermTable(tuple(new), self.structure)

    def terms_of(self, coefficient: str) -> tuple[Term, ...]:
        """The terms of one coefficient.

        Parameters
        ----------
        coefficient : str
            One of :data:`COEFFICIENTS`.

        Returns
        -------
        tuple of Term
        """
        return tuple(t for t in self.terms if t.coefficient == coefficient)

    def monomials(self, state: AeroState) -> list:
        """Values of every term's monomial (without its parameter), in table order.

        Parameters
        ----------
        state : AeroState
            Values of the aerodynamic variables (floats, arrays or series).

        Returns
        -------
        list
            One value per term, of the type of the state's entries.
        """
        return self._monomial_values(state, [t.exponents for t in self.terms])

    def _monomial_values(self, state: AeroState, exponent_list) -> list:
        cache: dict[tuple[int, int], object] = {}
        values = list(state)

        def power(i: int, e: int):
            key = (i, e)
            if key not in cache:
                cache[key] = values[i] if e == 1 else power(i, e - 1) * values[i]
            return cache[key]

        out = []
        for exps in exponent_list:
            m = None
            for i, e in enumerate(exps):
                if e:
                    m = power(i, e) if m is None else m * power(i, e)
            out.append(1.0 if m is None else m)
        return out

    def coefficients(self, state: AeroState) -> Coefficients:
        """Evaluate the six coefficients (paper eq. (GNA)).

        Parameters
        ----------
        state : AeroState
            alpha, beta [rad], phat, qhat, rhat [-], dl, dm, dn [rad]; floats,
            arrays (broadcast together) or truncated power series.

        Returns
        -------
        Coefficients
            CD, CY, CL, Cl, Cm, Cn, of the type of the state's entries.
        """
        mons = self._monomial_values(state, self._unique)
        # A series class that contracts in its own storage layout (planners.series.Series, the traced
        # series of planners.program): one tensor contraction instead of 45 scalings and additions.
        lin = next((type(m) for m in mons if hasattr(type(m), "linear_combinations")), None)
        if lin is not None:
            return Coefficients(*lin.linear_combinations(self._theta, mons))
        series = [m for m in mons if hasattr(m, "coeffs") and hasattr(m, "batch_shape")]
        if series:
            cls = type(series[0])
            order = min(m.order for m in series)
            batch = np.broadcast_shapes(
                *(m.batch_shape for m in series), *(np.shape(m) for m in mons if not hasattr(m, "coeffs"))
            )
            dtype = np.result_type(
                *(m.dtype for m in series), *(np.asarray(m).dtype for m in mons if not hasattr(m, "coeffs"))
            )
            stack = np.zeros((len(mons),) + batch + (order + 1,), dtype)
            for i, m in enumerate(mons):
                if hasattr(m, "coeffs"):
                    stack[i] = np.asarray(m.coeffs)[..., : order + 1]
                else:
                    stack[i, ..., 0] = m
            out = np.tensordot(self._theta, stack, axes=(1, 0))
            return Coefficients(*(cls(out[i]) for i in range(len(COEFFICIENTS))))
        sums = []
        for row in self._theta:
            acc = 0.0
            for w, m in zip(row, mons):
                if w != 0.0:
                    acc = acc + w * m
            sums.append(acc)
        return Coefficients(*sums)

    def __len__(self) -> int:
        return len(self.terms)
