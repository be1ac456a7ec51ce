"""Metrics of trajectories: pure functions that neither simulate nor write.

Trajectories are DataFrames indexed by time ``t`` [s] with the columns of
:data:`gna.trajectory.COLUMNS` (or objects with such a ``df``, e.g.
:class:`gna.simulate.SimulationResult`); SI units, angles in radians.

Rooms
-----
tables
    :func:`difference_table` (per-variable max, RMS, time of the maximum,
    relative difference ``delta_pct``, pass/fail), :class:`DifferenceTable`,
    tolerance specs (:func:`resolve_tolerances`), :func:`differences`.
scales
    :data:`DEFAULT_TOLERANCES`; the scale of ``delta_pct`` (:func:`percent_scale`:
    ``max|u_ref|``, or the excursion ``max - min`` of the datum-dependent
    variables :data:`DATUM_DEPENDENT`) and its floors (:func:`percent_floor`).
runs
    Sets of runs: :func:`engine_tables` (each engine against the reference per
    window, :data:`DEFAULT_WINDOWS`), deviation from the plan
    (:func:`position_error`, :func:`max_position_error`).  New figures of merit
    of closed-loop tracking go here.
"""

from .runs import engine_tables, max_position_error, position_error, window_span
from .scales import DATUM_DEPENDENT, DEFAULT_TOLERANCES, PERCENT_FLOORS, percent_floor, percent_scale
from .tables import (
    DEFAULT_VARIABLES,
    DEFAULT_WINDOWS,
    DifferenceRow,
    DifferenceTable,
    difference_table,
    differences,
    resolve_tolerances,
)

__all__ = [
    "DATUM_DEPENDENT",
    "DEFAULT_TOLERANCES",
    "DEFAULT_VARIABLES",
    "DEFAULT_WINDOWS",
    "PERCENT_FLOORS",
    "DifferenceRow",
    "DifferenceTable",
    "difference_table",
    "differences",
    "percent_floor",
    "percent_scale",
    "resolve_tolerances",
    "engine_tables",
    "window_span",
    "position_error",
    "max_position_error",
]
