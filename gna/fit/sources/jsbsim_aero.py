"""The aerodynamics of any JSBSim aircraft, evaluated through JSBSim itself.

Method (measured in ``shared/notes/jsbsim_aero_sampling.md``):

1. Load the model, **switch the flight-control system off**
   (``simulation/models/FGFCS/enabled = 0``) so that surface positions written
   from Python are not overwritten, and hold every configuration property the
   aerodynamics reads (``fcs/*``, ``gear/*``, ``systems/*`` other than the
   three surfaces: flaps, speedbrake, spoilers, LEF, gear, BLC, propeller
   thrust coefficient...) at 0 -- clean configuration, gear up (the FCS
   would otherwise leave ``gear/gear-pos-norm`` at 1).
2. For each point: Euler angles (0, alpha, 0), body velocities
   ``V (cos a cos b, sin b, sin a cos b)`` at the reference Mach and altitude,
   body rates from the nondimensional ones, surface positions; ``run_ic()``.
3. Read the body-axis aerodynamic forces and moments about the CG, remove
   the alpha-dot / beta-dot functions (inside ``run_ic`` alpha-dot comes from
   non-trimmed accelerations; the GNA structure has no such term) and divide
   by ``qbar S`` (``b``, ``cbar``).

Surfaces: ``dm`` is the elevator property (trailing edge down positive),
``dn`` the rudder property (trailing edge left positive), ``dl`` minus the
aileron property: JSBSim's positive aileron rolls right (``Cl > 0``), the
project's positive ``dl`` (right aileron trailing edge down) rolls left.

Coefficients are per reference Mach: Mach effects, power effects, flaps,
gear, speedbrake and ground effect are outside the GNA structure.
"""

from __future__ import annotations

import contextlib
import math
import re
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gna.errors import expand_home

from ... import units
from ...aero import AeroState, Coefficients
from ...errors import InputError, UnknownAircraftError
from . import jsbsim_xml as jx
from .base import SourceModel, broadcast_state, stability_from_body

#: Candidate properties for each surface, with the sign that maps them to the project's variable.
SURFACE_CANDIDATES: dict[str, tuple[tuple[str, float], ...]] = {
    "dm": (("fcs/elevator-pos-rad", 1.0),),
    "dl": (("fcs/left-aileron-pos-rad", -1.0), ("fcs/aileron-pos-rad", -1.0)),
    "dn": (("fcs/rudder-pos-rad", 1.0),),
}

#: Properties the FCS model derives from the surfaces (not held at 0).
DERIVED_SURFACE_PROPERTIES = ("fcs/mag-elevator-pos-rad", "fcs/mag-aileron-pos-rad", "fcs/mag-rudder-pos-rad")

#: The pilot's command of each surface (JSBSim's normalised FCS inputs, -1 .. 1).
PILOT_COMMANDS = {"dl": "fcs/aileron-cmd-norm", "dm": "fcs/elevator-cmd-norm", "dn": "fcs/rudder-cmd-norm"}

#: Reference altitude [m] and level-flight lift coefficient that set the default reference condition.
DEFAULT_ALTITUDE = 1000.0
DEFAULT_LIFT_COEFFICIENT = 0.4

_LONGITUDINAL_AXES = frozenset({"LIFT", "DRAG", "PITCH", "X", "Z"})
_LATERAL_AXES = frozenset({"SIDE", "ROLL", "YAW", "Y"})

_FORCE_AXES = {"DRAG": (-1.0, 0), "SIDE": (1.0, 1), "LIFT": (-1.0, 2)}
_MOMENT_AXES = {"ROLL": 0, "PITCH": 1, "YAW": 2}


class UnknownJSBSimAircraftError(UnknownAircraftError):
    """A JSBSim aircraft name or path that does not exist."""

    def __init__(self, name: str, known: list[str], root: str, file: str | None = None):
        self.root, self.file = root, file
        super().__init__(name, known)

    def __str__(self) -> str:
        missing = (
            f"no such file {self.file}" if self.file else f"no aircraft/{self.name}/{self.name}.xml under {self.root}"
        )
        return f"unknown JSBSim aircraft {self.name!r} ({missing}); available: {', '.join(self.known) or 'none there'}"


@contextlib.contextmanager
def _quiet():
    """JSBSim's message level is process-wide: silence it while we drive JSBSim, then restore it."""
    import jsbsim

    base = jsbsim.FGJSBBase()
    level = base.debug_lvl
    base.debug_lvl = 0
    try:
        yield
    finally:
        base.debug_lvl = level


#: Direct children of ``<fdm_config>`` that make JSBSim open files or network sockets (``<output>``: data logs,
#: FlightGear or socket streams; ``<input>``: telnet and socket inputs): left out of every model gflat loads.
IO_ELEMENTS = ("input", "output")


@contextlib.contextmanager
def _console_captured(records: list[str]):
    """JSBSim's console output kept in ``records``, not printed: the C++ streams on file descriptors 1 and 2,
    and what the jsbsim module forwards to Python's ``sys.stdout``/``sys.stderr`` when those are not the
    descriptors (a caller capturing the output)."""
    import io
    import os
    import sys

    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    saved = []
    py = io.StringIO()
    with tempfile.TemporaryFile() as sink, contextlib.redirect_stdout(py), contextlib.redirect_stderr(py):
        try:
            for fd in (1, 2):
                saved.append((fd, os.dup(fd)))
                os.dup2(sink.fileno(), fd)
        except OSError:  # no such descriptors (an embedded interpreter): nothing to capture
            pass
        try:
            yield records
        finally:
            for fd, copy in saved:
                os.dup2(copy, fd)
                os.close(copy)
            sink.seek(0)
            records.extend(line for line in sink.read().decode("utf-8", "replace").splitlines() if line.strip())
            records.extend(line for line in py.getvalue().splitlines() if line.strip())
            del records[:-1000]  # the latest lines: enough to name a failure


