"""A plan as files stock JSBSim replays natively: aircraft, initialization file, script with control tables.

What :class:`~.engine.JSBSimEngine` does in Python is written as JSBSim's own
files (``docs/jsbsim.md`` for the facts used):

* the aircraft file the engine flies (:meth:`JSBSimEngine.xml`: flat planet
  whose ``GM/r^2`` is ``g`` at the initial altitude) under ``aircraft/<id>/``;
* an initialization file (format 2) at the initial state: position (latitude,
  longitude [deg], altitude above sea level [ft]), Euler angles [deg], body
  velocity [ft/s] and body rates [deg/s];
* a script whose ``<run>`` has the engine's step, declares the settings the
  engine writes before ``run_ic`` (gravity model 0, integrators, density model,
  the controls at ``t0``) and one continuous event whose ``<set>`` functions
  are tables of ``simulation/sim-time-sec``: the two engine thrusts [lbf] and
  the three surfaces [rad] on a grid (linear interpolation between its nodes);
* a CSV ``<output>`` of the raw state properties :mod:`.states` reads.

JSBSim runs a script's events after advancing the time and before the models
(``FGFDMExec::Run``), so the tables give ``u(t_k)`` to the step reaching
``t_k``, as the engine writes it; on the engine's step grid the replay is the
engine's run up to round-off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from gna import units
from gna.aircraft import Aircraft
from gna.atmosphere import Environment
from gna.eom import CONTROL_NAMES, STATE_NAMES
from gna.errors import InputError, describe
from gna.frames import euler_from_wind
from gna.schema import check_name
from gna.trajectory import check_span, control_function, controls_on_grid, environment_of, initial_state

from ..base import EngineError
from . import export as jx
from .engine import JSBSimEngine
from .fdm import LogCapture, density_settings, import_jsbsim
from .grid import output_grid, resample
from .states import STATE_NODES, STATE_NODES_FLAT, StateConverter
from .xmlwriter import XMLWriter, comment_text, number_text

#: Properties of the CSV output, in column order (after JSBSim's ``Time``).
OUTPUT_PROPERTIES: tuple[str, ...] = (
    STATE_NODES_FLAT + STATE_NODES + jx.THRUST_PROPERTIES + tuple(jx.CONTROL_PROPERTIES.values())
)


@dataclass(frozen=True)
class ScriptBundle:
    """The files of one export, relative to its root folder.

    Parameters
    ----------
    root : pathlib.Path
        Folder to give JSBSim as its root directory.
    aircraft : str
        ``aircraft/<id>/<id>.xml``.
    initialization : str
        ``aircraft/<id>/<name>-init.xml``.
    script : str
        ``scripts/<name>.xml`` (the file to load).
    output : str
        The CSV JSBSim writes, relative to the working directory of the run.
    dt : float
        JSBSim step [s].
    t_span : (float, float)
        Start and end time [s].
    rows : int
        Nodes of each control table.
    x0 : tuple of 12 float
        Initial wind-frame state (origin of the NED plane of :func:`output_states`).
    dt_out : float
        Output interval [s] of :func:`replay`, as the JSBSim engine samples its steps.
    """

    root: Path
    aircraft: str
    initialization: str
    script: str
    output: str
    dt: float
    t_span: tuple[float, float]
    rows: int
    x0: tuple[float, ...] = ()
    dt_out: float = 0.02


def initialization_xml(x0: np.ndarray, name: str) -> str:
    """JSBSim initialization file (format 2) putting the aircraft at the wind-frame state ``x0``.

    Parameters
    ----------
    x0 : ndarray, shape (12,)
        Wind-frame state (SI, rad); the position is the origin of the flat planet's NED plane.
    name : str
        Name written in the file.

    Returns
    -------
    str
    """
    x, y, z, V, gamma, chi, alpha, beta, mu, p, q, r = (float(v) for v in x0)
    phi, theta, psi = euler_from_wind(gamma, chi, mu, alpha, beta)
    vf = V / units.FT
    w = XMLWriter()
    w.line('<?xml version="1.0" encoding="utf-8"?>')
    w.open("initialize", f'name="{name}" version="2.0"')
    note = comment_text(
        f"Written by gflat export-jsbsim-script: the initial state (NED origin at x = {x:g} m, y = {y:g} m)."
    )
    w.line(f"<!-- {note} -->")
    w.open("position", 'frame="ECEF"')
    w.leaf("latitude", 0.0, 'unit="DEG" type="geodetic"')
    w.leaf("longitude", 0.0, 'unit="DEG"')
    w.leaf("altitudeMSL", -z / units.FT, 'unit="FT"')
    w.close("position")
    w.open("orientation", 'unit="DEG" frame="LOCAL"')
    for tag, v in (("roll", phi), ("pitch", theta), ("yaw", psi)):
        w.leaf(tag, math.degrees(v))
    w.close("orientation")
    w.open("velocity", 'unit="FT/SEC" frame="BODY"')
    for tag, v in (
        ("x", vf * math.cos(alpha) * math.cos(beta)),
        ("y", vf * math.sin(beta)),
        ("z", vf * math.sin(alpha) * math.cos(beta)),
    ):
        w.leaf(tag, v)
    w.close("velocity")
    w.open("attitude_rate", 'unit="DEG/SEC" frame="BODY"')
    for tag, v in (("x", p), ("y", q), ("z", r)):
        w.leaf(tag, math.degrees(v))
    w.close("attitude_rate")
    w.close("initialize")
    return w.text()


def control_rows(controls, times: np.ndarray) -> dict[str, np.ndarray]:
    """The written properties' values (thrusts [lbf], surfaces [rad]) at ``times``, as the engine writes them.

    Parameters
    ----------
    controls : callable, plan or sequence of 5 floats
        Control source (:func:`gna.trajectory.control_function`).
    times : ndarray, shape (n,)
        Times [s].

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Property -> values (engine 1 thrust ``F (1 + eta) / 2``, engine 2 ``F (1 - eta) / 2``).

    Raises
    ------
    InputError
        Controls that are not finite (the first such time is named).
    """
    U = controls_on_grid(control_function(controls), times)
    if not np.all(np.isfinite(U)):
        k = int(np.argmax(~np.all(np.isfinite(U), axis=0)))
        raise InputError(f"controls are not finite at t = {times[k]:.6g} s")
    t1, t2 = jx.THRUST_PROPERTIES
    out = {t1: U[0] * (1.0 + U[1]) * 0.5 / units.LBF, t2: U[0] * (1.0 - U[1]) * 0.5 / units.LBF}
    out.update({prop: U[2 + i] for i, prop in enumerate(jx.CONTROL_PROPERTIES.values())})
    return out


def script_xml(
    name: str,
    aircraft_id: str,
    init_name: str,
    t_span: tuple[float, float],
    dt: float,
    settings: dict[str, float],
    tables: dict[str, np.ndarray],
    t_table: np.ndarray,
    output: str,
    output_rate_hz: float,
) -> str:
    """The JSBSim script text.

    Parameters
    ----------
    name : str
        Script name.
    aircraft_id, init_name : str
        ``<use aircraft=... initialize=...>``.
    t_span : (float, float)
        Start and end [s].
    dt : float
        Step [s].
    settings : dict of str to float
        Properties set when the script is loaded, before ``run_ic``.
    tables : dict of str to ndarray, shape (n,)
        Property -> its values at ``t_table``.
    t_table : ndarray, shape (n,)
        Table nodes [s] (``simulation/sim-time-sec``).
    output : str
        CSV file name.
    output_rate_hz : float
        Output rate [Hz].

    Returns
    -------
    str
    """
    w = XMLWriter()
    w.line('<?xml version="1.0" encoding="utf-8"?>')
    w.open("runscript", f'name="{name}"')
    w.open("description")
    w.line(
        comment_text(
            f"gflat plan {name} replayed open loop: controls tabulated at {t_table.size} times "
            "(linear interpolation), settings of the gflat JSBSim engine."
        )
    )
    w.close("description")
    w.line(f'<use aircraft="{aircraft_id}" initialize="{init_name}"/>')
    w.open("output", f'name="{output}" type="CSV" rate="{number_text(output_rate_hz)}"')
    for prop in OUTPUT_PROPERTIES:
        w.leaf("property", prop)
    w.close("output")
    # JSBSim's script compares the time at the start of a frame with ``end`` and, when past it, still runs
    # that frame (the output among its models) before the run stops: the last row is one step after the
    # first frame starting past ``end``.  ``end`` 1.5 steps before t1 makes it t1 whatever the round-off of
    # the summed steps (``end = t1`` wrote a row at t1 + dt; measured with JSBSim 1.3.3).
    end = t_span[1] - 1.5 * dt
    w.open("run", f'start="{number_text(t_span[0])}" end="{number_text(end)}" dt="{number_text(dt)}"')
    for prop, value in settings.items():
        w.leaf("property", prop, f'value="{number_text(value)}"')
    w.open("event", 'name="plan controls" continuous="true"')
    w.leaf("condition", f"simulation/sim-time-sec ge {number_text(t_span[0] - dt)}")
    for prop, values in tables.items():
        w.open("set", f'name="{prop}"')
        w.open("function")
        w.open("table")
        w.leaf("independentVar", "simulation/sim-time-sec", 'lookup="row"')
        w.open("tableData")
        w.lines.extend(f"{number_text(t)} {number_text(v)}" for t, v in zip(t_table, values))
        w.close("tableData")
        w.close("table")
        w.close("function")
        w.close("set")
    w.close("event")
    w.close("run")
    w.close("runscript")
    return w.text()


def steps_of(value: float, dt: float, what: str) -> int:
    """The whole number of JSBSim steps in an interval, or one line naming both when it is not one.

    Parameters
    ----------
    value : float
        The interval [s] (``dt_out``, ``table_dt``).
    dt : float
        JSBSim step [s].
    what : str
        The interval's name, for the message.

    Returns
    -------
    int
        ``value / dt`` (at least 1).

    Raises
    ------
    InputError
        ``value`` not positive, or not a whole number of steps within 1e-6 relative.
    """
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{what} must be positive, got {value}")
    k = round(value / dt)
    if k < 1 or abs(value / dt - k) > 1e-6 * max(k, 1):

        def n(k):
            return f"{k} step" + ("s" if k != 1 else "")

        near = f"{k * dt:.10g} ({n(k)}) or " if k >= 1 else ""
        ratio = f"{value / dt:.4g} of a step" if value < dt else f"{value / dt:.4g} steps"
        raise InputError(
            f"{what} = {value:g} s is not a whole number of JSBSim steps of {dt:.10g} s "
            f"({ratio}): give e.g. {near}{(k + 1) * dt:.10g} ({n(k + 1)})"
        )
    return int(k)


def export_script(
    out: str | Path,
    name: str,
    aircraft: Aircraft,
    controls,
    t_span=None,
    x0=None,
    *,
    env: Environment | None = None,
    engine: JSBSimEngine | None = None,
    dt_out: float = 0.025,
    table_dt: float | None = None,
) -> ScriptBundle:
    """Write the files stock JSBSim needs to replay ``controls`` open loop from ``x0``.

    Parameters
    ----------
    out : str or pathlib.Path
        Export folder (made with its parents; ``gflat export-jsbsim-script`` gives its run's staging folder,
        :class:`harness.rundir.RunDir`).
    name : str
        Script name (file names ``scripts/<name>.xml``, ``<name>-init.xml``, ``<name>.csv``).
    aircraft : Aircraft
        The aircraft (its file is exported under ``aircraft/<id>/``).
    controls : callable, plan or sequence of 5 floats
        Control source ``t [s] -> (F [N], eta [-], dl, dm, dn [rad])``.
    t_span : (float, float), optional
        Span [s]; default the source's ``(t0, t1)`` (a plan).
    x0 : array_like, shape (12,), optional
        Initial state; default the source's ``initial_state``.
    env : Environment, optional
        Atmosphere and g; default the source's, else the ISA.
    engine : JSBSimEngine, optional
        Step and integrators copied (default ``JSBSimEngine()``); flat earth only.
    dt_out : float
        Output interval [s] of the CSV JSBSim writes and of :func:`replay`: a whole number of JSBSim steps
        (:func:`steps_of`) dividing the span (default 0.025 s, 12 steps of 1/480 s).
    table_dt : float, optional
        Interval of the control tables [s], a whole number of JSBSim steps (:func:`steps_of`) at most the
        plan's largest node step (a longer one would draw straight lines over the plan's series), with
        JSBSim's linear interpolation in between (1/96 s: about 4e-7 m over the Twin Otter's 60 s, 8e-4 m
        over the GTM's 8 s roll); default every step, the engine's control samples exactly.

    Returns
    -------
    ScriptBundle

    Raises
    ------
    InputError
        Bad name, span, state, controls, atmosphere or intervals (not whole numbers of steps, ``table_dt``
        longer than the plan's node step); ``out`` is a file; a path escapes ``out``.
    """
    engine = JSBSimEngine() if engine is None else engine
    if engine.earth != "flat":
        raise InputError("export-jsbsim-script writes the flat-earth engine only")
    check_name(name, "script name", "export-jsbsim-script")
    check_name(aircraft.id, "aircraft id", "export-jsbsim-script")
    root = Path(out)
    if root.exists() and not root.is_dir():
        raise InputError(f"export folder {root} exists and is not a folder")
    if t_span is None:
        t_span = (getattr(controls, "t0", None), getattr(controls, "t1", None))
        if None in t_span:
            raise InputError("no time span: give t_span or a plan with t0 and t1")
    t0, t1 = check_span(t_span)
    env = environment_of(controls, env)
    y0 = initial_state(controls, x0)
    n, dt, _, _ = output_grid(t0, t1, engine.dt, dt_out, None)  # the engine's own step grid
    steps_of(dt_out, dt, "dt_out")
    every = 1
    if table_dt is not None:
        every = steps_of(table_dt, dt, "table_dt")
        nodes = np.asarray(getattr(controls, "t_nodes", ()), dtype=float)
        node_step = float(np.max(np.diff(nodes))) if nodes.size > 1 else math.inf
        if every * dt > node_step * (1 + 1e-9):
            raise InputError(
                f"table_dt = {table_dt:g} s is longer than the plan's node step {node_step:g} s: "
                f"the tables' straight lines would replace the plan's controls between its nodes"
            )
    k = np.arange(0, n + 1, every)
    if k[-1] != n:
        k = np.append(k, n)
    t_table = t0 + k * dt
    tables = control_rows(controls, t_table)
    settings = {"simulation/gravity-model": 0.0}
    settings.update({p: float(c) for p, c in engine.integrators.properties().items()})
    settings.update(density_settings(env))
    settings.update({p: float(v[0]) for p, v in tables.items()})
    init_name = f"{name}-init"
    rel = {
        "aircraft": f"aircraft/{aircraft.id}/{aircraft.id}.xml",
        "initialization": f"aircraft/{aircraft.id}/{init_name}.xml",
        "script": f"scripts/{name}.xml",
    }
    texts = {
        "aircraft": engine.xml(aircraft, env, y0),
        "initialization": initialization_xml(y0, init_name),
        "script": script_xml(
            name, aircraft.id, init_name, (t0, t1), dt, settings, tables, t_table, f"{name}.csv", 1.0 / dt_out
        ),
    }
    for key, r in rel.items():
        (root / r).parent.mkdir(parents=True, exist_ok=True)
        (root / r).write_text(texts[key], encoding="utf-8")
    return ScriptBundle(
        root=root,
        aircraft=rel["aircraft"],
        initialization=rel["initialization"],
        script=rel["script"],
        output=f"{name}.csv",
        dt=dt,
        t_span=(t0, t1),
        rows=int(t_table.size),
        x0=tuple(float(v) for v in y0),
        dt_out=float(dt_out),
    )


def output_states(csv: str | Path, x0, radius_ft: float = jx.PLANET_RADIUS_FT) -> pd.DataFrame:
    """The 12 wind-frame states and 5 controls from the CSV output of an exported script.

    Parameters
    ----------
    csv : str or pathlib.Path
        The file JSBSim wrote (columns ``Time`` and :data:`OUTPUT_PROPERTIES`).
    x0 : array_like, shape (12,)
        The initial state of the export (origin of the NED plane, start of chi and mu).
    radius_ft : float
        Radius of the flat planet [ft] (the engine's ``planet_radius_ft``).

    Returns
    -------
    pandas.DataFrame
        Indexed by time ``t`` [s]; columns :data:`gna.eom.STATE_NAMES` (SI, rad) then F [N], eta [-],
        dl, dm, dn [rad]; one row per output time (a repeated time keeps its last row).
    """
    raw = pd.read_csv(csv)
    raw.columns = [c.strip() for c in raw.columns]
    raw = raw.drop_duplicates(subset="Time", keep="last")
    cols = [c for c in raw.columns if c != "Time"]
    R = raw[cols].to_numpy(dtype=float).T
    conv = StateConverter(np.asarray(x0, dtype=float), radius_ft, None)
    S = conv.vector(R[:14])
    f1, f2 = R[14] * units.LBF, R[15] * units.LBF
    F = f1 + f2
    eta = np.divide(f1 - f2, F, out=np.zeros_like(F), where=F != 0)
    data = {n: S[i] for i, n in enumerate(STATE_NAMES)}
    data.update(zip(CONTROL_NAMES, (F, eta, R[16], R[17], R[18])))
    return pd.DataFrame(data, index=pd.Index(raw["Time"].to_numpy(dtype=float), name="t"))


def replay(bundle: ScriptBundle) -> pd.DataFrame:
    """Run an exported script in stock JSBSim (the ``jsbsim`` package's script loader) and read its CSV.

    Parameters
    ----------
    bundle : ScriptBundle
        What :func:`export_script` wrote; JSBSim's root is ``bundle.root`` and it writes its CSV there.

    Returns
    -------
    pandas.DataFrame
        :func:`output_states` of the CSV.

    Raises
    ------
    EngineError
        If JSBSim refuses the script or its initial condition (its messages are quoted).
    """
    jsbsim = import_jsbsim()
    capture = LogCapture(jsbsim)
    with capture:
        fdm = jsbsim.FGFDMExec(str(bundle.root))
        fdm.set_debug_level(0)
        try:
            ok = fdm.load_script(bundle.script) and fdm.run_ic()
            while ok and fdm.run():
                pass
        except jsbsim.BaseError as exc:
            raise EngineError(f"JSBSim stopped the script {bundle.script}: {describe(exc)}") from None
        finally:
            del fdm  # closes the CSV
    if not ok:
        raise EngineError(
            f"JSBSim could not load the script {bundle.script}: "
            f"{' | '.join(capture.problems()) or 'load_script or run_ic returned False'}"
        )
    states = output_states(Path(bundle.root) / bundle.output, bundle.x0)
    t0, t1 = bundle.t_span
    _, dt, out_times, _ = output_grid(t0, t1, bundle.dt, bundle.dt_out, None)
    return resample(states, out_times, t0, dt)
