"""Fit a term table to a source model: sample, fit, validate.

:func:`fit_source` is the Python API behind ``gflat fit``::

    from gna.fit import fit_source, gna45_structure, standard_design
    result = fit_source(source, gna45_structure(), standard_design(ranges))
    result.table      # fitted TermTable
    result.stats      # per-coefficient RMS, max error, R^2 on fit and held-out sets
"""

from __future__ import annotations

from dataclasses import replace

from ..aero import TermTable
from ..aircraft import load_aircraft
from ..errors import InputError
from .design import SamplingDesign
from .lstsq import FitResult, Samples, fit_table


def gna45_structure() -> TermTable:
    """The 45-term Grauer--Morelli structure (paper eq. (GNA)): the terms of the bundled ``f16c`` file, values zeroed.

    Returns
    -------
    TermTable
        The 45 terms (coefficient and monomial), values 0 and no source, structure ``"gna45"``.

    Raises
    ------
    InputError
        The bundled ``f16c.toml`` does not declare the ``gna45`` structure.
    """
    table = load_aircraft("f16c").aero
    if table.structure != "gna45":
        raise InputError(f"f16c.toml declares structure {table.structure!r}, expected 'gna45'")
    return TermTable(tuple(replace(t, value=0.0, source="") for t in table.terms), "gna45")


def structure_from_file(path: str) -> TermTable:
    """The term structure of an aircraft TOML file (values zeroed), to fit another structure than GNA's.

    Parameters
    ----------
    path : str
        A bundled aircraft id or a path to an aircraft ``.toml`` file (:func:`gna.aircraft.load_aircraft`).

    Returns
    -------
    TermTable
        The file's terms, values 0 and no source, with its structure name.

    Raises
    ------
    InputError
        The file cannot be loaded as an aircraft (from :func:`gna.aircraft.load_aircraft`).
    """
    table = load_aircraft(path).aero
    return TermTable(tuple(replace(t, value=0.0, source="") for t in table.terms), table.structure)


def fit_source(
    source, structure: TermTable, design: SamplingDesign, term_source: str | None = None, check_envelope: bool = True
) -> FitResult:
    """Sample ``source`` on ``design`` and fit ``structure`` by least squares.

    Each coefficient is fitted on the fit points of its design block and
    validated on the block's held-out points (``"test"``) and on the held-out
    points of every other block whose box contains its block
    (``"test_<block>"``, e.g. CD fitted on the longitudinal plane is also
    scored on the 8-D box).

    Parameters
    ----------
    source : object
        The source model: ``coefficients(AeroState)`` gives the six coefficients; optional ``name`` (for
        the terms' source text) and ``check_design(design)`` (refuses a design beyond its data).
    structure : TermTable
        Terms to fit (values ignored), e.g. :func:`gna45_structure`.
    design : SamplingDesign
        Where the source is sampled.
    term_source : str, optional
        Text stored as each fitted term's ``source`` (default: ``"least-squares fit to <source name>"``).
    check_envelope : bool
        Refuse a design beyond the source's data; False samples beyond it (JSBSim holds
        table end values there; the GTM database extrapolates linearly).

    Returns
    -------
    FitResult
        The fitted table and its statistics on the ``"fit"``, ``"test"`` and ``"test_<block>"`` sets.

    Raises
    ------
    InputError
        The design reaches outside ``source.envelope``.
    SingularFitError
        See :func:`gna.fit.lstsq.fit_coefficient`.
    """
    check = getattr(source, "check_design", None)
    if check_envelope and check is not None:
        check(design)
    drawn = design.draw(source)
    samples = {
        name: (Samples.from_source(source, fit), Samples.from_source(source, test))
        for name, (fit, test) in drawn.items()
    }
    fit_sets, validation = {}, {}
    for block in design.blocks:
        for c in block.coefficients:
            fit_sets[c] = samples[block.name][0]
            validation[c] = {"test": samples[block.name][1]}
            for other in design.blocks:
                if other is not block and other.contains(block):
                    validation[c][f"test_{other.name}"] = samples[other.name][1]
    label = term_source or f"least-squares fit to {getattr(source, 'name', 'source')}"
    return fit_table(structure, fit_sets, validation, source=label)
