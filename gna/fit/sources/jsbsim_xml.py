"""Reading what a JSBSim aircraft definition says about its aerodynamics, controls and engines.

Only what the fit needs, from the XML files themselves (``xml.etree``):

* the aerodynamic functions of each axis and the properties they read
  (:func:`aero_functions`), to find the configuration properties to hold at
  zero and the alpha-dot / beta-dot terms to remove;
* the breakpoint ranges of every table over alpha, beta and the surfaces
  (:func:`table_ranges`), the domain covered by the data (JSBSim holds a
  table's end values outside it);
* the output range of the flight-control component that drives a surface
  (:func:`surface_limit`);
* the engines: thruster positions and orientation, and the sea-level static
  thrust of turbine engines (:func:`engines`).

Lengths are returned as written (inches unless a unit says otherwise is not
supported: JSBSim locations here are all ``unit="IN"``); angles in rad.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from ...errors import InputError, describe

#: Properties whose use in a function marks it as an alpha-dot or beta-dot term.
RATE_OF_ANGLE = re.compile(r"aero/(alphadot|betadot)-(rad|deg)_sec")

_LENGTH_TO_IN = {"IN": 1.0, "FT": 12.0, "M": 1.0 / 0.0254}
_ANGLE_TO_RAD = {"RAD": 1.0, "DEG": math.pi / 180.0}


@dataclass(frozen=True)
class AeroFunction:
    """An aerodynamic function: its property name, axis (None for a pre-function) and what it reads."""

    name: str
    axis: str | None
    frame: str | None
    reads: frozenset[str]


@dataclass(frozen=True)
class Thruster:
    """Thrust point (structural frame, inches) and orientation (rad) of one engine."""

    x: float
    y: float
    z: float
    pitch: float
    yaw: float
    engine_file: str


def parse(path: Path) -> ET.Element:
    """The root element of a JSBSim XML file.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    xml.etree.ElementTree.Element
        Its root.

    Raises
    ------
    InputError
        The file cannot be read or is not well-formed XML.
    """
    try:
        return ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise InputError(f"cannot read JSBSim file {path}: {describe(exc)}") from None


def _texts(elem: ET.Element) -> set[str]:
    return {e.text.strip() for e in elem.iter() if e.tag in ("property", "independentVar") and e.text}


def aerodynamics_element(root: ET.Element, aircraft_dir: Path) -> ET.Element:
    """The ``<aerodynamics>`` element (following a ``file=`` reference).

    Parameters
    ----------
    root : xml.etree.ElementTree.Element
        The aircraft file's root.
    aircraft_dir : Path
        The aircraft's folder (where a referenced file is looked for, with or without ``.xml``).

    Returns
    -------
    xml.etree.ElementTree.Element
        The section, or the root of the file it references.

    Raises
    ------
    InputError
        No ``<aerodynamics>`` section, or its referenced file is not found (or unreadable).
    """
    aero = root.find("aerodynamics")
    if aero is None:
        raise InputError(f"the JSBSim aircraft in {aircraft_dir} has no <aerodynamics> section")
    ref = aero.get("file")
    if ref:
        for cand in (aircraft_dir / ref, aircraft_dir / f"{ref}.xml"):
            if cand.is_file():
                return parse(cand)
        raise InputError(f"JSBSim aerodynamics file {ref!r} not found under {aircraft_dir}")
    return aero


def aero_functions(aero: ET.Element) -> list[AeroFunction]:
    """Every function of the aerodynamics section (pre-functions have ``axis=None``).

    Parameters
    ----------
    aero : xml.etree.ElementTree.Element
        The ``<aerodynamics>`` element (:func:`aerodynamics_element`).

    Returns
    -------
    list of AeroFunction
        Pre-functions first, then each axis's functions in file order, with the axis name and frame
        upper-cased and the properties each reads.
    """
    out = []
    for fn in aero.findall("function"):
        out.append(AeroFunction(fn.get("name", ""), None, None, frozenset(_texts(fn))))
    for ax in aero.findall("axis"):
        for fn in ax.findall("function"):
            out.append(
                AeroFunction(
                    fn.get("name", ""),
                    ax.get("name", "").upper(),
                    (ax.get("frame") or "").upper() or None,
                    frozenset(_texts(fn)),
                )
            )
    return out


def angle_rate_functions(functions: list[AeroFunction]) -> list[AeroFunction]:
    """Axis functions that depend, directly or through pre-functions, on alpha-dot or beta-dot.

    Parameters
    ----------
    functions : list of AeroFunction
        The section's functions (:func:`aero_functions`).

    Returns
    -------
    list of AeroFunction
        The axis functions reading :data:`RATE_OF_ANGLE`, or a function that does, at any depth.
    """
    tainted: set[str] = set()
    changed = True
    while changed:
        changed = False
        for f in functions:
            if f.name not in tainted and (any(RATE_OF_ANGLE.search(p) for p in f.reads) or f.reads & tainted):
                tainted.add(f.name)
                changed = True
    return [f for f in functions if f.axis is not None and f.name in tainted]


def _numbers(text: str) -> list[list[float]]:
    rows = []
    for line in (text or "").strip().splitlines():
        line = line.split("<!--")[0].strip()
        if line:
            rows.append([float(x) for x in line.split()])
    return rows


def table_ranges(
    aero: ET.Element, exclude: frozenset[str] = frozenset(), include: frozenset[str] | None = None
) -> dict[str, tuple[float, float, str]]:
    """The range of the breakpoints of the tables over each property they are indexed by.

    The ranges of a property's tables are intersected: the domain where every table has data.

    Parameters
    ----------
    aero : xml.etree.ElementTree.Element
        The ``<aerodynamics>`` element.
    exclude : frozenset of str
        Names of functions whose tables are ignored (e.g. the alpha-dot terms removed from the fit).
    include : frozenset of str, optional
        Only the tables of these functions count (default: every function's).

    Returns
    -------
    dict of str to (float, float, str)
        Property -> ``(min, max, where)`` in the table's units, ``where`` naming the functions that set the
        bounds.

    Raises
    ------
    InputError
        A table whose breakpoints cannot be read as numbers (naming its function and variables).
    """
    out: dict[str, tuple[float, float, str]] = {}

    def add(prop: str, values: list[float], owner: str):
        if not values:
            return
        lo, hi = min(values), max(values)
        if prop in out:
            plo, phi, pwhere = out[prop]
            where = (
                pwhere if (lo <= plo and hi >= phi) else (owner if (lo >= plo and hi <= phi) else f"{pwhere}, {owner}")
            )
            lo, hi = max(lo, plo), min(hi, phi)
        else:
            where = owner
        out[prop] = (lo, hi, where)

    owners = {}
    for fn in aero.iter("function"):
        for table in fn.iter("table"):
            owners.setdefault(id(table), fn.get("name", "?"))
    for table in aero.iter("table"):
        owner = owners.get(id(table), table.get("name", "?"))
        if owner in exclude or (include is not None and owner not in include):
            continue
        ivars = {}
        for iv in table.findall("independentVar"):
            ivars[iv.get("lookup", "row")] = iv.text.strip()
        datas = table.findall("tableData")
        try:
            if "table" in ivars:
                add(ivars["table"], [float(d.get("breakPoint")) for d in datas], owner)
            for d in datas:
                rows = _numbers(d.text)
                if "column" in ivars:
                    add(ivars["column"], rows[0], owner)
                    body = rows[1:]
                else:
                    body = rows
                if "row" in ivars:
                    add(ivars["row"], [r[0] for r in body], owner)
        except (TypeError, ValueError, IndexError):
            raise InputError(f"cannot read the JSBSim table of {owner} over {', '.join(ivars.values())}") from None
    return out


def _system_files(root: ET.Element, aircraft_dir: Path, jsbsim_root: Path) -> list[ET.Element]:
    elems = [e for tag in ("flight_control", "autopilot", "system") for e in root.findall(tag)]
    out = []
    for e in elems:
        ref = e.get("file")
        if not ref:
            out.append(e)
            continue
        for cand in (
            aircraft_dir / "Systems" / f"{ref}.xml",
            aircraft_dir / f"{ref}.xml",
            jsbsim_root / "systems" / f"{ref}.xml",
            aircraft_dir / "Systems" / ref,
        ):
            if cand.is_file():
                out.append(parse(cand))
                break
    return out


def surface_limit(root: ET.Element, aircraft_dir: Path, jsbsim_root: Path, prop: str) -> tuple[float, float] | None:
    """Output range of the flight-control component that writes ``prop``.

    Its ``<range>`` (times its ``<gain>`` for an ``aerosurface_scale``), else its ``<clipto>``; the first
    component found in the flight-control, autopilot and system files.

    Parameters
    ----------
    root : xml.etree.ElementTree.Element
        The aircraft file's root.
    aircraft_dir, jsbsim_root : Path
        The aircraft's folder and JSBSim's root folder (to find the system files).
    prop : str
        The property written, e.g. ``"fcs/elevator-pos-rad"``.

    Returns
    -------
    tuple of float or None
        ``(lo, hi)`` in the property's units, or None when no component with a constant range writes it.
    """
    for sysroot in _system_files(root, aircraft_dir, jsbsim_root):
        for comp in sysroot.iter():
            out = comp.find("output")
            if out is None or (out.text or "").strip() != prop:
                continue
            try:
                gain = float(comp.findtext("gain", "1")) if comp.tag == "aerosurface_scale" else 1.0
            except ValueError:
                gain = 1.0
            for tag in ("range", "clipto"):
                r = comp.find(tag)
                if r is not None and r.findtext("min") is not None and r.findtext("max") is not None:
                    try:
                        lo, hi = float(r.findtext("min")) * gain, float(r.findtext("max")) * gain
                    except ValueError:
                        continue
                    return min(lo, hi), max(lo, hi)
    return None


#: Flight-control components whose steady output is a function of one input that :func:`surface_copies` follows.
COPY_COMPONENTS = ("aerosurface_scale", "pure_gain", "summer", "actuator", "lag_filter")


def _copy_function(comp: ET.Element, negate: bool):
    """The steady-state map input -> output of one FCS component, or None when not a constant map.

    ``aerosurface_scale``: JSBSim's zero-centred scaling (``x/domain_max *
    range_max`` for ``x > 0``, ``x/domain_min * range_min`` below; the
    linear domain -> range map when ``<zero_centered>`` is false) times the
    gain; ``pure_gain``: the gain; ``summer``: plus the bias; ``actuator``
    and ``lag_filter``: the input (steady state).  ``<clipto>`` applies last.
    """

    def num(path, default):
        text = comp.findtext(path)
        if text is None:
            return default
        return float(text)  # a property name raises ValueError: not a constant map

    try:
        kind = comp.tag
        gain = num("gain", 1.0)
        clip = comp.find("clipto")
        lo_c = num("clipto/min", -math.inf) if clip is not None else -math.inf
        hi_c = num("clipto/max", math.inf) if clip is not None else math.inf
        if kind == "aerosurface_scale":
            dmin, dmax = num("domain/min", -1.0), num("domain/max", 1.0)
            rmin, rmax = num("range/min", None), num("range/max", None)
            if rmin is None or rmax is None:
                return None
            centred = comp.findtext("zero_centered", "true").strip().lower() not in ("false", "0")

            def base(x):
                if centred:
                    return 0.0 if x == 0 else (x / dmax * rmax if x > 0 else x / dmin * rmin)
                return rmin + (x - dmin) * (rmax - rmin) / (dmax - dmin)
        elif kind == "pure_gain":

            def base(x):
                return x
        elif kind == "summer":
            bias = num("bias", 0.0)

            def base(x):
                return x + bias
        elif kind in ("actuator", "lag_filter"):
            gain = 1.0

            def base(x):
                return x
        else:
            return None
    except ValueError:
        return None
    sign = -1.0 if negate else 1.0
    return lambda x: min(max(gain * base(sign * x), lo_c), hi_c)


def surface_copies(
    root: ET.Element, aircraft_dir: Path, jsbsim_root: Path, sources
) -> list[tuple[str, str, object, str]]:
    """The flight-control outputs computed from the surface properties alone (normalised copies, scalings).

    With the flight-control system switched off these properties keep their
    initial 0 unless set; an aircraft whose aerodynamics read
    ``fcs/elevator-pos-norm`` instead of ``fcs/elevator-pos-rad`` then loses
    the surface's effect.  Components with one input (a source or an earlier
    copy) of the kinds :data:`COPY_COMPONENTS` with constant parameters are
    followed.

    Parameters
    ----------
    root : xml.etree.ElementTree.Element
        The aircraft file's root.
    aircraft_dir, jsbsim_root : Path
        Folders to find the system files.
    sources : iterable of str
        The surface properties written directly.

    Returns
    -------
    list of (output, input, function, component kind)
        In an order where every input is a source or an earlier output;
        ``function(input value) -> output value``.
    """
    known = set(sources)
    comps = [
        c
        for sysroot in _system_files(root, aircraft_dir, jsbsim_root)
        for c in sysroot.iter()
        if c.tag in COPY_COMPONENTS
    ]
    out, done = [], set()
    changed = True
    while changed:
        changed = False
        for comp in comps:
            inputs = [(i.text or "").strip() for i in comp.findall("input")]
            outputs = [(o.text or "").strip() for o in comp.findall("output")]
            if len(inputs) != 1 or not outputs:
                continue
            negate = inputs[0].startswith("-")
            src = inputs[0].lstrip("-").strip()
            if src not in known:
                continue
            f = _copy_function(comp, negate)
            if f is None:
                continue
            for o in outputs:
                if o and o not in known and o not in done:
                    out.append((o, src, f, comp.tag))
                    done.add(o)
                    known.add(o)
                    changed = True
    return out


def _location(elem: ET.Element | None, what: str) -> tuple[float, float, float]:
    if elem is None:
        raise InputError(f"JSBSim {what} has no <location>")
    f = _LENGTH_TO_IN.get(elem.get("unit", "IN").upper())
    if f is None:
        raise InputError(f"JSBSim {what}: unsupported length unit {elem.get('unit')!r}")
    return tuple(float(elem.findtext(k, "0")) * f for k in ("x", "y", "z"))


def engines(root: ET.Element) -> list[Thruster]:
    """Thrusters of the propulsion section, in order.

    Parameters
    ----------
    root : xml.etree.ElementTree.Element
        The aircraft file's root.

    Returns
    -------
    list of Thruster
        Each engine's thruster location (structural frame [in]; the engine's own location when the
        thruster has none) and orientation [rad]; empty without a propulsion section.

    Raises
    ------
    InputError
        An engine without a location, or a location in an unsupported length unit.
    """
    out = []
    prop = root.find("propulsion")
    if prop is None:
        return out
    for eng in prop.findall("engine"):
        thr = eng.find("thruster")
        where = f"engine {eng.get('file')!r}"
        loc = thr.find("location") if thr is not None else None
        x, y, z = _location(loc if loc is not None else eng.find("location"), where)
        orient = thr.find("orient") if thr is not None else None
        pitch = yaw = 0.0
        if orient is not None:
            f = _ANGLE_TO_RAD.get(orient.get("unit", "RAD").upper(), 1.0)
            pitch = float(orient.findtext("pitch", "0")) * f
            yaw = float(orient.findtext("yaw", "0")) * f
        out.append(Thruster(x, y, z, pitch, yaw, eng.get("file", "")))
    return out


def turbine_static_thrust(engine_file: str, aircraft_dir: Path, jsbsim_root: Path) -> tuple[float, str] | None:
    """Sea-level static thrust of a turbine engine file (``maxthrust`` if augmented, else ``milthrust``).

    Parameters
    ----------
    engine_file : str
        The engine's file name without ``.xml``.
    aircraft_dir, jsbsim_root : Path
        Where the file is looked for: ``<aircraft_dir>/Engines``, then ``<jsbsim_root>/engine``.

    Returns
    -------
    tuple of (float, str) or None
        Thrust [lbf] and which element it is (``"<file> <maxthrust>"``); None for a missing file, another
        engine type or a missing rating.

    Raises
    ------
    InputError
        The engine file cannot be read (:func:`parse`).
    """
    for cand in (aircraft_dir / "Engines" / f"{engine_file}.xml", jsbsim_root / "engine" / f"{engine_file}.xml"):
        if cand.is_file():
            eng = parse(cand)
            t = eng if eng.tag == "turbine_engine" else eng.find("turbine_engine")
            if t is None:
                return None
            aug = (t.findtext("augmented") or "0").strip() not in ("0", "")
            key = "maxthrust" if aug and t.findtext("maxthrust") else "milthrust"
            if t.findtext(key) is None:
                return None
            return float(t.findtext(key)), f"{cand.name} <{key}>"
    return None


def engine_kind(engine_file: str, aircraft_dir: Path, jsbsim_root: Path) -> str:
    """The element name of an engine file's root (``piston_engine``, ``turbine_engine``, ``turboprop_engine``...).

    Parameters
    ----------
    engine_file : str
        The engine's file name without ``.xml``.
    aircraft_dir, jsbsim_root : Path
        Where the file is looked for: ``<aircraft_dir>/Engines``, then ``<jsbsim_root>/engine``.

    Returns
    -------
    str
        The tag, ``"unknown engine"`` when the file is not found.

    Raises
    ------
    InputError
        The engine file cannot be read (:func:`parse`).
    """
    for cand in (aircraft_dir / "Engines" / f"{engine_file}.xml", jsbsim_root / "engine" / f"{engine_file}.xml"):
        if cand.is_file():
            eng = parse(cand)
            if eng.tag.endswith("_engine"):
                return eng.tag
            inner = next((c.tag for c in eng if c.tag.endswith("_engine")), None)
            return inner or eng.tag
    return "unknown engine"
