"""Artefacts of a run: trajectories as Parquet (CSV on request), plans, ``manifest.json``, ``summary.json``.

What a validation run leaves for pandas, MATLAB or a third simulator, and for
the reports.  Every writer takes a plain folder (a command's
:class:`harness.rundir.RunDir` staging folder: the run appears whole or not at
all).  Layout of a case folder (:func:`write_artefacts`)::

    trajectory-<engine>.parquet            every engine's run (the reference first)
    trajectory-<engine>-half-step.parquet  self-convergence: JSBSim at half its step
    trajectory-<engine>-open-loop.parquet  closed loop: the reference engine without feedback
    trajectory-*.csv                       the same, with ``csv=True``
    differences.txt                        the difference report
    summary.json                           verdict, tolerances and settings that made it, tables (with delta %)
    plan/plan-j<k>.parquet                 the plan of every iterate on the output grid (``plan=True``)
    manifest.json                          versions, commit, date, command line, input sha256 (``manifest=True``)

Trajectory columns: ``t`` [s], the 12 states, the 5 applied controls, the
derived columns of :data:`gna.trajectory.DERIVED_NAMES`, then altitude ``h``,
Euler angles ``phi theta psi``, body velocities ``u v w`` and ``Mach``; each
Parquet field carries its unit in its metadata (key ``unit``), and the file's
metadata the whole table (key ``gflat.units``, JSON).
"""

from __future__ import annotations

import dataclasses
import datetime
import functools
import hashlib
import importlib.metadata
import json
import math
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from gna.atmosphere import speed_of_sound
from gna.errors import InputError, describe
from gna.trajectory import UNITS


def json_safe(obj, nonfinite: str = "null"):
    """A copy of ``obj`` that :func:`json.dumps` takes with ``allow_nan=False``.

    NumPy scalars and arrays become Python numbers and lists, paths strings,
    tuples and sets lists, dataclasses dicts, other objects their ``str``.

    Parameters
    ----------
    obj : object
        Nested dicts, lists, numbers, strings, paths, NumPy values, dataclasses.
    nonfinite : {"null", "text"}
        How a NaN or infinite float is written (JSON has none): ``None``, or
        the strings ``"nan"``, ``"inf"``, ``"-inf"`` (which keep NaN and
        infinity apart, as a report shows them).

    Returns
    -------
    object
        The same structure with JSON types only.
    """
    if isinstance(obj, dict):
        return {str(k): json_safe(v, nonfinite) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set)):
        return [json_safe(v, nonfinite) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist(), nonfinite)
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else (str(v) if nonfinite == "text" else None)
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return json_safe(dataclasses.asdict(obj), nonfinite)
    if obj is None or isinstance(obj, str):
        return obj
    return str(obj)


def json_text(obj, where: str | Path = "JSON") -> str:
    """``obj`` as JSON text (indent 2, keys in their order, a final newline).

    NumPy numbers, arrays and paths are converted; NaN and infinities are
    refused (JSON has none): pass the object through :func:`json_safe` to
    write them as ``null``.

    Parameters
    ----------
    obj : object
        JSON-serialisable structure.
    where : str or Path
        The file it is for (named by the error).

    Returns
    -------
    str

    Raises
    ------
    InputError
        A NaN, an infinity or an object JSON cannot represent, naming ``where``.
    """

    def default(o):
        if isinstance(o, (np.generic, np.ndarray, os.PathLike, set, tuple)):
            return json_safe(o) if not isinstance(o, np.floating) else float(o)
        raise TypeError(f"{type(o).__name__} is not JSON serialisable")

    try:
        return json.dumps(obj, indent=2, sort_keys=False, allow_nan=False, default=default) + "\n"
    except (ValueError, TypeError) as exc:
        raise InputError(f"cannot write {where} as JSON: {exc}") from None


