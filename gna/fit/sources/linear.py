"""Linear (stability-derivative) aerodynamic models, e.g. the UIUC/NASA Twin Otter.

The model is a sum of derivative terms in **body axes** about the CG::

    CX = CXo + CX_a alpha + CX_a2 alpha^2 + ...
    CZ = CZo + CZ_a alpha + CZ_q qhat + CZ_de de + ...
    CY = CY_beta beta + CY_p phat + CY_r rhat + CY_dr dr + ...
    Cl, Cm, Cn likewise

(derivatives per rad, rates nondimensional ``phat = p b/2V``, ...); unlisted
derivatives are zero.  The force coefficients are rotated into the project's
stability-axis CD, CL (:func:`~gna.fit.sources.base.stability_from_body`).

The CSV format is the one of ``gna/data/sources/twin_otter``: columns
``group,name,value,unit,note``; rows whose name reads ``<coef>o`` or
``<coef>_<suffix>`` with ``<coef>`` in CX, CY, CZ, Cl, Cm, Cn are
derivatives, the others (geometry, mass, limits) are vehicle data.  Suffixes:
``a`` alpha, ``a2`` alpha^2, ``beta`` beta, ``p``/``q``/``r`` the
nondimensional rates, ``de``/``da``/``dr`` elevator, aileron, rudder.

Surface signs: the UIUC convention (elevator trailing-edge down positive,
``Cl_da < 0`` for positive aileron, ``Cn_dr < 0`` for positive rudder) is the
project's (``dm``, ``dl``, ``dn``), so the surfaces map one-to-one.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...aero import AERO_VARIABLES, AeroState, Coefficients
from ...errors import InputError
from .base import SourceModel, broadcast_state, stability_from_body

#: Body-axis coefficients a linear model may define.
BODY_COEFFICIENTS: tuple[str, ...] = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")

#: Derivative suffix -> exponents over :data:`gna.aero.AERO_VARIABLES`.
SUFFIXES: dict[str, dict[str, int]] = {
    "o": {},
    "a": {"alpha": 1},
    "a2": {"alpha": 2},
    "a3": {"alpha": 3},
    "beta": {"beta": 1},
    "b": {"beta": 1},
    "p": {"phat": 1},
    "q": {"qhat": 1},
    "r": {"rhat": 1},
    "de": {"dm": 1},
    "da": {"dl": 1},
    "dr": {"dn": 1},
}

_NAME = re.compile(r"^(CX|CY|CZ|Cl|Cm|Cn)(?:(o)|_([A-Za-z0-9]+))$")


@dataclass(frozen=True)
class Derivative:
    """One term: ``value * monomial`` of a body-axis coefficient."""

    coefficient: str
    name: str
    exponents: tuple[int, ...]
    value: float


def parse_derivative(name: str, value: float) -> Derivative | None:
    """A :class:`Derivative` from a name like ``CZ_de``; None if the name is not a derivative.

    Parameters
    ----------
    name : str
        A CSV row's name: ``<coef>o`` or ``<coef>_<suffix>`` (:data:`SUFFIXES`) with ``<coef>`` in
        :data:`BODY_COEFFICIENTS` for a derivative.
    value : float or str
        Its value [per rad, or per unit nondimensional rate].

    Returns
    -------
    Derivative or None
        The term, or None for a vehicle-data row.

    Raises
    ------
    InputError
        A derivative name with an unknown suffix, or a non-finite value.
    """
    m = _NAME.match(name.strip())
    if not m:
        return None
    coef, suffix = m.group(1), m.group(2) or m.group(3)
    if suffix not in SUFFIXES:
        raise InputError(f"derivative {name!r}: unknown suffix {suffix!r}; known: {', '.join(SUFFIXES)}")
    exps = [0] * len(AERO_VARIABLES)
    for var, e in SUFFIXES[suffix].items():
        exps[AERO_VARIABLES.index(var)] = e
    v = float(value)
    if not np.isfinite(v):
        raise InputError(f"derivative {name!r} is {v}")
    return Derivative(coef, name.strip(), tuple(exps), v)


class LinearDerivativeModel(SourceModel):
    """A sum of body-axis derivative terms (see the module docstring).

    Parameters
    ----------
    derivatives : sequence of Derivative
        The terms; at least one, no two of the same coefficient and monomial.
    envelope : mapping
        Variable -> (lo, hi): the domain where the model is taken as valid (a
        linear model states no data range; the caller declares it).
    name : str
        Short description (messages, the fitted terms' source).
    citation : str, optional
        Where the derivatives come from (the ``source`` of the fitted file; default ``name``).

    Raises
    ------
    InputError
        No derivatives, or one given twice.
    """

    def __init__(
        self,
        derivatives,
        envelope: Mapping[str, tuple[float, float]],
        name: str = "linear model",
        citation: str | None = None,
    ):
        self.derivatives = tuple(derivatives)
        if not self.derivatives:
            raise InputError(f"{name}: no derivatives")
        seen = set()
        for d in self.derivatives:
            key = (d.coefficient, d.exponents)
            if key in seen:
                raise InputError(f"{name}: derivative {d.name} given twice")
            seen.add(key)
        self.envelope = {k: (float(a), float(b)) for k, (a, b) in envelope.items()}
        self.name = name
        self.citation = citation or name

    @classmethod
    def from_csv(
        cls,
        path: str | Path,
        envelope: Mapping[str, tuple[float, float]],
        name: str | None = None,
        citation: str | None = None,
    ) -> LinearDerivativeModel:
        """Read the derivative rows of a ``group,name,value,unit,note`` CSV file.

        Parameters
        ----------
        path : str or Path
            The CSV file (the format of ``gna/data/sources/twin_otter``).
        envelope : mapping
            Variable -> (lo, hi) [rad / nondimensional] declared valid.
        name : str, optional
            Short description (default ``"linear derivative model <file name>"``).
        citation : str, optional
            Where the derivatives come from (default ``"derivatives of <path>"``).

        Returns
        -------
        LinearDerivativeModel
            The model of the file's derivative rows.

        Raises
        ------
        InputError
            A missing or malformed file, a non-numeric value, an unknown derivative suffix, or a derivative
            given twice.
        """
        rows = _read_rows(path)
        ders = [d for d in (parse_derivative(r["name"], r["value"]) for r in rows) if d is not None]
        return cls(
            ders, envelope, name or f"linear derivative model {Path(path).name}", citation or f"derivatives of {path}"
        )

    def provenance(self) -> dict[str, str]:
        """Source description for the fitted aircraft file.

        Returns
        -------
        dict of str to str
            ``source`` (the citation) and ``source_model`` (the derivatives used and the axis rotation).
        """
        terms = ", ".join(d.name for d in self.derivatives)
        return {
            "source": self.citation,
            "source_model": f"gna.fit.sources.linear: body-axis derivative model ({terms}), CX and CZ "
            f"rotated to stability-axis CD, CL; unlisted derivatives zero",
        }

    def body_coefficients(self, state: AeroState) -> dict[str, np.ndarray]:
        """The body-axis coefficients, sums of the derivative terms.

        Parameters
        ----------
        state : AeroState
            The eight aerodynamic variables (broadcast together) [rad / nondimensional].

        Returns
        -------
        dict of str to ndarray
            ``CX, CY, CZ, Cl, Cm, Cn`` (body axes, about the CG), arrays of the broadcast shape.
        """
        st, shape = broadcast_state(state)
        out = {c: np.zeros(shape) for c in BODY_COEFFICIENTS}
        for d in self.derivatives:
            m = np.ones(shape)
            for v, e in zip(st, d.exponents):
                if e:
                    m = m * v**e
            out[d.coefficient] = out[d.coefficient] + d.value * m
        return out

    def coefficients(self, state: AeroState) -> Coefficients:
        """The six coefficients, CX and CZ rotated to stability-axis CD, CL (:func:`.base.stability_from_body`).

        Parameters
        ----------
        state : AeroState
            The eight aerodynamic variables (broadcast together) [rad / nondimensional].

        Returns
        -------
        Coefficients
            CD, CY, CL, Cl, Cm, Cn, arrays of the broadcast shape.
        """
        st, _ = broadcast_state(state)
        b = self.body_coefficients(st)
        CD, CL = stability_from_body(st.alpha, b["CX"], b["CZ"])
        return Coefficients(CD, b["CY"], CL, b["Cl"], b["Cm"], b["Cn"])


def _read_rows(path: str | Path) -> list[dict[str, str]]:
    """Rows of a ``group,name,value,unit,note`` CSV file (clear error if malformed).

    Raises
    ------
    InputError
        A missing file, missing columns, or a non-numeric value (naming the line).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"linear model file not found: {path}")
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    need = {"group", "name", "value"}
    if not rows or not need <= set(rows[0]):
        raise InputError(f"{path}: expected columns group,name,value[,unit,note]")
    for i, r in enumerate(rows, start=2):
        try:
            float(r["value"])
        except (TypeError, ValueError):
            raise InputError(f"{path}, line {i}: value {r['value']!r} of {r['name']!r} is not a number") from None
    return rows


def vehicle_values(path: str | Path) -> dict[str, tuple[float, str]]:
    """The vehicle data of a linear-model CSV file: its non-derivative rows.

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Returns
    -------
    dict of str to (float, str)
        Row name -> (value, unit) as written (source units).

    Raises
    ------
    InputError
        A missing or malformed file, or a derivative row with an unknown suffix.
    """
    return {
        r["name"]: (float(r["value"]), r.get("unit", ""))
        for r in _read_rows(path)
        if parse_derivative(r["name"], r["value"]) is None
    }
