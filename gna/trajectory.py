"""The trajectory contract shared by the model, the planners and every engine.

Names and units of the columns of every trajectory gflat writes or compares:
the 12 wind-frame states, the 5 controls and the derived quantities.  SI units,
angles in radians; frames as in ``docs/conventions.md`` (NED position, wind-axis
forces, body-axis moments about the CG).
"""

from __future__ import annotations

from .eom import CONTROL_NAMES, STATE_NAMES

#: Derived columns of every engine's trajectory, after the states and controls.
DERIVED_NAMES: tuple[str, ...] = ("qbar", "rho", "nx", "ny", "nz", "X", "Y", "Z", "L", "M", "N",
                                  "CD", "CY", "CL", "Cl", "Cm", "Cn")

#: Columns of every engine's DataFrame, in order.
COLUMNS: tuple[str, ...] = STATE_NAMES + CONTROL_NAMES + DERIVED_NAMES

#: Composite variable of comparisons: Euclidean distance between the positions.
POSITION = "position"

#: Unit of every named quantity (states, controls, derived columns, trim variables).
UNITS: dict[str, str] = {
    POSITION: "m", "x": "m", "y": "m", "z": "m", "V": "m/s",
    "gamma": "rad", "chi": "rad", "alpha": "rad", "beta": "rad", "mu": "rad",
    "p": "rad/s", "q": "rad/s", "r": "rad/s", "chi_dot": "rad/s",
    "F": "N", "eta": "-", "dl": "rad", "dm": "rad", "dn": "rad",
    "qbar": "Pa", "rho": "kg/m^3", "nx": "-", "ny": "-", "nz": "-", "X": "N", "Y": "N", "Z": "N",
    "L": "N m", "M": "N m", "N": "N m", "CD": "-", "CY": "-", "CL": "-", "Cl": "-", "Cm": "-", "Cn": "-",
}

#: Variables that are angles (their differences are wrapped into (-pi, pi]).
ANGLES: frozenset[str] = frozenset({"gamma", "chi", "alpha", "beta", "mu"})