def write_json(path: str | Path, obj) -> Path:
    """Write ``obj`` as JSON (:func:`json_text`) to ``path``, its folder made.

    Parameters
    ----------
    path : str or Path
        The file.
    obj : object
        JSON-serialisable structure.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        As :func:`json_text`.
    """
    path = Path(path)
    text = json_text(obj, path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


#: A run's record: versions, inputs, settings and every file with its sha256 (:meth:`harness.rundir.RunDir.commit`).
MANIFEST = "manifest.json"


def read_manifest(folder: str | Path) -> dict | None:
    """The manifest of the gflat run in ``folder``, or None when ``folder`` holds none.

    Parameters
    ----------
    folder : str or Path
        A folder.

    Returns
    -------
    dict or None
        ``manifest.json`` when it is a readable JSON object with ``"tool": "gflat"``.
    """
    p = Path(folder) / MANIFEST
    try:
        if p.is_symlink() or not p.is_file():
            return None
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("tool") == "gflat" else None


def manifest_problem(folder: str | Path) -> str | None:
    """What keeps ``folder`` from being a gflat run's, naming the file and what is wrong with it; None if nothing.

    Parameters
    ----------
    folder : str or Path
        A folder.

    Returns
    -------
    str or None
        ``"no manifest.json in <folder>"``, ``"<folder>/manifest.json is not valid JSON (line 1 column 2:
        ...)"``, ``... is a JSON list, not an object``, ``... names tool 'x', not gflat``, ``... 'files' is not
        a list`` or ``... a file entry ... lacks ...`` (a link, a folder, an unreadable file: said so); None
        for a gflat run's manifest (:func:`read_manifest` reads it).
    """
    p = Path(folder) / MANIFEST
    if p.is_symlink():
        return f"{p} is a symbolic link, not a run's manifest"
    if not p.exists():
        return f"no {MANIFEST} in {folder}"
    if not p.is_file():
        return f"{p} is not a regular file"
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        return f"{p} is not UTF-8 text (byte {exc.start})"
    except OSError as exc:
        return f"{p} cannot be read: {describe(exc)}"
    try:
        data = json.loads(text)
    except ValueError as exc:
        return f"{p} is not valid JSON ({describe(exc)})"
    if not isinstance(data, dict):
        return f"{p} is a JSON {_json_kind(data)}, not an object"
    if data.get("tool") != "gflat":
        return f"{p} names tool {data.get('tool')!r}, not 'gflat' (not written by gflat, or before it named itself)"
    files = data.get("files")
    if not isinstance(files, list):
        return f"{p}: 'files' is a JSON {_json_kind(files)}, not a list"
    for f in files:
        ok = isinstance(f, dict) and isinstance(f.get("path"), str) and isinstance(f.get("sha256"), str)
        if not ok or isinstance(f.get("bytes"), bool) or not isinstance(f.get("bytes"), int):
            shown = json.dumps(f)
            shown = shown if len(shown) <= 80 else shown[:77] + "..."
            return f"{p}: a file entry {shown} lacks a string path, an integer bytes or a string sha256"
    return None


def _json_kind(value) -> str:
    """The JSON name of a decoded value's type."""
    for kind, name in ((bool, "boolean"), (str, "string"), ((int, float), "number"), (list, "list"), (dict, "object")):
        if isinstance(value, kind):
            return name
    return "null" if value is None else type(value).__name__


def enclosing_run(path: str | Path) -> Path | None:
    """The nearest of ``path``'s parent folders that is a gflat run's (:func:`read_manifest`).

    Parameters
    ----------
    path : str or Path
        An absolute path (existing or not); only its parents are looked at.

    Returns
    -------
    Path or None
    """
    return next((d for d in Path(path).parents if read_manifest(d) is not None), None)


#: Units of the columns added to every trajectory written.
EXTRA_UNITS: dict[str, str] = {
    "t": "s",
    "h": "m",
    "phi": "rad",
    "theta": "rad",
    "psi": "rad",
    "u": "m/s",
    "v": "m/s",
    "w": "m/s",
    "Mach": "-",
}


def _rotations(axis: int, angle: np.ndarray) -> np.ndarray:
    """The elementary frame rotations of :mod:`gna.frames` (``R1``, ``R2``, ``R3``) at every angle, (n, 3, 3)."""
    n = angle.size
    cos, sin = np.cos(angle), np.sin(angle)
    R = np.zeros((n, 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis - 1]
    R[:, axis - 1, axis - 1] = 1.0
    R[:, i, i], R[:, i, j], R[:, j, i], R[:, j, j] = cos, sin, -sin, cos
    return R


def _euler_angles(gamma, chi, mu, alpha, beta) -> np.ndarray:
    """Body Euler angles (phi, theta, psi) of every sample, (n, 3) [rad]: :func:`gna.frames.euler_from_dcm` of
    :func:`gna.frames.C_body_ned`, on arrays (NaN where an angle is not finite)."""
    C = _rotations(2, alpha) @ _rotations(3, -beta) @ _rotations(1, mu) @ _rotations(2, gamma) @ _rotations(3, chi)
    eul = np.stack(
        [
            np.arctan2(C[:, 1, 2], C[:, 2, 2]),
            -np.arcsin(np.clip(C[:, 0, 2], -1.0, 1.0)),
            np.arctan2(C[:, 0, 1], C[:, 0, 0]),
        ],
        axis=1,
    )
    bad = ~np.all(np.isfinite(np.stack([gamma, chi, mu, alpha, beta])), axis=0)
    eul[bad] = np.nan
    return eul


def augmented(df: pd.DataFrame) -> pd.DataFrame:
    """A trajectory with altitude, Euler angles, body velocities and Mach added.

    Parameters
    ----------
    df : DataFrame
        Indexed by ``t`` [s], with the states ``z``, ``V``, ``gamma``, ``chi``,
        ``alpha``, ``beta``, ``mu`` (SI, rad).

    Returns
    -------
    DataFrame
        A copy with ``h = -z`` [m]; ``phi, theta, psi`` [rad] of ``C_bn =
        C_bw(alpha, beta) C_wn(gamma, chi, mu)``; ``u, v, w = V (cos a cos b,
        sin b, sin a cos b)`` [m/s]; ``Mach = V / a(h)`` with the ISA speed
        of sound (:func:`speed_of_sound`, also under a constant-density
        atmosphere).
    """
    out = df.copy()
    need = ("z", "V", "gamma", "chi", "alpha", "beta", "mu")
    if not all(c in out.columns for c in need) or out.empty:
        return out
    g, c, m, a, b = (out[k].to_numpy(float) for k in ("gamma", "chi", "mu", "alpha", "beta"))
    V = out["V"].to_numpy(float)
    out["h"] = -out["z"].to_numpy(float)
    eul = _euler_angles(g, c, m, a, b)
    out["phi"], out["theta"], out["psi"] = eul[:, 0], eul[:, 1], eul[:, 2]
    out["u"] = V * np.cos(a) * np.cos(b)
    out["v"] = V * np.sin(b)
    out["w"] = V * np.sin(a) * np.cos(b)
    out["Mach"] = V / speed_of_sound(out["h"].to_numpy(float))
    return out


def units_of(columns) -> dict[str, str]:
    """The unit of each column (:data:`gna.trajectory.UNITS` and :data:`EXTRA_UNITS`).

    Parameters
    ----------
    columns : iterable of str
        Column names.

    Returns
    -------
    dict
        Column -> unit (``""`` when unknown).
    """
    return {c: EXTRA_UNITS.get(c, UNITS.get(c, "")) for c in columns}


def trajectory_table(df: pd.DataFrame, metadata: dict | None = None):
    """A trajectory as a pyarrow Table, time first, with the units in the field metadata.

    Parameters
    ----------
    df : DataFrame
        Indexed by time [s].
    metadata : dict, optional
        Added to the file metadata as JSON (key ``gflat``).

    Returns
    -------
    pyarrow.Table
    """
    import pyarrow as pa

    flat = df.reset_index()
    flat = flat.rename(columns={flat.columns[0]: "t"})
    units = units_of(flat.columns)
    fields = [
        pa.field(str(c), pa.float64() if flat[c].dtype.kind in "fiu" else pa.string(), metadata={"unit": units[c]})
        for c in flat.columns
    ]
    meta = {"gflat.units": json.dumps(units)}
    if metadata:
        meta["gflat"] = json.dumps(json_safe(metadata))
    schema = pa.schema(fields, metadata=meta)
    return pa.Table.from_pandas(flat, schema=schema, preserve_index=False)


#: Options of the trajectories' Parquet files: plain encoding (a dictionary of float samples, nearly all
#: distinct, costs more time than it saves bytes: the files come out smaller without), Snappy compression.
PARQUET_OPTIONS = {"use_dictionary": False, "compression": "snappy"}


def write_trajectory(
    out: str | Path, name: str, df: pd.DataFrame, *, csv: bool = False, metadata: dict | None = None
) -> list[Path]:
    """Write ``<name>.parquet`` (and ``<name>.csv``) of a trajectory, with the added columns.

    Parameters
    ----------
    out : str or Path
        Folder (made when missing).
    name : str
        File name without suffix, e.g. ``"trajectory-jsbsim"``.
    df : DataFrame
        Indexed by time [s] (columns of :data:`gna.trajectory.COLUMNS`).
    csv : bool
        Also write a CSV (header: column names; units in the Parquet file and ``summary.json``).
    metadata : dict, optional
        Stored in the Parquet metadata (run status, settings).

    Returns
    -------
    list of Path
        The files written.
    """
    import pyarrow.parquet as pq

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    full = augmented(df)
    table = trajectory_table(full, metadata)
    pq.write_table(table, out / f"{name}.parquet", **PARQUET_OPTIONS)
    paths = [out / f"{name}.parquet"]
    if csv:
        full.reset_index().rename(columns=lambda c: "t" if c in ("index", full.index.name) else c).to_csv(
            out / f"{name}.csv", index=False, float_format="%.12g"
        )
        paths.append(out / f"{name}.csv")
    return paths


def read_trajectory(path: str | Path) -> tuple[pd.DataFrame, dict[str, str]]:
    """Read a trajectory written by :func:`write_trajectory`.

    Parameters
    ----------
    path : str or Path
        A ``.parquet`` file.

    Returns
    -------
    df : DataFrame
        Indexed by ``t`` [s].
    units : dict
        Column -> unit, from the field metadata.
    """
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    units = {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in table.schema}
    return table.to_pandas().set_index("t"), units


def file_record(path: str | Path | None) -> dict | None:
    """Path and sha256 of an input file.

    Parameters
    ----------
    path : str or Path or None
        The file.

    Returns
    -------
    dict or None
        ``{"path", "sha256"}``; None without a readable file.
    """
    if not path:
        return None
    p = Path(path)
    try:
        return {"path": str(p.resolve()), "sha256": hashlib.sha256(p.read_bytes()).hexdigest()}
    except OSError:
        return None


@functools.cache
def package_version(pkg: str) -> str | None:
    """The installed version of a distribution (read once per process: the installed packages do not change
    under a running command).

    Parameters
    ----------
    pkg : str
        Distribution name, e.g. ``"jsbsim"``.

    Returns
    -------
    str or None
        None when it is not installed.
    """
    try:
        return importlib.metadata.version(pkg)
    except importlib.metadata.PackageNotFoundError:
        return None


@functools.cache
def source_commit() -> str | None:
    """The git commit of gflat's source tree (``git rev-parse HEAD``, run once per process: the code running is
    the one imported).

    Returns
    -------
    str or None
        None outside a git checkout, or without git.
    """
    try:
        r = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=Path(__file__).resolve().parent, capture_output=True, text=True, timeout=5
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout.strip() if r.returncode == 0 and r.stdout.strip() else None


def manifest(*, inputs: dict | None = None, cases: list | None = None, command_line: list | None = None) -> dict:
    """What a run was made with: versions, commit, UTC date, command line, inputs, settings.

    Parameters
    ----------
    inputs : dict, optional
        Name -> :func:`file_record` of the aircraft and scenario files.
    cases : list of dict, optional
        Per case: scenario, loop, integrator settings per engine, JSBSim step,
        tolerances (:func:`case_record`).
    command_line : list of str, optional
        Default ``sys.argv``.

    Returns
    -------
    dict
        ``gflat, jsbsim, numpy, scipy, pandas, pyarrow, python`` versions,
        ``git_commit`` (absent outside a git checkout), ``date_utc``,
        ``command_line``, ``inputs``, ``cases``.
    """
    out = {
        "gflat": package_version("gflat"),
        "jsbsim": package_version("jsbsim"),
        "numpy": np.__version__,
        "scipy": package_version("scipy"),
        "pandas": pd.__version__,
        "pyarrow": package_version("pyarrow"),
        "python": platform.python_version(),
    }
    commit = source_commit()
    if commit is not None:
        out["git_commit"] = commit
    out["date_utc"] = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    out["command_line"] = list(sys.argv if command_line is None else command_line)
    out["inputs"] = {k: v for k, v in (inputs or {}).items() if v is not None}
    out["cases"] = list(cases or [])
    return json_safe(out)


def case_inputs(result) -> dict:
    """The input files of a case result: its scenario and aircraft, with their sha256.

    Parameters
    ----------
    result : harness.validation.CaseResult
        A case's result.

    Returns
    -------
    dict
        ``"<scenario> scenario"`` and ``"<aircraft> aircraft"`` -> :func:`file_record`.
    """
    sc = getattr(result, "scenario", None)
    plan = result.plan
    return {
        f"{plan.name} scenario": file_record(getattr(sc, "path", None)),
        f"{plan.aircraft.id} aircraft": file_record(getattr(plan.aircraft, "path", None)),
    }


def case_record(result) -> dict:
    """A case's settings for the manifest: engines' integrator settings, JSBSim step, tolerances.

    Parameters
    ----------
    result : harness.validation.CaseResult
        A case's result.

    Returns
    -------
    dict
        ``scenario``, ``loop``, ``J``, ``engines`` (name -> run settings), ``compare`` (the settings),
        ``tracking`` (closed loop: the design flown, ``"paper"`` or ``"lqr"``; None open loop).
    """
    return {
        "scenario": result.plan.name,
        "loop": result.case.loop,
        "J": result.plan.J,
        "engines": {k: r.settings.as_dict() for k, r in result.runs.items()},
        "compare": result.settings.to_dict() if result.settings is not None else None,
        "tracking": tracking_design(result),
    }


def tracking_design(result) -> str | None:
    """The tracking design a case flew (``"paper"`` or ``"lqr"``), None for an open-loop case.

    Parameters
    ----------
    result : harness.validation.CaseResult

    Returns
    -------
    str or None
    """
    closed = getattr(result, "closed_loop", None)
    return None if closed is None else getattr(closed.controller, "design", "paper")


def cpu_time() -> float:
    """CPU time of this process and of its children that have ended [s] (user + system).

    Returns
    -------
    float
    """
    import resource

    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def cpu_split(tasks, plan_s: float, render_s: float, total_s: float) -> dict:
    """The CPU of a run by stage, for its manifest's ``execution.cpu_s``.

    Parameters
    ----------
    tasks : list of dict
        The worker tasks' log (:attr:`harness.parallel.ForkPool.log`: ``what``, ``cpu_s``): ``flying ...``
        tasks count as flying, ``writing ...`` ones as writing.
    plan_s : float
        CPU of planning (and writing the plans' files) [s].
    render_s : float
        CPU of rendering the pages and printing the PDF, and of preparing the figures in the command's
        process [s].
    total_s : float
        CPU of the whole run, its worker processes included [s].

    Returns
    -------
    dict
        ``plan``, ``fly``, ``write`` (the case folders' figures and files, the pages and the PDF),
        ``other`` (the rest: tabulating and judging the flights, the command's own work) and ``total`` [s],
        and ``write_share``: ``write / total``.
    """
    fly = sum(t.get("cpu_s", 0.0) for t in tasks if str(t.get("what", "")).startswith("flying"))
    write = sum(t.get("cpu_s", 0.0) for t in tasks if str(t.get("what", "")).startswith("writing")) + render_s
    other = max(total_s - plan_s - fly - write, 0.0)
    return {
        "plan": plan_s,
        "fly": fly,
        "write": write,
        "other": other,
        "total": total_s,
        "write_share": write / total_s if total_s > 0 else None,
    }


def run_manifest(results=(), *, command_line: list | None = None, execution: dict | None = None) -> dict:
    """The manifest of a run's case results (what :meth:`harness.rundir.RunDir.commit` records).

    Parameters
    ----------
    results : iterable of CaseResult
        The cases run.
    command_line : list of str, optional
        Default ``sys.argv``.
    execution : dict, optional
        How the run was executed (e.g. worker processes), recorded as ``"execution"``.

    Returns
    -------
    dict
        :func:`manifest` of the cases' inputs and settings, with ``execution``.
    """
    inputs, cases = {}, []
    for r in results:
        inputs.update(case_inputs(r))
        cases.append(case_record(r))
    record = manifest(inputs=inputs, cases=cases, command_line=command_line)
    if execution is not None:
        record["execution"] = json_safe(execution)
    return record


def write_plan_iterates(out: str | Path, plan, times, *, csv: bool = False, iterates=None) -> list[Path]:
    """Write the plan of every iterate, ``plan-j<k>.parquet`` (and ``plan-j<k>.csv``), on the given times.

    Parameters
    ----------
    out : str or Path
        Folder (e.g. ``<scenario>/plan``).
    plan : planners.plan.Plan
        The plan.
    times : array_like, shape (N,)
        Times [s].
    csv : bool
        Also write CSV files.
    iterates : sequence of int, optional
        The iterates written (default every one, 0 to J).

    Returns
    -------
    list of Path
    """
    t = np.asarray(times, dtype=float)
    paths = []
    for j in range(plan.J + 1) if iterates is None else iterates:
        paths += write_trajectory(
            out,
            f"plan-j{j}",
            plan.to_dataframe(t, j=j),
            csv=csv,
            metadata={"plan": plan.name, "iterate": j, "J": plan.J},
        )
    return paths


def _run_meta(res) -> dict:
    return {"status": res.status, "message": res.message, "t_end": res.t_end, "settings": res.settings.as_dict()}


def write_artefacts(
    result,
    out: str | Path,
    *,
    csv: bool = False,
    plan: bool = True,
    manifest: bool = True,
    figures=(),
    extra: dict | None = None,
    command_line: list | None = None,
) -> dict[str, list[Path]]:
    """Write a case result's data: trajectories, ``differences.txt``, ``summary.json``, plan, manifest.

    Parameters
    ----------
    result : harness.validation.CaseResult
        A case's result (:func:`harness.validation.run_case`).
    out : str or Path
        The case folder (made when missing).
    csv : bool
        Also write every trajectory as CSV.
    plan : bool
        Write the plan of every iterate under ``plan/``.
    manifest : bool
        Write ``manifest.json`` in the folder (:func:`run_manifest`; a command's run records it through
        :meth:`harness.rundir.RunDir.commit` instead).
    figures : sequence of path
        Figures already written, listed in ``summary.json``.
    extra : dict, optional
        Added to ``summary.json``.
    command_line : list of str, optional
        The command recorded in the manifest (default ``sys.argv``).

    Returns
    -------
    dict
        ``"trajectories"``, ``"plan"`` -> list of Path; ``"differences"``,
        ``"summary"``, ``"manifest"`` -> [Path].
    """
    od = Path(out)
    od.mkdir(parents=True, exist_ok=True)
    files: dict[str, list[Path]] = {"trajectories": [], "plan": []}
    for label, res in result.runs.items():
        files["trajectories"] += write_trajectory(od, f"trajectory-{label}", res.df, csv=csv, metadata=_run_meta(res))
    for label, res in getattr(result, "half_step", {}).items():
        files["trajectories"] += write_trajectory(
            od, f"trajectory-{label}-half-step", res.df, csv=csv, metadata=_run_meta(res)
        )
    if result.open_loop is not None:
        files["trajectories"] += write_trajectory(
            od,
            f"trajectory-{result.reference_engine}-open-loop",
            result.open_loop.df,
            csv=csv,
            metadata=_run_meta(result.open_loop),
        )
    if plan:
        times = np.asarray(result.runs[result.reference_engine].df.index, dtype=float)
        files["plan"] = write_plan_iterates(od / "plan", result.plan, times, csv=csv)
    (od / "differences.txt").write_text(result.report_text() + "\n", encoding="utf-8")
    files["differences"] = [od / "differences.txt"]
    summary = dict(
        result.summary(figures),
        provenance=result.provenance,
        verdict=result.verdict(),
        loop=result.case.loop,
        units=units_of(list(EXTRA_UNITS) + list(UNITS)),
        trajectories=[p.name for p in files["trajectories"]],
    )
    if result.closed_loop is not None:
        summary.update(
            saturated_s=result.saturated_s(),
            feedforward_iterate=result.closed_loop.feedforward_iterate,
            tracking=tracking_design(result),
        )
    summary.update(extra or {})
    files["summary"] = [write_json(od / "summary.json", json_safe(summary))]
    if manifest:
        files["manifest"] = [write_json(od / "manifest.json", run_manifest([result], command_line=command_line))]
    return files