@contextlib.contextmanager
def loadable_model(name: str, aircraft_dir: Path):
    """The aircraft folder to load ``name`` from: the file itself, or a copy without its input/output directives.

    An aircraft whose ``<fdm_config>`` has ``<output>`` or ``<input>`` children (:data:`IO_ELEMENTS`) is
    loaded from a temporary folder holding the file without them and links to everything else of its folder
    (the systems, engines and tables it references), removed as soon as JSBSim has read it: JSBSim then
    writes no file, binds no socket and prints nothing about them.

    Parameters
    ----------
    name : str
        The aircraft's name (``<name>/<name>.xml``).
    aircraft_dir : pathlib.Path
        Its folder.

    Yields
    ------
    pathlib.Path
        The folder whose parent to pass to JSBSim as the aircraft path.
    """
    xml = aircraft_dir / f"{name}.xml"
    root = jx.parse(xml)
    io = [child for child in root if child.tag in IO_ELEMENTS]
    if not io:
        yield aircraft_dir
        return
    import xml.etree.ElementTree as ET

    for child in io:
        root.remove(child)
    with tempfile.TemporaryDirectory(prefix="gflat-jsbsim-model-") as tmp:
        folder = Path(tmp) / name
        folder.mkdir()
        for entry in aircraft_dir.iterdir():
            if entry.name != xml.name:
                (folder / entry.name).symlink_to(entry.resolve(), target_is_directory=entry.is_dir())
        ET.ElementTree(root).write(folder / xml.name, encoding="utf-8", xml_declaration=True)
        yield folder


def load_model(name: str, aircraft_dir: Path, root: Path):
    """A new ``jsbsim.FGFDMExec`` with the aircraft loaded, quietly (:func:`loadable_model`, console captured).

    Parameters
    ----------
    name : str
        The aircraft's name.
    aircraft_dir : pathlib.Path
        Its folder (absolute).
    root : pathlib.Path
        The JSBSim root (absolute; ``engine/`` and ``systems/`` under it).

    Returns
    -------
    fdm : jsbsim.FGFDMExec
    console : list of str
        What JSBSim printed while loading.

    Raises
    ------
    InputError
        JSBSim could not load the aircraft (its messages named).
    """
    import os

    import jsbsim

    console: list[str] = []
    previous = os.environ.get("JSBSIM_DEBUG")
    os.environ["JSBSIM_DEBUG"] = "0"  # the constructor's banner, before set_debug_level can act
    try:
        with _quiet(), _console_captured(console), loadable_model(name, aircraft_dir) as folder:
            fdm = jsbsim.FGFDMExec(str(root))
            fdm.set_debug_level(0)
            ok = fdm.load_model_with_paths(name, str(folder.parent), str(root / "engine"), str(root / "systems"))
            fdm.disable_output()
    finally:
        if previous is None:
            os.environ.pop("JSBSIM_DEBUG", None)
        else:
            os.environ["JSBSIM_DEBUG"] = previous
    if not ok:
        said = " | ".join(console[-5:]) or "load_model returned False"
        raise InputError(f"JSBSim could not load {aircraft_dir / (name + '.xml')}: {said}")
    return fdm, console


#: Points of the pilot's command over [-1, 1], and the time [s] the flight-control system runs at each.
SWEEP_POINTS = 9
SWEEP_SECONDS = 2.0
_WORDS = {"dl": "aileron", "dm": "elevator", "dn": "rudder"}


def flight_control_sweep(source, variables, reads) -> dict:
    """The flight-control outputs at steady state for the pilot's surface commands over [-1, 1].

    The aircraft is loaded again with its flight-control system running, held at the reference condition
    (``simulation/models/FGPropagate/enabled = 0``: the state does not move, rates zero), and each command of
    :data:`PILOT_COMMANDS` (the others at 0) is set to :data:`SWEEP_POINTS` values; the system runs
    :data:`SWEEP_SECONDS` at 120 Hz (actuator lags and rate limits settle) before the properties are read.

    Parameters
    ----------
    source : JSBSimAeroSource
        Its model, folders, reference altitude and Mach are used (``console`` collects JSBSim's output).
    variables : iterable of str
        ``"dl"``, ``"dm"``, ``"dn"``: the commands to sweep.
    reads : set of str
        Properties the aerodynamics read; the ``fcs/`` ones and the candidate surfaces are recorded.

    Returns
    -------
    dict
        Variable -> ``(commands, {property: values})``, arrays of shape ``(SWEEP_POINTS,)``.

    Raises
    ------
    InputError
        JSBSim cannot load the aircraft, or its flight-control system fails when run (a property only
        FlightGear gives).
    """
    fdm, console = load_model(source.model, source.aircraft_dir, source.root)
    source.console.extend(console)
    pm = fdm.get_property_manager()
    cands = [p for cs in SURFACE_CANDIDATES.values() for p, _ in cs]
    props = sorted({p for p in reads if p.startswith("fcs/")} | {p for p in cands if pm.hasNode(p)})
    props = [p for p in props if pm.hasNode(p)]
    grid = np.linspace(-1.0, 1.0, SWEEP_POINTS)
    out = {}
    with _quiet(), _console_captured(source.console):
        fdm.set_dt(1.0 / 120.0)
        fdm["ic/h-sl-ft"] = source.altitude / units.FT
        fdm["ic/mach"] = source.mach
        steps = round(SWEEP_SECONDS * 120)
        try:
            fdm.run_ic()
            fdm["simulation/models/FGPropagate/enabled"] = 0
            _sweep(fdm, variables, props, grid, steps, out)
        except Exception as exc:  # JSBSim's LogException: the system reads a property no model gives
            said = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputError(
                f"JSBSim {source.model} is not representable: its flight-control system, run to find the "
                f"surfaces, fails outside FlightGear ({said})"
            ) from None
    return out


