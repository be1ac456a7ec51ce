"""Fitting GNA term tables to source aerodynamic models (``gflat fit``).

Python API::

    from gna.fit import fit_source, gna45_structure, standard_design
    from gna.fit.sources.jsbsim_aero import JSBSimAeroSource

    src = JSBSimAeroSource("F4N", mach=0.6, altitude=3048.0)
    design = standard_design({"alpha": (-0.087, 0.436), "beta": (-0.26, 0.26), "phat": (-0.15, 0.15),
                              "qhat": (-0.03, 0.03), "rhat": (-0.06, 0.06), **{k: src.envelope[k]
                              for k in ("dl", "dm", "dn")}}, dm_band=0.1)
    result = fit_source(src, gna45_structure(), design)
    result.table            # the fitted TermTable (any structure can be fitted)
    result.stats["Cl"]["test"].r2

Modules: :mod:`.design` (sampling designs), :mod:`.lstsq` (least squares and
statistics), :mod:`.pipeline` (sample + fit + validate), :mod:`.sources`
(GTM database, JSBSim aircraft, linear derivative models), :mod:`.quality`
(trim of the fit against its source), :mod:`.writer` / :mod:`.document`
(aircraft files with provenance), :mod:`.regenerate` (the bundled fitted
aircraft), :mod:`.report` (the tables of ``docs/fit_quality.md``),
:mod:`.vendor` (copying the source data into the package).
"""

from .design import Block, SamplingDesign, standard_design
from .lstsq import FitResult, Samples, SingularFitError, fit_table
from .pipeline import fit_source, gna45_structure, structure_from_file
from .quality import ReferenceCondition, trim_comparison

__all__ = [
    "Block",
    "SamplingDesign",
    "standard_design",
    "FitResult",
    "Samples",
    "SingularFitError",
    "fit_table",
    "fit_source",
    "gna45_structure",
    "structure_from_file",
    "ReferenceCondition",
    "trim_comparison",
]
