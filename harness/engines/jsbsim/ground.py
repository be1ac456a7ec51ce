"""The ground effect of :mod:`gna.ground_effect` as JSBSim functions (written by :mod:`.export` when asked).

JSBSim's ``aero/h_b-cg-ft`` is, despite its name, a ratio: the distance of the
CG above the terrain over the wing span (``FGAuxiliary``: ``DistanceAGL /
Wingspan``, evaluated each frame before the aerodynamics).  The exported files
leave JSBSim's terrain at the planet's surface (elevation 0, also on the WGS84
Earth, where the in-house ``z`` is minus the height above the ellipsoid), so
the in-house ``h/b = (-z - elevation)/b`` (height of the CG, no attitude
correction) is ``aero/h_b-cg-ft - elevation/b``.  From it:

* ``aero/gflat/ground/phi = (16 h/b)^2 / (1 + (16 h/b)^2)`` (McCormick 1995, ch. 7);
* ``aero/gflat/ground/k_L = (1 + K)/(1 + K phi)``, ``K = a0/(pi e A)``;
* ``aero/gflat/ground/CL = k_L CL`` and ``aero/gflat/ground/CD = CD + (phi k_L^2 - 1) CL^2/(pi e A)``,
  which the drag and lift axes then use.
"""

from __future__ import annotations

import math

from gna.aircraft import Aircraft
from gna.ground_effect import MCCORMICK_CONSTANT, GroundEffect

from .xmlwriter import XMLWriter, comment_text, number_text

#: JSBSim's height of the CG above the terrain over the span.
JSBSIM_H_OVER_B_PROPERTY = "aero/h_b-cg-ft"

#: Our ground-effect properties: h/b, McCormick's phi, the lift factor k_L, the corrected CL and CD.
GROUND_EFFECT_PROPERTIES: dict[str, str] = {k: f"aero/gflat/ground/{k}" for k in ("h_b", "phi", "k_L", "CL", "CD")}


def _tree(w: XMLWriter, node) -> None:
    """Write a function tree: a float is a ``<value>``, a str a ``<property>``, a tuple ``(op, *args)``."""
    if isinstance(node, tuple):
        w.open(node[0])
        for arg in node[1:]:
            _tree(w, arg)
        w.close(node[0])
    elif isinstance(node, str):
        w.leaf("property", node)
    else:
        w.leaf("value", node)


def ground_effect_functions(w: XMLWriter, aircraft: Aircraft, ge: GroundEffect, cl: str, cd: str) -> tuple[str, str]:
    """Write the ground-effect functions (see the module notes) into an ``<aerodynamics>`` element.

    Parameters
    ----------
    w : XMLWriter
        The file being written, inside ``<aerodynamics>``, after the coefficient functions.
    aircraft : Aircraft
        Span ``b`` and wing area ``S`` [m, m^2] (aspect ratio ``A = b^2/S``).
    ge : GroundEffect
        Ground elevation [m], Oswald factor and section lift slope [1/rad].
    cl, cd : str
        Properties of the free-air lift and drag coefficients (stability axes).

    Returns
    -------
    tuple of str
        Properties of the corrected ``(CL, CD)``.
    """
    geo = aircraft.geometry
    A = geo.b * geo.b / geo.S
    K = ge.section_lift_slope / (math.pi * ge.oswald * A)
    c2 = MCCORMICK_CONSTANT * MCCORMICK_CONSTANT
    P = GROUND_EFFECT_PROPERTIES
    x2 = ("product", c2, P["h_b"], P["h_b"])
    functions = {
        "h_b": ("difference", JSBSIM_H_OVER_B_PROPERTY, ge.elevation / geo.b),
        "phi": ("quotient", x2, ("sum", 1.0, x2)),
        "k_L": ("quotient", 1.0 + K, ("sum", 1.0, ("product", K, P["phi"]))),
        "CL": ("product", P["k_L"], cl),
        "CD": (
            "sum",
            cd,
            (
                "product",
                1.0 / (math.pi * ge.oswald * A),
                cl,
                cl,
                ("difference", ("product", P["phi"], P["k_L"], P["k_L"]), 1.0),
            ),
        ),
    }
    w.line(
        f"<!-- {comment_text(ge.describe())}: h/b = {JSBSIM_H_OVER_B_PROPERTY} - elevation/b (JSBSim's terrain "
        f"at 0); phi = (16 h/b)^2/(1 + (16 h/b)^2); k_L = (1 + K)/(1 + K phi), K = a0/(pi e A) = "
        f"{number_text(K)}, A = {number_text(A)}; CL_g = k_L CL; CD_g = CD + (phi k_L^2 - 1) CL^2/(pi e A) -->"
    )
    for key, tree in functions.items():
        w.open("function", f'name="{P[key]}"')
        _tree(w, tree)
        w.close("function")
    return P["CL"], P["CD"]
