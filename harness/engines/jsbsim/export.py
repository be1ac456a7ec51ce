"""Export gflat aircraft to JSBSim aircraft files (``aircraft_xml/<id>/<id>.xml``).

The file is generated from the aircraft's data alone, so that any aircraft of
:func:`gna.aircraft.list_aircraft` (and any variant built in memory) exports:

* **units**: native English units (ft, ft^2, in, slug ft^2, lbf, slug/ft^3), converted from SI with the
  exact factors of :mod:`gna.units` (JSBSim's own unit factors are truncated, so no SI unit attribute is
  ever written);
* **aerodynamics**: JSBSim function trees generated from the GNA term table,
  one ``<sum>`` of ``<product>`` monomials per coefficient, as pre-functions
  ``aero/gflat/CD`` ... ``aero/gflat/Cn``.  They use ``aero/gflat/phat|qhat|rhat``
  computed explicitly from ``velocities/{p,q,r}-aero-rad_sec`` (JSBSim's
  ``aero/bi2vel`` lags one frame in pre-functions).  Forces go on the
  ``STABILITY`` axes (C_D along -x_s, C_Y along y, C_L along -z_s: exactly the
  in-house definition), moments on the body ``ROLL``/``PITCH``/``YAW`` axes about
  the ``AERORP`` = the model's moment reference ``x_ref``; JSBSim transfers them
  to the CG ``x_cg`` with ``r x F`` as the in-house model does;
* **dynamic pressure**: ``aero/gflat/qbar-psf = 0.5 rho V^2`` with the in-house
  density model written into the file (``aero/gflat/rho-slug_ft3``): the ISA of
  :class:`gna.atmosphere.ISA` (geometric altitude used as geopotential, unlike
  JSBSim's own atmosphere) when ``gflat/density-model`` is 0, the constant
  ``gflat/density-slug_ft3`` when it is 1.  JSBSim's atmosphere is not used by
  the forces;
* **thrust**: two ``BODY``-frame external forces ``engine1`` (left, y = -y_p)
  and ``engine2`` (right, y = +y_p) at the CG's x, direction
  ``(cos eps, 0, -sin eps)``; their magnitudes (lbf) are
  ``external_reactions/engine{1,2}/magnitude``.  A single-engine aircraft gets
  the same two forces, both on the symmetry plane, so that every aircraft has
  the same interface (F1 + F2 = F); a thrust line offset below the CG moves
  both forces there, a propeller torque is a ``BODY`` moment about x whose
  magnitude is ``torque_arm (F1 + F2)`` (:mod:`gna.eom`'s propulsive moments);
* **controls**: declared properties ``ctrl/delta-{l,m,n}-rad``;
* **ground effect**, only when asked (an engine flying an environment with one): the correction of
  :mod:`gna.ground_effect` as functions of JSBSim's ``aero/h_b-cg-ft`` (:mod:`.ground`); the lift and drag
  axes then use the corrected coefficients.  The free-air file is unchanged;
* **planet**: a flat-earth approximation, a non-rotating sphere of radius :data:`PLANET_RADIUS_FT`
  without J2 whose ``GM = g (R + h_ref)^2`` gives exactly ``g`` at the reference altitude ``h_ref``;
* **mass**: ``emptywt = m[slug] * 32.174049`` lbf (JSBSim divides by that number),
  inertia with ``negated_crossproduct_inertia="false"`` and the flight-dynamics ``+Ixz``.

Deterministic output: ``gflat export-jsbsim --all`` reproduces the committed ``aircraft_xml/`` byte for byte.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gna import units
from gna.aero import AERO_VARIABLES, COEFFICIENTS
from gna.aircraft import Aircraft
from gna.atmosphere import H_TROPO, LAPSE, R_AIR, RHO0, RHO_TROPO, T0, T_TROPO
from gna.errors import InputError
from gna.ground_effect import GroundEffect

from .ground import ground_effect_functions
from .xmlwriter import XMLWriter, comment_text, number_text


def _escape(text: str) -> str:
    """``&``, ``<`` and ``>`` of ``text`` as XML entities (:func:`xml.sax.saxutils.escape`'s result, without
    importing :mod:`xml.sax.saxutils`, which imports :mod:`urllib.request` and :mod:`http.client`: 50 ms of every
    command's start)."""
    return text.replace("&", "&amp;").replace(">", "&gt;").replace("<", "&lt;")


#: Version of the file layout (bump when the generated structure changes).
FORMAT_VERSION = 1

#: Radius of the flat-earth planet [ft]: balances the sphere's curvature (errors ~ V^2 t^2 / R, 3e-4 m in
#: 10 s at 150 m/s with 1e10 ft) against ECEF round-off (~R * 1e-16 per step; its accumulation along a steady climb
#: is corrected by :mod:`.roundoff`); see docs/jsbsim.md.
PLANET_RADIUS_FT = 1.0e11

#: JSBSim's pound-per-slug factor: it computes the mass as ``emptywt / SLUG_TO_LB``.
SLUG_TO_LB = 32.174049

#: Control properties declared in every file (rad).
CONTROL_PROPERTIES: dict[str, str] = {"dl": "ctrl/delta-l-rad", "dm": "ctrl/delta-m-rad", "dn": "ctrl/delta-n-rad"}

#: Thrust magnitude properties (lbf) of engine 1 (left) and engine 2 (right).
THRUST_PROPERTIES: tuple[str, str] = ("external_reactions/engine1/magnitude", "external_reactions/engine2/magnitude")

#: Density model selector (0: ISA of gna.atmosphere, 1: constant) and the constant [slug/ft^3].
DENSITY_MODEL_PROPERTY = "gflat/density-model"
DENSITY_CONSTANT_PROPERTY = "gflat/density-slug_ft3"

#: Our own derived properties.
RHO_PROPERTY = "aero/gflat/rho-slug_ft3"
QBAR_PROPERTY = "aero/gflat/qbar-psf"
COEFFICIENT_PROPERTIES: dict[str, str] = {c: f"aero/gflat/{c}" for c in COEFFICIENTS}

#: JSBSim property of each aerodynamic variable of the term tables.
VARIABLE_PROPERTIES: dict[str, str] = {
    "alpha": "aero/alpha-rad",
    "beta": "aero/beta-rad",
    "phat": "aero/gflat/phat",
    "qhat": "aero/gflat/qhat",
    "rhat": "aero/gflat/rhat",
    "dl": CONTROL_PROPERTIES["dl"],
    "dm": CONTROL_PROPERTIES["dm"],
    "dn": CONTROL_PROPERTIES["dn"],
}
assert tuple(VARIABLE_PROPERTIES) == AERO_VARIABLES

#: Altitude property the density model reads.
ALTITUDE_PROPERTY = "position/h-sl-ft"


@dataclass(frozen=True)
class FlatPlanet:
    """The flat-earth approximation written as a JSBSim ``<planet>``.

    Parameters
    ----------
    g : float
        Gravity [m/s^2] at the reference altitude.
    h_ref : float
        Reference altitude [m] where JSBSim's ``GM/r^2`` equals ``g`` exactly.
    radius_ft : float
        Sphere radius [ft]; gravity varies by ``2 dh / R`` relative (6.6e-8 per
        1000 m at 1e11 ft) and the horizon drops by ``d^2 / 2R``.
    """

    g: float = units.G0
    h_ref: float = 0.0
    radius_ft: float = PLANET_RADIUS_FT

    def __post_init__(self):
        for name in ("g", "h_ref", "radius_ft"):
            if not math.isfinite(getattr(self, name)):
                raise InputError(f"flat planet: {name} must be finite, got {getattr(self, name)}")
        if not self.g > 0 or not self.radius_ft > 0:
            raise InputError(f"flat planet: g and radius must be positive (g = {self.g}, R = {self.radius_ft} ft)")

    @property
    def GM(self) -> float:
        """Gravitational parameter [ft^3/s^2]."""
        r = self.radius_ft + self.h_ref / units.FT
        return self.g / units.FT * r * r


def _planet_element(w: XMLWriter, planet: FlatPlanet) -> None:
    """The ``<planet>`` element: a non-rotating sphere without J2."""
    w.open("planet", 'name="gflat flat earth"')
    w.leaf("semimajor_axis", planet.radius_ft, 'unit="FT"')
    w.leaf("semiminor_axis", planet.radius_ft, 'unit="FT"')
    w.leaf("rotation_rate", 0.0, 'unit="RAD/SEC"')
    w.leaf("GM", planet.GM, 'unit="FT3/SEC2"')
    w.leaf("J2", 0.0)
    w.close("planet")


def planet_xml(planet: FlatPlanet) -> str:
    """A planet file of ``planet`` alone, for ``FGFDMExec.load_planet`` (the element :func:`aircraft_xml` writes).

    Parameters
    ----------
    planet : FlatPlanet
        The flat-earth planet.

    Returns
    -------
    str
        The XML document.
    """
    w = XMLWriter()
    w.line('<?xml version="1.0"?>')
    _planet_element(w, planet)
    return w.text()


def _monomial_product(w: XMLWriter, value: float, exponents) -> None:
    """``value * v1 * v1 * v2 ...`` in the variable order of the term table."""
    factors = []
    for name, e in zip(AERO_VARIABLES, exponents):
        factors += [VARIABLE_PROPERTIES[name]] * int(e)
    if not factors:
        w.leaf("value", value)
        return
    w.open("product")
    w.leaf("value", value)
    for prop in factors:
        w.leaf("property", prop)
    w.close("product")


def _density_function(w: XMLWriter) -> None:
    """ISA density of :class:`gna.atmosphere.ISA` in slug/ft^3 as a function of h [ft], or the constant."""
    k_tropo = LAPSE * units.FT / T0  # 1/ft
    h_tropo_ft = H_TROPO / units.FT
    k_strato = units.G0 * units.FT / (R_AIR * T_TROPO)  # 1/ft
    w.line("<!-- air density [slug/ft^3]: gflat/density-model 1 = constant gflat/density-slug_ft3; 0 = ISA of")
    w.line("     gna.atmosphere (geometric altitude used as geopotential, troposphere and lower stratosphere) -->")
    w.open("function", f'name="{RHO_PROPERTY}"')
    w.open("ifthen")
    w.open("eq")
    w.leaf("property", DENSITY_MODEL_PROPERTY)
    w.leaf("value", 1)
    w.close("eq")
    w.leaf("property", DENSITY_CONSTANT_PROPERTY)
    w.open("ifthen")
    w.open("le")
    w.leaf("property", ALTITUDE_PROPERTY)
    w.leaf("value", h_tropo_ft)
    w.close("le")
    w.open("product")
    w.leaf("value", RHO0 / units.SLUG_FT3)
    w.open("pow")
    w.open("difference")
    w.leaf("value", 1)
    w.open("product")
    w.leaf("value", k_tropo)
    w.leaf("property", ALTITUDE_PROPERTY)
    w.close("product")
    w.close("difference")
    w.leaf("value", units.G0 / (R_AIR * LAPSE) - 1.0)
    w.close("pow")
    w.close("product")
    w.open("product")
    w.leaf("value", RHO_TROPO / units.SLUG_FT3)
    w.open("exp")
    w.open("product")
    w.leaf("value", -k_strato)
    w.open("difference")
    w.leaf("property", ALTITUDE_PROPERTY)
    w.leaf("value", h_tropo_ft)
    w.close("difference")
    w.close("product")
    w.close("exp")
    w.close("product")
    w.close("ifthen")
    w.close("ifthen")
    w.close("function")


def _rate_function(w: XMLWriter, name: str, rate_property: str, length_ft: float) -> None:
    """``rate * length / (2 V)``."""
    w.open("function", f'name="{name}"')
    w.open("quotient")
    w.open("product")
    w.leaf("value", 0.5 * length_ft)
    w.leaf("property", rate_property)
    w.close("product")
    w.leaf("property", "velocities/vt-fps")
    w.close("quotient")
    w.close("function")


def _axis(w: XMLWriter, axis: str, frame: str | None, fname: str, coefficient: str, scale: float, what: str) -> None:
    w.open("axis", f'name="{axis}"' + (f' frame="{frame}"' if frame else ""))
    w.line(f"<!-- {what} -->")
    w.open("function", f'name="{fname}"')
    w.open("product")
    w.leaf("property", QBAR_PROPERTY)
    w.leaf("value", scale)
    w.leaf("property", COEFFICIENT_PROPERTIES.get(coefficient, coefficient))
    w.close("product")
    w.close("function")
    w.close("axis")


def aircraft_xml(
    aircraft: Aircraft, planet: FlatPlanet | None = FlatPlanet(), ground_effect: GroundEffect | None = None
) -> str:
    """JSBSim aircraft file of ``aircraft`` (text).

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft (any, bundled or built in memory).
    planet : FlatPlanet or None
        The flat-earth planet written into the file; ``None`` writes no
        ``<planet>`` (JSBSim then flies its default rotating WGS84 Earth).
    ground_effect : GroundEffect, optional
        Adds the ground effect of :mod:`gna.ground_effect` (:mod:`.ground`); None (default): free air.

    Returns
    -------
    str
        The XML document; identical inputs give identical bytes.
    """
    geo, mass, eng = aircraft.geometry, aircraft.mass, aircraft.propulsion
    S_ft2 = geo.S / units.FT2
    b_ft = geo.b / units.FT
    c_ft = geo.cbar / units.FT
    w = XMLWriter()
    w.line('<?xml version="1.0"?>')
    w.line(
        f"<!-- Generated by 'gflat export-jsbsim' (harness/engines/jsbsim/export.py, format {FORMAT_VERSION}) from the gflat "
        f"aircraft '{comment_text(aircraft.id)}'. Do not edit: regenerate. -->"
    )
    w.open("fdm_config", f'name="{_escape(aircraft.id)}" version="2.0" release="PRODUCTION"')
    w.line()
    w.open("fileheader")
    w.leaf("author", "gflat export-jsbsim")
    w.leaf("description", _escape(aircraft.name))
    for key in sorted(aircraft.provenance):
        w.leaf("note", _escape(f"{key}: {aircraft.provenance[key]}"))
    w.leaf(
        "note",
        "Conventions: CD, CL stability axes (drag along -x_s, lift along -z_s); CY, Cl, Cm, Cn body axes, "
        "moments about AERORP = x_ref; phat = p b/2V, qhat = q cbar/2V, rhat = r b/2V; angles and "
        "surfaces in rad (ctrl/delta-l-rad aileron, ctrl/delta-m-rad elevator, ctrl/delta-n-rad rudder). "
        "Structural x is measured aft of the mean aerodynamic chord's leading edge.",
    )
    w.close("fileheader")
    w.line()

    if planet is not None:
        w.line(
            f"<!-- flat-earth approximation: non-rotating sphere, no J2, GM = g (R + h_ref)^2 with g = "
            f"{number_text(planet.g)} m/s^2 at h_ref = {number_text(planet.h_ref)} m -->"
        )
        _planet_element(w, planet)
        w.line()

    w.open("metrics")
    w.leaf("wingarea", S_ft2, 'unit="FT2"')
    w.leaf("wingspan", b_ft, 'unit="FT"')
    w.leaf("chord", c_ft, 'unit="FT"')
    w.line("<!-- moment reference x_ref, structural frame (x aft of the MAC leading edge, y right, z up) -->")
    w.location("AERORP", geo.x_ref / units.IN, 0.0, 0.0)
    w.location("EYEPOINT", geo.x_cg / units.IN, 0.0, 0.0)
    w.location("VRP", 0.0, 0.0, 0.0)
    w.close("metrics")
    w.line()

    w.open("mass_balance", 'negated_crossproduct_inertia="false"')
    w.line(f"<!-- m = {number_text(mass.mass)} kg; Ixz = +integral(x z dm) (flight-dynamics sign) -->")
    w.leaf("ixx", mass.Ixx / units.SLUG_FT2, 'unit="SLUG*FT2"')
    w.leaf("iyy", mass.Iyy / units.SLUG_FT2, 'unit="SLUG*FT2"')
    w.leaf("izz", mass.Izz / units.SLUG_FT2, 'unit="SLUG*FT2"')
    w.leaf("ixy", 0.0, 'unit="SLUG*FT2"')
    w.leaf("ixz", mass.Ixz / units.SLUG_FT2, 'unit="SLUG*FT2"')
    w.leaf("iyz", 0.0, 'unit="SLUG*FT2"')
    w.leaf("emptywt", mass.mass / units.SLUG * SLUG_TO_LB, 'unit="LBS"')
    w.location("CG", geo.x_cg / units.IN, 0.0, 0.0)
    w.close("mass_balance")
    w.line()

    w.line("<ground_reactions/>")
    w.line()

    yp_in = eng.y_p / units.IN if eng.count == 2 else 0.0
    w.open("external_reactions")
    w.line(
        f"<!-- thrust: engine 1 left (y = -y_p), engine 2 right (y = +y_p), tilt eps = {number_text(eng.epsilon)} rad "
        f"nose-up; magnitudes in lbf{'; single engine: both forces on the symmetry plane' if eng.count == 1 else ''} -->"
    )
    # The thrust line thrust_line_offset below the CG: the forces at body (o sin eps, y, o cos eps) from it.
    o = eng.thrust_line_offset
    x_t = geo.x_cg / units.IN - (o * math.sin(eng.epsilon) / units.IN if o != 0.0 else 0.0)
    z_t = -o * math.cos(eng.epsilon) / units.IN if o != 0.0 else 0.0
    for k, y_in in ((1, -yp_in), (2, yp_in)):
        w.open("force", f'name="engine{k}" frame="BODY"')
        w.location(None, x_t, y_in, z_t)
        w.open("direction")
        w.leaf("x", math.cos(eng.epsilon))
        w.leaf("y", 0.0)
        w.leaf("z", -math.sin(eng.epsilon))
        w.close("direction")
        w.close("force")
    if eng.torque_arm != 0.0:
        # The propeller torque, torque_arm x the total thrust [lbf ft], about body x.
        w.open("moment", 'name="propeller-torque" frame="BODY"')
        w.open("function", 'name="external_reactions/propeller-torque/magnitude"')
        w.open("product")
        w.leaf("value", eng.torque_arm / units.FT)
        w.open("sum")
        for prop in THRUST_PROPERTIES:
            w.leaf("property", prop)
        w.close("sum")
        w.close("product")
        w.close("function")
        w.open("direction")
        w.leaf("x", 1.0)
        w.leaf("y", 0.0)
        w.leaf("z", 0.0)
        w.close("direction")
        w.close("moment")
    w.close("external_reactions")
    w.line()

    w.open("aerodynamics")
    w.line("<!-- inputs written by the driver (declared so that functions bind at load) -->")
    for name, prop in CONTROL_PROPERTIES.items():  # noqa: B007
        w.leaf("property", prop, 'value="0"')
    w.leaf("property", DENSITY_MODEL_PROPERTY, 'value="0"')
    w.leaf("property", DENSITY_CONSTANT_PROPERTY, f'value="{number_text(RHO0 / units.SLUG_FT3)}"')
    w.line()
    _density_function(w)
    w.line()
    w.line("<!-- dynamic pressure from the gflat density [psf] -->")
    w.open("function", f'name="{QBAR_PROPERTY}"')
    w.open("product")
    w.leaf("value", 0.5)
    w.leaf("property", RHO_PROPERTY)
    w.leaf("property", "velocities/vt-fps")
    w.leaf("property", "velocities/vt-fps")
    w.close("product")
    w.close("function")
    w.line()
    w.line("<!-- nondimensional rates -->")
    _rate_function(w, VARIABLE_PROPERTIES["phat"], "velocities/p-aero-rad_sec", b_ft)
    _rate_function(w, VARIABLE_PROPERTIES["qhat"], "velocities/q-aero-rad_sec", c_ft)
    _rate_function(w, VARIABLE_PROPERTIES["rhat"], "velocities/r-aero-rad_sec", b_ft)
    w.line()
    w.line(
        f"<!-- coefficients: GNA term table '{comment_text(aircraft.aero.structure)}', {len(aircraft.aero)} terms -->"
    )
    for coef in COEFFICIENTS:
        terms = aircraft.aero.terms_of(coef)
        w.open("function", f'name="{COEFFICIENT_PROPERTIES[coef]}"')
        if not terms:
            w.line("<!-- no term -->")
            w.leaf("value", 0.0)
        elif len(terms) == 1:  # a one-argument <sum> draws a JSBSim warning
            w.line(f"<!-- theta{terms[0].index}: {comment_text(terms[0].monomial)} -->")
            _monomial_product(w, terms[0].value, terms[0].exponents)
        else:
            w.open("sum")
            for t in terms:
                w.line(f"<!-- theta{t.index}: {comment_text(t.monomial)} -->")
                _monomial_product(w, t.value, t.exponents)
            w.close("sum")
        w.close("function")
    w.line()
    cl, cd = "CL", "CD"
    if ground_effect is not None:
        cl, cd = ground_effect_functions(
            w, aircraft, ground_effect, COEFFICIENT_PROPERTIES["CL"], COEFFICIENT_PROPERTIES["CD"]
        )
        w.line()
    _axis(w, "X", "STABILITY", "aero/force/gflat-drag-lbs", cd, S_ft2, "drag, positive aft along -x_s")
    _axis(w, "Y", "STABILITY", "aero/force/gflat-side-lbs", "CY", S_ft2, "side force along y")
    _axis(w, "Z", "STABILITY", "aero/force/gflat-lift-lbs", cl, S_ft2, "lift, positive along -z_s")
    _axis(w, "ROLL", None, "aero/moment/gflat-roll-lbsft", "Cl", S_ft2 * b_ft, "body axes, about AERORP")
    _axis(w, "PITCH", None, "aero/moment/gflat-pitch-lbsft", "Cm", S_ft2 * c_ft, "body axes, about AERORP")
    _axis(w, "YAW", None, "aero/moment/gflat-yaw-lbsft", "Cn", S_ft2 * b_ft, "body axes, about AERORP")
    w.close("aerodynamics")
    w.line()
    w.close("fdm_config")
    return w.text()