def _sweep(fdm, variables, props, grid, steps, out) -> None:
    """The command sweep of :func:`flight_control_sweep` (fills ``out``)."""
    for var in variables:
        values = np.empty((len(props), len(grid)))
        for j, c in enumerate(grid):
            for cmd in PILOT_COMMANDS.values():
                fdm[cmd] = 0.0
            fdm[PILOT_COMMANDS[var]] = float(c)
            for _ in range(steps):
                fdm.run()
            values[:, j] = [fdm[p] for p in props]
        out[var] = (grid, dict(zip(props, values)))


def _swept_surface(model: str, var: str, sweep, reads) -> tuple[tuple[str, float], tuple[float, float]]:
    """The one property the aerodynamics read that the command of ``var`` moves, its factor and range.

    ``property = factor * variable``: the factor's sign makes the variable move as JSBSim's own surface
    property does for the same command (:data:`SURFACE_CANDIDATES`' sign), ``180/pi`` for a ``-deg``
    property; a normalised property is scaled by the deflection in rad the same command gives (a
    candidate property linear in it), else the aircraft is refused.

    Raises
    ------
    InputError
        No property, or several, move with the command; a normalised property without a deflection in rad.
    """
    grid, values = sweep
    word, cmd = _WORDS[var], PILOT_COMMANDS[var]
    cand_props = {p: sgn for p, sgn in SURFACE_CANDIDATES[var]}
    moved = {p: v for p, v in values.items() if np.ptp(v) > 1e-3}
    read = [p for p in moved if p not in cand_props and p not in DERIVED_SURFACE_PROPERTIES and p in reads]
    if not read:
        raise InputError(
            f"JSBSim {model} is not representable: its aerodynamics read no {word} property "
            f"({', '.join(cand_props)}) and none that the {word} command {cmd} moves through its flight-control "
            f"system (no {word} in the model)"
        )
    if len(read) > 1:
        raise InputError(
            f"JSBSim {model} is not representable: the {word} command {cmd} moves {len(read)} properties the "
            f"aerodynamics read ({', '.join(read)}); the project's model has one {word} deflection"
        )
    prop = read[0]
    v = moved[prop]
    base = SURFACE_CANDIDATES[var][0][1]
    slope = 1.0 if v[-1] >= v[0] else -1.0
    if prop.endswith("-norm"):
        rad = [(p, moved[p]) for p in cand_props if p in moved]
        if not rad:
            raise InputError(
                f"JSBSim {model} is not representable: its aerodynamics read {prop}, a normalised {word} "
                f"position, and its flight-control system gives no deflection in rad for it"
            )
        r = rad[0][1]
        k, c = np.polyfit(r, v, 1)
        if np.max(np.abs(k * r + c - v)) > 1e-3 * np.ptp(v) or abs(c) > 1e-3 * np.ptp(v):
            raise InputError(
                f"JSBSim {model} is not representable: its aerodynamics read {prop}, a normalised {word} "
                f"position not proportional to the deflection {rad[0][0]}"
            )
        factor = float(k) * cand_props[rad[0][0]]
    else:
        factor = slope * base * (180.0 / math.pi if prop.endswith("-deg") else 1.0)
    x = v / factor
    return (prop, float(factor)), (float(np.min(x)), float(np.max(x)))


def property_names(fdm) -> list[str]:
    """Every property of a loaded model (``FGFDMExec.query_property_catalog``), without the access flags.

    Parameters
    ----------
    fdm : jsbsim.FGFDMExec

    Returns
    -------
    list of str
    """
    return [line.rsplit(" (", 1)[0].strip() for line in fdm.query_property_catalog("").splitlines() if line.strip()]


def check_properties(fdm, named: Mapping[str, str], where: str, also=()) -> None:
    """Refuse property names the loaded model does not have, with the closest one (difflib).

    Parameters
    ----------
    fdm : jsbsim.FGFDMExec
        The loaded model.
    named : mapping of str to str
        Property -> what names it, for the message (``"surface dm"``, ``"configuration"``).
    where : str
        The model, for the message.
    also : iterable of str
        Further accepted names (properties the aerodynamics read, created when written).

    Raises
    ------
    InputError
        One line naming the property, what gave it and the closest property of the model.
    """
    import difflib

    pm = fdm.get_property_manager()
    also = set(also)
    for prop, what in named.items():
        if prop in also or pm.hasNode(prop):
            continue
        close = difflib.get_close_matches(prop, property_names(fdm) + sorted(also), n=1, cutoff=0.6)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise InputError(f"{where}: {prop!r} ({what}) is not a property of the loaded model{hint}")


def default_root() -> Path:
    """The JSBSim root folder of the installed jsbsim package (``aircraft/``, ``engine/``, ``systems/``).

    Returns
    -------
    Path
        ``jsbsim.get_default_root_dir()``.
    """
    import jsbsim

    return Path(jsbsim.get_default_root_dir())


def available_aircraft(root: Path) -> list[str]:
    """Aircraft under ``root/aircraft`` (folders holding ``<name>/<name>.xml``).

    Parameters
    ----------
    root : Path
        A JSBSim root folder.

    Returns
    -------
    list of str
        The aircraft names, sorted; empty when ``root/aircraft`` is not a folder.
    """
    d = root / "aircraft"
    if not d.is_dir():
        return []
    return sorted(p.name for p in d.iterdir() if (p / f"{p.name}.xml").is_file())


def check_model_name(model: str) -> str:
    """``model`` when it is an aircraft's name (one folder name under ``<root>/aircraft``), not a path.

    Parameters
    ----------
    model : str
        What the user gave, not ending in ``.xml``.

    Returns
    -------
    str

    Raises
    ------
    InputError
        A name with a ``/``, a ``..`` or other characters than a folder's (one line naming it): an aircraft
        elsewhere is given as the path of its ``<name>/<name>.xml``.
    """
    if model and model not in (".", "..") and all(c.isalnum() or c in "._-+" for c in model):
        return model
    raise InputError(
        f"JSBSim aircraft {model!r}: not an aircraft's name (one folder name under the JSBSim root's aircraft/); "
        f"give a bundled name such as F4N, or the path of an aircraft file <name>/<name>.xml"
    )


