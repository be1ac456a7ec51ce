"""A fresh install's first ``gflat plan`` (an empty cache: the native library not yet compiled) against warm ones.

Measures an installed ``gflat`` console script (``--gflat``, default the one on ``PATH``), as a user has it:
its children run without ``PYTHONPATH``, ``GFLAT_NATIVE_WAIT`` or ``GFLAT_SERIES_BACKEND``, each in a temporary
folder with its own ``--out``.  For each scenario, ``--rounds`` rounds, each on a new empty cache folder
(``XDG_CACHE_HOME``, where ``planners/_native.py`` keeps the compiled library):

* ``first``: ``gflat plan SCENARIO --json`` on the empty cache (it finds no library, starts the compiler in
  the background and plans on the numpy path);
* then the wait for that background build (the library file in the cache, the build's lock file gone);
* ``warm``: the same command, the library loaded from the cache;
* ``numpy``: the same with ``GFLAT_SERIES_BACKEND=numpy`` (what the first command's plan runs on).

Printed per scenario and kind: every run's wall time, CPU time (user + system of the command and its
waited-for children, from ``getrusage``: the detached background compiler is not among them) and
``planning_time_s``, their medians, and first − warm; whether every run's plan agrees with the warm one (the
equation residual of every iterate to 1e-9 relative
or 1e-12 absolute); the load average (1, 5, 15 min) at each scenario's start
and at the end.  The goal of issue 23: the first command at most 2 s over a warm one.

``--concurrent N`` also starts N commands at once on one empty cache, twice: as a user would (background build)
and with ``GFLAT_NATIVE_WAIT=1`` (each compiles at once, into a temporary file renamed into place).  The
compiler is a logging wrapper around the real one (``$CC``, else ``cc``), so the compilations are counted; the
cache folder's files after the builds, each command's status and its plan's agreement are printed::

    python benchmarks/bench_first_run.py --gflat /tmp/fresh-venv/bin/gflat [--rounds 3] [--concurrent 2]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENARIOS = ("gtm-aileron-roll", "twin-otter-single-engine", "gtm-forward-slip")
KINDS = ("first", "warm", "numpy")
#: The goal of issue 23: the first command's wall time over a warm one's [s].
BUDGET_S = 2.0
#: Longest wait for a background build [s] (``planners._native.BUILD_LOCK_S``'s order).
BUILD_WAIT_S = 300.0
#: Variables of the measuring environment a user's shell does not have.
CLEARED = ("PYTHONPATH", "GFLAT_NATIVE_WAIT", "GFLAT_SERIES_BACKEND")


def child_env(cache: Path, **extra: str) -> dict[str, str]:
    """The environment of a measured command: this one's less :data:`CLEARED`, the cache folder set.

    Parameters
    ----------
    cache : pathlib.Path
        Its ``XDG_CACHE_HOME``.
    **extra : str
        More variables.

    Returns
    -------
    dict
    """
    env = {k: v for k, v in os.environ.items() if k not in CLEARED}
    env["XDG_CACHE_HOME"] = str(cache)
    env.update(extra)
    return env


def plan_command(gflat: str, scenario: str, out: Path) -> list[str]:
    """The measured command line.

    Parameters
    ----------
    gflat : str
        The console script.
    scenario : str
        A bundled scenario.
    out : pathlib.Path
        Its ``--out`` folder (not yet existing).

    Returns
    -------
    list of str
    """
    return [gflat, "plan", scenario, "--json", "--out", str(out)]


def run_plan(gflat: str, scenario: str, work: Path, env: dict[str, str]) -> dict:
    """One ``gflat plan`` in ``work``: wall and CPU time, its ``planning_time_s`` and residuals.

    Parameters
    ----------
    gflat : str
        The console script.
    scenario : str
        A bundled scenario.
    work : pathlib.Path
        The folder it runs in (its output goes to a new sub-folder).
    env : dict
        Its environment (:func:`child_env`).

    Returns
    -------
    dict
        ``wall_s``, ``cpu_s`` (user + system of the command and its waited-for children), ``planning_s``,
        ``residuals`` (the equation residual per iterate), ``feasible``.

    Raises
    ------
    RuntimeError
        The command could not start, failed, or printed no JSON.
    """
    out = Path(tempfile.mkdtemp(prefix="out-", dir=work))
    out.rmdir()  # gflat creates its --out folder whole
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        done = subprocess.run(plan_command(gflat, scenario, out), env=env, cwd=work, capture_output=True, text=True)
    except OSError as exc:
        raise RuntimeError(f"cannot run {gflat}: {exc.strerror}") from None
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"gflat plan {scenario} exited with {done.returncode}: {done.stderr.strip()[-300:]}")
    try:
        summary = json.loads(done.stdout)
    except json.JSONDecodeError:
        raise RuntimeError(f"gflat plan {scenario} printed no JSON: {done.stdout.strip()[:200]}") from None
    return {
        "wall_s": wall,
        "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        "planning_s": summary["planning_time_s"],
        "residuals": summary["equation_residual_per_iterate"],
        "feasible": summary["feasible"],
    }


def library_files(cache: Path) -> list[Path]:
    """The compiled libraries in a cache folder (``gflat/native/gflat_program-*``, no temporary files)."""
    return sorted((cache / "gflat" / "native").glob("gflat_program-*"))


def wait_for_build(cache: Path, limit_s: float = BUILD_WAIT_S) -> float:
    """Wait until the background build has put its library in ``cache`` and removed its lock file.

    Parameters
    ----------
    cache : pathlib.Path
        The ``XDG_CACHE_HOME``.
    limit_s : float
        Longest wait [s].

    Returns
    -------
    float
        The wait [s].

    Raises
    ------
    RuntimeError
        No library after ``limit_s`` (the reason in a ``.failed`` file when the build failed).
    """
    folder = cache / "gflat" / "native"
    start = time.perf_counter()
    while time.perf_counter() - start < limit_s:
        if library_files(cache) and not list(folder.glob(".*.building")):
            return time.perf_counter() - start
        failed = list(folder.glob(".*.failed"))
        if failed:
            raise RuntimeError(f"the background build failed: {failed[0].read_text()[:300]}")
        time.sleep(0.05)
    raise RuntimeError(f"no library in {folder} after {limit_s:g} s")


def agrees(a: dict, b: dict, rtol: float = 1e-9, atol: float = 1e-12) -> bool:
    """Whether two runs' plans agree: the same feasibility and every iterate's residual to ``rtol`` or ``atol``
    (the numpy and the native paths agree to 1e-12, ``tests/planners/test_native.py``)."""
    ra, rb = a["residuals"], b["residuals"]
    return (
        a["feasible"] == b["feasible"]
        and len(ra) == len(rb)
        and all(abs(x - y) <= max(rtol * max(abs(x), abs(y)), atol) for x, y in zip(ra, rb))
    )


def summarise(runs: dict[str, list[dict]]) -> dict:
    """Medians per kind and first − warm.

    Parameters
    ----------
    runs : dict
        Kind (:data:`KINDS`) -> its runs (:func:`run_plan`).

    Returns
    -------
    dict
        Kind -> ``wall_s``, ``cpu_s``, ``planning_s`` medians; ``first_minus_warm_wall_s`` and ``_cpu_s``.
    """
    med = {
        k: {m: statistics.median(r[m] for r in v) for m in ("wall_s", "cpu_s", "planning_s")} for k, v in runs.items()
    }
    med["first_minus_warm_wall_s"] = med["first"]["wall_s"] - med["warm"]["wall_s"]
    med["first_minus_warm_cpu_s"] = med["first"]["cpu_s"] - med["warm"]["cpu_s"]
    return med


def measure_scenario(gflat: str, scenario: str, rounds: int, work: Path) -> dict:
    """The rounds of one scenario (module docstring).

    Parameters
    ----------
    gflat : str
        The console script.
    scenario : str
        A bundled scenario.
    rounds : int
        Rounds, each on a new empty cache.
    work : pathlib.Path
        A scratch folder.

    Returns
    -------
    dict
        ``loadavg_start``, ``runs`` (kind -> list of :func:`run_plan`), ``build_wait_s``, ``agree`` (every
        run's plan agrees with the first warm one), ``medians`` (:func:`summarise`).
    """
    load = os.getloadavg()
    runs: dict[str, list[dict]] = {k: [] for k in KINDS}
    waits = []
    for _ in range(rounds):
        cache = Path(tempfile.mkdtemp(prefix="cache-", dir=work))
        runs["first"].append(run_plan(gflat, scenario, work, child_env(cache)))
        waits.append(wait_for_build(cache))
        runs["warm"].append(run_plan(gflat, scenario, work, child_env(cache)))
        runs["numpy"].append(run_plan(gflat, scenario, work, child_env(cache, GFLAT_SERIES_BACKEND="numpy")))
    ref = runs["warm"][0]
    return {
        "loadavg_start": list(load),
        "runs": runs,
        "build_wait_s": waits,
        "agree": all(agrees(r, ref) for v in runs.values() for r in v),
        "medians": summarise(runs),
    }


def _compiler_wrapper(folder: Path) -> tuple[Path, Path]:
    """A ``CC`` that logs each call to a file and runs the real compiler (``$CC``, else ``cc``)."""
    real = shlex.split(os.environ.get("CC") or "cc")
    if not real or shutil.which(real[0]) is None:
        raise RuntimeError("no C compiler to wrap (set CC, or install cc)")
    log = folder / "compiler-calls.log"
    log.touch()
    wrapper = folder / "cc-logged"
    wrapper.write_text(f'#!/bin/sh\necho "$*" >> {shlex.quote(str(log))}\nexec {shlex.join(real)} "$@"\n')
    wrapper.chmod(0o755)
    return wrapper, log


def measure_concurrent(gflat: str, scenario: str, n: int, work: Path, wait: bool) -> dict:
    """``n`` commands started at once on one empty cache.

    Parameters
    ----------
    gflat : str
        The console script.
    scenario : str
        A bundled scenario.
    n : int
        Commands at once.
    work : pathlib.Path
        A scratch folder.
    wait : bool
        With ``GFLAT_NATIVE_WAIT=1`` (each compiles before planning) rather than the background build.

    Returns
    -------
    dict
        ``mode``, ``loadavg_start``, ``status`` (each exit status), ``wall_s`` (each), ``compilations`` (the
        compiler's calls with ``-o``), ``cache_files`` (the cache folder's file names after the builds),
        ``agree`` (every command's plan agrees with the first's).
    """
    folder = Path(tempfile.mkdtemp(prefix="concurrent-", dir=work))
    cache = folder / "cache"
    wrapper, log = _compiler_wrapper(folder)
    extra = {"CC": str(wrapper), **({"GFLAT_NATIVE_WAIT": "1"} if wait else {})}
    env = child_env(cache, **extra)
    load = os.getloadavg()
    procs, starts = [], []
    for i in range(n):
        starts.append(time.perf_counter())
        procs.append(
            subprocess.Popen(
                plan_command(gflat, scenario, folder / f"out{i}"),
                env=env,
                cwd=folder,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
        )
    results, walls, status = [], [], []
    for p, t0 in zip(procs, starts):
        out, err = p.communicate()
        walls.append(time.perf_counter() - t0)
        status.append(p.returncode)
        try:
            s = json.loads(out)
            results.append({"residuals": s["equation_residual_per_iterate"], "feasible": s["feasible"]})
        except (json.JSONDecodeError, KeyError):
            results.append({"residuals": [], "feasible": None, "stderr": err.strip()[-300:]})
    wait_for_build(cache)
    calls = [line for line in log.read_text().splitlines() if " -o " in f" {line} "]
    return {
        "mode": "GFLAT_NATIVE_WAIT=1" if wait else "background build",
        "loadavg_start": list(load),
        "status": status,
        "wall_s": walls,
        "compilations": len(calls),
        "cache_files": sorted(p.name for p in (cache / "gflat" / "native").iterdir()),
        "agree": all(agrees(r, results[0]) for r in results),
    }


def measure(gflat: str | None, scenarios: list[str], rounds: int, concurrent: int) -> dict:
    """Every scenario's rounds, then the concurrent starts (``concurrent`` > 0) on the first scenario.

    Parameters
    ----------
    gflat : str, optional
        The console script (default: ``gflat`` on ``PATH``).
    scenarios : list of str
        Bundled scenarios.
    rounds : int
        Rounds per scenario.
    concurrent : int
        Commands started at once (0: none).

    Returns
    -------
    dict
        ``gflat``, ``rounds``, ``budget_s``, ``scenarios`` (name -> :func:`measure_scenario`), ``concurrent``
        (a list of :func:`measure_concurrent`), ``loadavg_end``.

    Raises
    ------
    RuntimeError
        No console script, a command failed, or a build did not finish.
    """
    gflat = gflat or shutil.which("gflat")
    if not gflat:
        raise RuntimeError("no gflat console script on PATH: give --gflat PATH (a fresh install's)")
    with tempfile.TemporaryDirectory(prefix="gflat-first-run-") as tmp:
        work = Path(tmp)
        result = {
            "gflat": gflat,
            "rounds": rounds,
            "budget_s": BUDGET_S,
            "scenarios": {s: measure_scenario(gflat, s, rounds, work) for s in scenarios},
            "concurrent": [measure_concurrent(gflat, scenarios[0], concurrent, work, w) for w in (False, True)]
            if concurrent > 0
            else [],
        }
    result["loadavg_end"] = list(os.getloadavg())
    return result


def format_table(result: dict) -> str:
    """The figures of :func:`measure` as text.

    Parameters
    ----------
    result : dict
        From :func:`measure`.

    Returns
    -------
    str
    """
    lines = [f"first gflat plan on an empty cache against warm ones; {result['rounds']} rounds; {result['gflat']}"]
    for name, s in result["scenarios"].items():
        lines.append(f"{name} (load average at start {' '.join(f'{x:.2f}' for x in s['loadavg_start'])})")
        for kind in KINDS:
            runs = s["runs"][kind]
            m = s["medians"][kind]
            walls = " ".join(f"{r['wall_s']:.3f}" for r in runs)
            cpus = " ".join(f"{r['cpu_s']:.3f}" for r in runs)
            lines.append(
                f"  {kind:<6} wall {walls} (median {m['wall_s']:.3f} s)  CPU {cpus} (median {m['cpu_s']:.3f} s)  "
                f"planning {m['planning_s']:.4f} s"
            )
        m = s["medians"]
        verdict = "within" if m["first_minus_warm_wall_s"] <= result["budget_s"] else "OVER"
        lines.append(
            f"  first - warm: {m['first_minus_warm_wall_s']:+.3f} s wall ({verdict} the {result['budget_s']:g} s "
            f"budget), {m['first_minus_warm_cpu_s']:+.3f} s CPU; background builds ready "
            f"{' '.join(f'{w:.2f}' for w in s['build_wait_s'])} s after the first command; "
            f"plans agree: {s['agree']}"
        )
    for c in result["concurrent"]:
        lines.append(
            f"concurrent, {c['mode']} (load {c['loadavg_start'][0]:.2f}): exit {c['status']}, wall "
            f"{' '.join(f'{w:.2f}' for w in c['wall_s'])} s, {c['compilations']} compilation(s), plans agree: "
            f"{c['agree']}; cache: {', '.join(c['cache_files'])}"
        )
    lines.append("load average (1, 5, 15 min) at end: " + " ".join(f"{x:.2f}" for x in result["loadavg_end"]))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its figures (or JSON).

    Parameters
    ----------
    argv : list of str, optional
        Command-line words (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0, or 2 when a command or a build failed.
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--gflat", help="the installed gflat console script (default: gflat on PATH)")
    parser.add_argument("--scenarios", default=",".join(SCENARIOS), help="bundled scenarios, comma-separated")
    parser.add_argument("--rounds", type=int, default=3, help="rounds per scenario, each on an empty cache (3)")
    parser.add_argument("--concurrent", type=int, default=0, help="commands started at once on one empty cache")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error(f"--rounds must be at least 1, got {args.rounds}")
    if args.concurrent < 0:
        parser.error(f"--concurrent must be 0 or more, got {args.concurrent}")
    scenarios = [s for s in args.scenarios.split(",") if s]
    if not scenarios:
        parser.error("--scenarios: at least one scenario")
    try:
        result = measure(args.gflat, scenarios, args.rounds, args.concurrent)
    except RuntimeError as exc:
        print(f"bench_first_run: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(result, indent=2) if args.json else format_table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