def resolve(model: str, root: str | Path | None = None) -> tuple[str, Path, Path]:
    """Where a JSBSim aircraft's files are.

    Parameters
    ----------
    model : str
        A bundled aircraft name (``"F4N"``), a name under ``root``, or a path ``.../<name>/<name>.xml``.
    root : str or Path, optional
        JSBSim root folder (default :func:`default_root`).

    Returns
    -------
    name : str
        The aircraft's name.
    aircraft_dir : Path
        Its folder.
    jsbsim_root : Path
        The JSBSim root folder (engines and systems are looked for there).

    Raises
    ------
    UnknownJSBSimAircraftError
        No such aircraft (the message lists those available).
    InputError
        A path to an ``.xml`` file not laid out as ``<name>/<name>.xml``.
    """
    base = expand_home(root).resolve() if root is not None else default_root()  # JSBSim joins relative ones
    if root is not None and not base.is_dir():
        raise InputError(f"JSBSim root {str(root)!r}: {base} is not a folder")
    p = expand_home(model)
    if p.suffix == ".xml":
        p = p.resolve()
        if not p.is_file():
            raise UnknownJSBSimAircraftError(str(model), available_aircraft(base), str(base), file=str(p))
        if p.parent.name != p.stem:
            raise InputError(f"JSBSim expects an aircraft file as <dir>/<name>/<name>.xml; got {p}")
        return p.stem, p.parent, base
    check_model_name(model)
    if not (base / "aircraft" / model / f"{model}.xml").is_file():
        raise UnknownJSBSimAircraftError(str(model), available_aircraft(base), str(base))
    return model, base / "aircraft" / model, base


class JSBSimAeroSource(SourceModel):
    """A JSBSim aircraft's aerodynamics at a reference Mach and altitude.

    Parameters
    ----------
    model : str
        Bundled aircraft name (``"F4N"``), name under ``root``, or path to
        ``<name>/<name>.xml``.
    mach : float
        Reference Mach number (the coefficients are evaluated at it).
    altitude : float
        Reference altitude [m] (ISA of JSBSim).
    root : path, optional
        JSBSim root directory (``aircraft/``, ``engine/``, ``systems/``);
        default: the one of the installed jsbsim package.
    surfaces : mapping, optional
        ``{"dl"|"dm"|"dn": (property, factor)}`` overriding the detected
        surface properties: property = factor * variable [rad] (factor -1 or
        +1 for a surface position in rad, e.g. ``1/0.35`` for a normalised
        position reaching 1 at 0.35 rad).
    configuration : mapping, optional
        Property -> value overriding the default 0 of the configuration properties.

    Raises
    ------
    InputError
        Mach outside (0, 5) or altitude outside [-500, 30000] m; an aircraft whose files cannot be read or
        that JSBSim cannot load; no surface property found for dl, dm or dn (and none given); an
        alpha-dot/beta-dot function in an unsupported axis.
    UnknownJSBSimAircraftError
        No such aircraft (:func:`resolve`).
    """

    def __init__(
        self,
        model: str,
        *,
        mach: float | None = None,
        altitude: float | None = None,
        root: str | Path | None = None,
        surfaces: Mapping[str, tuple[str, float]] | None = None,
        configuration: Mapping[str, float] | None = None,
    ):
        altitude = DEFAULT_ALTITUDE if altitude is None else altitude
        if mach is not None and not (math.isfinite(mach) and 0 < mach < 5):
            raise InputError(f"reference Mach must be in (0, 5), got {mach}")
        if not (math.isfinite(altitude) and -500 <= altitude <= 30000):
            raise InputError(f"reference altitude must be in [-500, 30000] m, got {altitude}")
        self.model, self.aircraft_dir, self.root = resolve(model, root)
        self.altitude = float(altitude)
        self._xml = jx.parse(self.aircraft_dir / f"{self.model}.xml")
        aero = jx.aerodynamics_element(self._xml, self.aircraft_dir)
        functions = jx.aero_functions(aero)
        reads = set().union(*(f.reads for f in functions)) if functions else set()
        # Sampling must not run the aircraft's <output> or <input> directives (files written into the JSBSim
        # root, sockets bound): the model is loaded without them, JSBSim's console output captured.
        fdm, self.console = load_model(self.model, self.aircraft_dir, self.root)
        where = f"JSBSim {self.model}"
        self.mach = float(mach) if mach is not None else self._default_mach(fdm, aero)
        self.mach_rule = (
            "given"
            if mach is not None
            else f"the speed of level flight at C_L = {DEFAULT_LIFT_COEFFICIENT:g} at {self.altitude:g} m "
            f"(W / (qbar S), the loaded weight), raised to the lowest Mach of the aerodynamic tables"
        )
        # A candidate surface counts when the aerodynamics read it or one of the aircraft's copies of it.
        cands = {p for cs in SURFACE_CANDIDATES.values() for p, _ in cs}
        origin = {}
        for o, i, _, _ in jx.surface_copies(self._xml, self.aircraft_dir, self.root, cands):
            origin[o] = origin.get(i, i)
        seen = set(reads) | {origin[o] for o in reads if o in origin}
        #: Variable -> (lo, hi) [rad] of the surfaces found by the flight-control sweep.
        self.swept_ranges: dict[str, tuple[float, float]] = {}
        self.surface_map = self._surfaces(seen, surfaces or {}, reads)
        self.removed = jx.angle_rate_functions(functions)
        for f in self.removed:
            if f.axis not in _FORCE_AXES and f.axis not in _MOMENT_AXES:
                raise InputError(
                    f"JSBSim {self.model}: alpha-dot/beta-dot function {f.name} in axis {f.axis} "
                    f"is not supported (only DRAG, SIDE, LIFT, ROLL, PITCH, YAW)"
                )
        used = {p for p, _ in self.surface_map.values()}
        # The aircraft's own copies of the surfaces (normalised positions, mirrored surfaces) follow them.
        self.copies = jx.surface_copies(self._xml, self.aircraft_dir, self.root, used)
        copied = {o for o, _, _, _ in self.copies}
        config = {
            p: 0.0
            for p in sorted(reads)
            if p.startswith(("fcs/", "gear/", "systems/"))
            and p not in used
            and p not in copied
            and p not in DERIVED_SURFACE_PROPERTIES
        }
        for k, v in (configuration or {}).items():
            config[str(k)] = float(v)
        self.configuration = config
        self.copies = [c for c in self.copies if c[0] not in config]  # an explicit value wins
        #: The copies the aerodynamics read: output -> (input, component kind).
        self.surface_copies = {o: (i, kind) for o, i, _, kind in self.copies if o in reads}

        check_properties(
            fdm,
            {
                **{p: "configuration" for p in (configuration or {})},
                **{
                    str(surfaces[v][0]): f"surface {v}, --property {v}=..."
                    for v in (surfaces or {})
                    if v in SURFACE_CANDIDATES
                },
            },
            where,
            also=reads,
        )
        self._fdm = fdm
        fdm["simulation/models/FGFCS/enabled"] = 0
        for k, v in self.configuration.items():
            fdm[k] = v
        fdm["ic/lat-geod-rad"] = 0.0
        fdm["ic/long-gc-rad"] = 0.0
        fdm["ic/h-sl-ft"] = self.altitude / units.FT
        fdm["ic/mach"] = self.mach
        with _quiet(), _console_captured(self.console):
            fdm.run_ic()
        self.V_fps = self.mach * fdm["atmosphere/a-fps"]
        self.V_ref = self.V_fps * units.FT
        self.S = fdm["metrics/Sw-sqft"]
        self.b = fdm["metrics/bw-ft"]
        self.cbar = fdm["metrics/cbarw-ft"]
        self.cg_in = np.array([fdm["inertia/cg-x-in"], fdm["inertia/cg-y-in"], fdm["inertia/cg-z-in"]])
        self.rp_in = np.array([fdm["metrics/aero-rp-x-in"], fdm["metrics/aero-rp-y-in"], fdm["metrics/aero-rp-z-in"]])
        self.name = f"JSBSim {self.model} at Mach {self.mach:g}, {self.altitude:g} m"
        self.envelope = self._envelope(aero, functions)

    def _default_mach(self, fdm, aero) -> float:
        """Mach of level flight at :data:`DEFAULT_LIFT_COEFFICIENT` at the reference altitude, the loaded weight,
        raised to the lowest Mach of the tables (below it JSBSim holds their end values)."""
        fdm["ic/h-sl-ft"] = self.altitude / units.FT
        fdm["ic/mach"] = 0.3
        fdm["simulation/models/FGFCS/enabled"] = 0  # as for sampling: the weight needs no flight control
        with _quiet(), _console_captured(self.console):
            fdm.run_ic()
        W, S = fdm["inertia/weight-lbs"], fdm["metrics/Sw-sqft"]
        if not (W > 0 and S > 0):
            raise InputError(
                f"JSBSim {self.model}: weight {W:g} lbf, wing area {S:g} ft^2: no level-flight speed to "
                f"take as the reference (give --mach)"
            )
        V = math.sqrt(2.0 * W / (fdm["atmosphere/rho-slugs_ft3"] * S * DEFAULT_LIFT_COEFFICIENT))
        mach = V / fdm["atmosphere/a-fps"]
        tables = jx.table_ranges(aero).get("velocities/mach")
        if tables is not None and tables[0] < 5:
            mach = max(mach, tables[0])
        if not 0 < mach < 5:
            raise InputError(
                f"JSBSim {self.model}: level flight at C_L = {DEFAULT_LIFT_COEFFICIENT:g} needs Mach {mach:.3g} "
                f"(weight {W:g} lbf on {S:g} ft^2): outside (0, 5); give --mach"
            )
        return float(f"{mach:.3g}")

    # -- set-up helpers -------------------------------------------------------------------------
    def _surfaces(
        self, seen: set[str], override: Mapping[str, tuple[str, float]], reads: set[str]
    ) -> dict[str, tuple[str, float]]:
        """Each surface's property and factor: the override, a candidate the aerodynamics read, else the one
        property the aerodynamics read that the pilot's command moves (:func:`flight_control_sweep`)."""
        unknown = [k for k in override if k not in SURFACE_CANDIDATES]
        if unknown:
            raise InputError(f"unknown surface variable(s) {', '.join(unknown)}; use dl, dm, dn")
        out = {}
        missing = []
        for var, cands in SURFACE_CANDIDATES.items():
            if var in override:
                prop, sign = override[var]
                out[var] = (str(prop), float(sign))
                continue
            found = [(p, s) for p, s in cands if p in seen]
            if found:
                out[var] = found[0]
            else:
                missing.append(var)
        if missing:
            sweep = flight_control_sweep(self, missing, reads)
            for var in missing:
                out[var], self.swept_ranges[var] = _swept_surface(self.model, var, sweep[var], reads)
        return out

    def _envelope(self, aero, functions) -> dict[str, tuple[float, float]]:
        """Domain covered by the tables (JSBSim holds end values beyond) and the FCS surface ranges;
        the tables of the removed alpha-dot/beta-dot functions do not count.

        alpha is bounded by the tables of the lift, drag and pitching-moment axes (``LIFT``, ``DRAG``,
        ``PITCH``, body ``X``, ``Z``), beta by those of the side-force, rolling and yawing axes: a lateral
        derivative tabulated over a narrower alpha range (JSBSim holds its end values) does not bound the
        longitudinal data.  The surfaces are bounded by every table and by the flight-control output range.
        Also sets :attr:`envelope_origin` (variable -> what limits it) and :attr:`mach_range` (the Mach range
        of the tables, None when no table depends on Mach).
        """
        excluded = frozenset(f.name for f in self.removed)
        ranges = jx.table_ranges(aero, excluded)
        longitudinal = frozenset(f.name for f in functions if f.axis in _LONGITUDINAL_AXES)
        lateral = frozenset(f.name for f in functions if f.axis in _LATERAL_AXES)
        by_axes = {
            "alpha": jx.table_ranges(aero, excluded, include=longitudinal),
            "beta": jx.table_ranges(aero, excluded, include=lateral),
        }
        mach = ranges.get("velocities/mach")
        self.mach_range = (mach[0], mach[1]) if mach is not None else None
        env: dict[str, tuple[float, float]] = {}
        origin: dict[str, str] = {}

        def meet(var, lo, hi, why):
            if var in env:
                if lo > env[var][0] or hi < env[var][1]:
                    origin[var] = why if (lo >= env[var][0] and hi <= env[var][1]) else f"{origin[var]}; {why}"
                lo, hi = max(lo, env[var][0]), min(hi, env[var][1])
            else:
                origin[var] = why
            env[var] = (lo, hi)

        deg = math.pi / 180.0
        for var, axis_ranges in by_axes.items():
            for prop, (lo, hi, where) in axis_ranges.items():
                f = deg if prop.endswith("deg") else 1.0
                why = f"tables of {where} over {prop}"
                if var == "alpha" and prop in ("aero/alpha-rad", "aero/alpha-deg"):
                    meet("alpha", lo * f, hi * f, why)
                elif var == "beta" and prop in ("aero/beta-rad", "aero/beta-deg"):
                    meet("beta", lo * f, hi * f, why)
                elif var == "beta" and prop in ("aero/mag-beta-rad", "aero/mag-beta-deg"):
                    meet("beta", -hi * f, hi * f, why)
        for var, (prop, sign) in self.surface_map.items():
            if prop in ranges:
                lo, hi, where = ranges[prop]
                a, b = sorted((lo / sign, hi / sign))
                meet(var, a, b, f"tables of {where} over {prop}")
            if var in self.swept_ranges:
                meet(var, *self.swept_ranges[var], f"flight-control sweep of {PILOT_COMMANDS[var]} over [-1, 1]")
            lim = jx.surface_limit(self._xml, self.aircraft_dir, self.root, prop)
            if lim is not None:
                a, b = sorted((lim[0] / sign, lim[1] / sign))
                meet(var, a, b, f"flight-control output range of {prop}")
        self.envelope_origin = origin
        return env

    # -- evaluation -----------------------------------------------------------------------------
    def body_forces(
        self, alpha: float, beta: float, p: float, q: float, r: float, surfaces: Mapping[str, float]
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """One JSBSim evaluation (``run_ic``) at the reference Mach and altitude.

        The attitude is ``(0, alpha, 0)`` and the body velocity ``V (cos a cos b, sin b, sin a cos b)``;
        the forces and moments of the removed alpha-dot/beta-dot functions are subtracted (force terms
        rotated from wind to body axes, with their moment about the CG).

        Parameters
        ----------
        alpha, beta : float
            Angle of attack and sideslip [rad].
        p, q, r : float
            Body rates [rad/s].
        surfaces : mapping of str to float
            JSBSim property -> value, the surface positions (rad) and their copies.

        Returns
        -------
        F : ndarray, shape (3,)
            Aerodynamic body-axis force [lbf].
        M : ndarray, shape (3,)
            Aerodynamic moment about the CG, body axes [lbf ft].
        qbar : float
            Dynamic pressure [psf].
        """
        fdm = self._fdm
        V = self.V_fps
        fdm["ic/phi-rad"] = 0.0
        fdm["ic/theta-rad"] = alpha
        fdm["ic/psi-true-rad"] = 0.0
        fdm["ic/u-fps"] = V * math.cos(alpha) * math.cos(beta)
        fdm["ic/v-fps"] = V * math.sin(beta)
        fdm["ic/w-fps"] = V * math.sin(alpha) * math.cos(beta)
        fdm["ic/p-rad_sec"] = p
        fdm["ic/q-rad_sec"] = q
        fdm["ic/r-rad_sec"] = r
        for prop, val in surfaces.items():
            fdm[prop] = val
        fdm.run_ic()
        F = np.array([fdm["forces/fbx-aero-lbs"], fdm["forces/fby-aero-lbs"], fdm["forces/fbz-aero-lbs"]])
        M = np.array([fdm["moments/l-aero-lbsft"], fdm["moments/m-aero-lbsft"], fdm["moments/n-aero-lbsft"]])
        if self.removed:
            a, b = fdm["aero/alpha-rad"], fdm["aero/beta-rad"]
            ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
            wind_to_body = np.array([[ca * cb, -ca * sb, -sa], [sb, cb, 0.0], [sa * cb, -sa * sb, ca]])
            arm = np.array(
                [
                    (self.cg_in[0] - self.rp_in[0]) / 12.0,
                    (self.rp_in[1] - self.cg_in[1]) / 12.0,
                    (self.cg_in[2] - self.rp_in[2]) / 12.0,
                ]
            )
            for f in self.removed:
                v = fdm[f.name]
                if f.axis in _MOMENT_AXES:
                    M[_MOMENT_AXES[f.axis]] -= v
                else:
                    sign, k = _FORCE_AXES[f.axis]
                    fw = np.zeros(3)
                    fw[k] = sign * v
                    fb = wind_to_body @ fw
                    F -= fb
                    M -= np.cross(arm, fb)
        return F, M, fdm["aero/qbar-psf"]

    def body_coefficients(self, state: AeroState) -> np.ndarray:
        """Body-axis coefficients about the JSBSim CG, one :meth:`body_forces` evaluation a point.

        Parameters
        ----------
        state : AeroState
            The eight aerodynamic variables (broadcast together) [rad / nondimensional]; the rates are
            made dimensional with the reference speed, the surfaces mapped to JSBSim properties.

        Returns
        -------
        ndarray, shape (..., 6)
            ``[CX, CY, CZ, Cl, Cm, Cn]`` (forces over ``qbar S``, moments over ``qbar S b`` or ``qbar S cbar``).
        """
        st, shape = broadcast_state(state)
        flat = [np.ravel(v) for v in st]
        n = flat[0].size
        out = np.empty((n, 6))
        two_V = 2.0 * self.V_fps
        with _quiet(), _console_captured(self.console):
            self._evaluate(flat, out, two_V)
        return out.reshape(shape + (6,))

    def _evaluate(self, flat, out, two_V) -> None:
        for i in range(out.shape[0]):
            a, b, ph, qh, rh, dl, dm, dn = (float(v[i]) for v in flat)
            surf = {}
            for var, val in (("dl", dl), ("dm", dm), ("dn", dn)):
                prop, sign = self.surface_map[var]
                surf[prop] = sign * val
            for out_prop, in_prop, f, _ in self.copies:
                surf[out_prop] = f(surf[in_prop])
            F, M, qbar = self.body_forces(a, b, ph * two_V / self.b, qh * two_V / self.cbar, rh * two_V / self.b, surf)
            qS = qbar * self.S
            out[i, :3] = F / qS
            out[i, 3:] = M / (qS * np.array([self.b, self.cbar, self.b]))

    def coefficients(self, state: AeroState) -> Coefficients:
        st, _ = broadcast_state(state)
        c = self.body_coefficients(st)
        CD, CL = stability_from_body(st.alpha, c[..., 0], c[..., 2])
        return Coefficients(CD, c[..., 1], CL, c[..., 3], c[..., 4], c[..., 5])

    # -- vehicle data -------------------------------------------------------------------------
    def vehicle(self) -> dict:
        """Mass, inertia, geometry and engines as the JSBSim definition gives them (English units).

        Returns
        -------
        dict
            ``mass_slug``, ``I..._slugft2`` (``Ixz`` in the flight-dynamics sign), ``S_ft2``, ``b_ft``,
            ``cbar_ft``, ``cg_in`` and ``aero_rp_in`` (structural frame [in]) and ``engines`` (``count``,
            ``thrusters`` and, for turbine engines, ``max_thrust_lbf`` with its source).

        Raises
        ------
        InputError
            An engine without a location or an unreadable engine file (:mod:`.jsbsim_xml`).
        """
        fdm = self._fdm
        thr = jx.engines(self._xml)
        eng: dict = {"count": len(thr), "thrusters": thr}
        ratings = [jx.turbine_static_thrust(t.engine_file, self.aircraft_dir, self.root) for t in thr]
        if thr and all(r is not None for r in ratings):
            eng["max_thrust_lbf"] = sum(r[0] for r in ratings)
            eng["max_thrust_source"] = ", ".join(sorted({r[1] for r in ratings}))
        return {
            "mass_slug": fdm["inertia/mass-slugs"],
            "Ixx_slugft2": fdm["inertia/ixx-slugs_ft2"],
            "Iyy_slugft2": fdm["inertia/iyy-slugs_ft2"],
            "Izz_slugft2": fdm["inertia/izz-slugs_ft2"],
            "Ixz_slugft2": 0.0 - fdm["inertia/ixz-slugs_ft2"],
            "S_ft2": self.S,
            "b_ft": self.b,
            "cbar_ft": self.cbar,
            "cg_in": tuple(float(x) for x in self.cg_in),
            "aero_rp_in": tuple(float(x) for x in self.rp_in),
            "engines": eng,
        }

    def provenance(self) -> dict[str, str]:
        import jsbsim

        removed = ", ".join(f.name for f in self.removed) or "none"
        cfg = ", ".join(f"{k} = {v:g}" for k, v in self.configuration.items()) or "none"
        surf = ", ".join(
            f"{var} = {'-' if s < 0 else ''}{p}" if abs(s) == 1.0 else f"{var} = {p} / {s:g}"
            for var, (p, s) in self.surface_map.items()
        )
        copies = "".join(f"{o} follows {i} ({kind}); " for o, (i, kind) in self.surface_copies.items())
        bundled = self.aircraft_dir.parent == default_root() / "aircraft"
        where = (
            f"{self.aircraft_dir.name}/{self.model}.xml of the jsbsim package"
            if bundled
            else str(self.aircraft_dir / f"{self.model}.xml")
        )
        return {
            "source": f"JSBSim {jsbsim.__version__} aircraft {self.model} ({where})",
            "source_model": f"aerodynamic forces and moments read from JSBSim (FCS disabled, run_ic per "
            f"point) at Mach {self.mach:g}, {self.altitude:g} m (V = {self.V_ref:.6g} m/s); "
            f"surfaces: {surf}; {copies}"
            f"configuration held: {cfg}; functions removed (alpha-dot/beta-dot): {removed}; "
            f"moments about the JSBSim CG",
        }


def vehicle_sections(source: JSBSimAeroSource, measure: bool = False) -> dict[str, dict]:
    """``[mass]``, ``[geometry]``, ``[engines]`` of a JSBSim aircraft as loaded (default fuel and payload).

    x positions are measured aft of the JSBSim aerodynamic reference point
    (JSBSim files give no MAC leading edge); the coefficients are sampled
    about the CG, so ``x_ref = x_cg``.

    Parameters
    ----------
    source : JSBSimAeroSource
        The loaded aircraft.
    measure : bool
        Measure the engines in JSBSim (:func:`gna.fit.sources.jsbsim_engines.measure_engines`, once the
        layout is known to be representable): their rating against speed (non-turbine engines), thrust lag,
        thrust line offset and torque arm join ``[engines]``; False leaves the propulsive moments
        unrepresented (the bundled fits).

    Returns
    -------
    dict of str to dict
        ``mass``, ``geometry``, ``engines`` in the aircraft-file layout (English units, the measured
        engine keys in SI), each with its ``source``.

    Raises
    ------
    InputError
        No engine, more than two engines, or an engine layout the project's model cannot
        represent (one engine off the symmetry plane, two not symmetric).
    """
    v = source.vehicle()
    thr = v["engines"]["thrusters"]
    where = f"JSBSim {source.model}"
    if not thr:
        raise InputError(f"{where} has no engine")
    if len(thr) > 2:
        raise InputError(f"{where} has {len(thr)} engines; the project's aircraft model has 1 or 2")
    if len(thr) == 1 and abs(thr[0].y) > 1e-9:
        raise InputError(f"{where}: its single engine is off the symmetry plane (y = {thr[0].y} in)")
    if len(thr) == 2 and (
        abs(thr[0].y + thr[1].y) > 1e-6 or abs(thr[0].x - thr[1].x) > 1e-6 or abs(thr[0].z - thr[1].z) > 1e-6
    ):
        raise InputError(f"{where}: its two engines are not symmetric about the symmetry plane")
    if measure:
        from .jsbsim_engines import measure_engines

        engines = measure_engines(source)
    else:
        engines = None
    cg_x, _, cg_z = v["cg_in"]
    rp_x = v["aero_rp_in"][0]
    dz_ft = (thr[0].z - cg_z) / 12.0
    eps = sum(t.pitch for t in thr) / len(thr)
    eng = {"count": len(thr), "y_p_in": abs(thr[0].y), "epsilon_rad": eps}
    if "max_thrust_lbf" in v["engines"]:
        eng["max_thrust_lbf"] = v["engines"]["max_thrust_lbf"]
    yaw = ", ".join(f"{math.degrees(t.yaw):g}" for t in thr)
    moment = "its pitching moment is not represented" if engines is None else "thrust_line_offset, measured"
    eng["source"] = (
        f"{where}: thrusters at y = {', '.join(f'{t.y:g}' for t in thr)} in, pitch "
        f"{', '.join(f'{math.degrees(t.pitch):g}' for t in thr)} deg, yaw {yaw} deg; the thrust line "
        f"is {abs(dz_ft):.3g} ft {'above' if dz_ft > 0 else 'below'} the CG ({moment}); max thrust: "
        + (
            f"sum of {v['engines']['max_thrust_source']}"
            if "max_thrust_lbf" in eng
            else (
                "the largest of the measured rating times the engine count"
                if engines is not None
                else "unknown (not a turbine engine file)"
            )
        )
    )
    if engines is not None:
        eng.update(engines.section())
    return {
        "mass": {
            "mass_slug": v["mass_slug"],
            "Ixx_slugft2": v["Ixx_slugft2"],
            "Iyy_slugft2": v["Iyy_slugft2"],
            "Izz_slugft2": v["Izz_slugft2"],
            "Ixz_slugft2": v["Ixz_slugft2"],
            "source": f"{where} as loaded with its default fuel and point masses, read after run_ic "
            f"(inertia/*); Ixz = -inertia/ixz-slugs_ft2 (flight-dynamics sign)",
        },
        "geometry": {
            "S_ft2": v["S_ft2"],
            "b_ft": v["b_ft"],
            "cbar_ft": v["cbar_ft"],
            "x_cg_in": cg_x - rp_x,
            "x_ref_in": cg_x - rp_x,
            "source": f"{where} metrics; x positions aft of the JSBSim AERORP (no MAC leading edge in the "
            f"file); CG at x = {cg_x:.6g} in (structural), AERORP at {rp_x:.6g} in; the "
            f"coefficients are about the CG, so x_ref = x_cg",
        },
        "engines": eng,
    }


@dataclass(frozen=True)
class FittedSource:
    """What a GNA set fitted by :class:`JSBSimAeroSource` was sampled from, read back from its provenance.

    Attributes
    ----------
    model : str
        Bundled JSBSim aircraft name (``"f16"``) or path to ``<name>/<name>.xml``
        (what :func:`resolve` accepts).
    surfaces : dict
        ``"dl" | "dm" | "dn" -> (property, sign)``: project variable = sign * property.
    configuration : dict
        Property -> value held at every sample (clean configuration).
    """

    model: str
    surfaces: dict
    configuration: dict


_PROV_SOURCE = re.compile(r"JSBSim\s+\S+\s+aircraft\s+(\S+)\s+\((.*)\)\s*$")
_PROV_SURFACES = re.compile(r"surfaces:\s*([^;]+)")
_PROV_CONFIG = re.compile(r"configuration held:\s*([^;]+)")


def fitted_source(provenance: Mapping[str, str], name: str = "aircraft") -> FittedSource:
    """Parse the ``source`` and ``source_model`` strings that :meth:`JSBSimAeroSource.provenance` writes.

    Parameters
    ----------
    provenance : mapping
        An aircraft's ``[provenance]`` table (:attr:`gna.aircraft.Aircraft.provenance`).
    name : str
        The aircraft's id, for messages.

    Returns
    -------
    FittedSource

    Raises
    ------
    InputError
        If the provenance names no JSBSim aircraft or lacks the dl, dm, dn surface mapping.
    """
    m = _PROV_SOURCE.search(str(provenance.get("source", "")))
    if m is None:
        raise InputError(
            f"{name} was not fitted from a JSBSim aircraft (provenance source: {provenance.get('source', 'none')!r})"
        )
    where = m.group(2)
    model = where if where.endswith(".xml") and not where.endswith("of the jsbsim package") else m.group(1)
    text = str(provenance.get("source_model", ""))
    sm = _PROV_SURFACES.search(text)
    surfaces = {}
    for item in sm.group(1).split(",") if sm else []:
        var, _, prop = (s.strip() for s in item.partition("="))
        surfaces[var] = (prop.lstrip("-").strip(), -1.0 if prop.startswith("-") else 1.0)
    if set(surfaces) != {"dl", "dm", "dn"}:
        raise InputError(
            f"{name}: the provenance source_model gives no complete surface mapping "
            f"('surfaces: dm = <property>, dl = ..., dn = ...'); got {sm.group(1) if sm else 'none'!r}"
        )
    config = {}
    cm = _PROV_CONFIG.search(text)
    if cm is not None and cm.group(1).strip() != "none":
        for item in cm.group(1).split(","):
            prop, _, value = (s.strip() for s in item.partition("="))
            config[prop] = float(value)
    return FittedSource(model, surfaces, config)
