"""Start-up time of the ``gflat`` command line and of ``import gflat``, against ``python -c pass`` in the same run.

Five commands, each run ``--runs`` times (default 5), interleaved (one of each per round, the order rotated
every round so that none always follows the same one):

* ``python -c pass``: the peer, the interpreter's own start-up;
* ``gflat --version`` and ``gflat --help``: the console script (the ``gflat`` on ``PATH``, or ``--gflat``);
* ``python -m gflat --version``;
* ``python -c "import gflat"``.

Every child runs the checkout this script is in (its root first on ``PYTHONPATH``).  Printed per command:
the median, min and max of the wall time [s], the median CPU time of the child and its own children
(user + system, from ``getrusage``) [s], and the differences and ratios of the medians against
``python -c pass``; with the load average (1, 5, 15 min) at the start and the end.  The target of issue 21:
``gflat --version`` and ``gflat --help`` at most 0.3 s more than ``python -c pass``::

    python benchmarks/bench_cli_startup.py [--runs 5] [--gflat PATH] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PEER = "python -c pass"
#: The budget over the peer of ``gflat --version`` and ``gflat --help`` [s].
BUDGET_S = 0.3


def commands(gflat: str) -> dict[str, list[str]]:
    """Label -> command line of each measured command (the peer first).

    Parameters
    ----------
    gflat : str
        Path of the ``gflat`` console script.

    Returns
    -------
    dict
    """
    py = sys.executable
    return {
        PEER: [py, "-c", "pass"],
        "gflat --version": [gflat, "--version"],
        "gflat --help": [gflat, "--help"],
        "python -m gflat --version": [py, "-m", "gflat", "--version"],
        'python -c "import gflat"': [py, "-c", "import gflat"],
    }


def run_once(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU time of one run of ``argv`` (its output discarded).

    Parameters
    ----------
    argv : list of str
        The command line.
    env : dict
        Its environment.

    Returns
    -------
    (float, float)
        Wall time [s]; CPU time of the child and its descendants, user + system [s].

    Raises
    ------
    RuntimeError
        The command could not start, or exited with a non-zero status.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        done = subprocess.run(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    except OSError as exc:
        raise RuntimeError(f"cannot run {argv[0]}: {exc.strerror}") from None
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} exited with {done.returncode}: {done.stderr.strip()[-500:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def measure(runs: int = 5, gflat: str | None = None) -> dict:
    """Run every command of :func:`commands` ``runs`` times, interleaved, and summarise.

    Parameters
    ----------
    runs : int
        Runs of each command.
    gflat : str, optional
        The console script (default: ``gflat`` on ``PATH``).

    Returns
    -------
    dict
        ``runs``, ``gflat`` (the script's path), ``python``, ``loadavg_start``/``loadavg_end`` (1, 5, 15 min),
        ``budget_s`` and ``entries``: label -> ``wall_s`` (every run), ``wall_median_s``, ``wall_min_s``,
        ``wall_max_s``, ``cpu_median_s``, ``wall_minus_peer_s``, ``wall_ratio_to_peer``, ``cpu_ratio_to_peer``.

    Raises
    ------
    RuntimeError
        No ``gflat`` script found, or a command failed.
    """
    gflat = gflat or shutil.which("gflat")
    if not gflat:
        raise RuntimeError("no gflat console script on PATH (pip install -e .), or give --gflat PATH")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    table = commands(gflat)
    labels = list(table)
    samples = {label: [] for label in labels}
    load_start = os.getloadavg()
    for r in range(runs):
        for label in labels[r % len(labels) :] + labels[: r % len(labels)]:
            samples[label].append(run_once(table[label], env))
    load_end = os.getloadavg()
    entries = {}
    for label in labels:
        wall = [w for w, _ in samples[label]]
        cpu = [c for _, c in samples[label]]
        entries[label] = {
            "wall_s": wall,
            "wall_median_s": statistics.median(wall),
            "wall_min_s": min(wall),
            "wall_max_s": max(wall),
            "cpu_median_s": statistics.median(cpu),
        }
    peer = entries[PEER]
    for e in entries.values():
        e["wall_minus_peer_s"] = e["wall_median_s"] - peer["wall_median_s"]
        e["wall_ratio_to_peer"] = e["wall_median_s"] / peer["wall_median_s"]
        e["cpu_ratio_to_peer"] = e["cpu_median_s"] / peer["cpu_median_s"] if peer["cpu_median_s"] > 0 else None
    return {
        "runs": runs,
        "gflat": gflat,
        "python": sys.executable,
        "loadavg_start": list(load_start),
        "loadavg_end": list(load_end),
        "budget_s": BUDGET_S,
        "entries": entries,
    }


def format_table(result: dict) -> str:
    """The figures of :func:`measure` as a text table.

    Parameters
    ----------
    result : dict
        From :func:`measure`.

    Returns
    -------
    str
    """
    head = (
        f"{'command':<28} {'wall median':>11} {'min':>7} {'max':>7} {'CPU median':>10} "
        f"{'- peer':>8} {'/ peer':>7} {'CPU / peer':>10}"
    )
    lines = [
        f"gflat start-up, {result['runs']} interleaved runs each; peer: {PEER}",
        f"gflat script: {result['gflat']}",
        "load average (1, 5, 15 min) at start: {:.2f} {:.2f} {:.2f}".format(*result["loadavg_start"]),
        head,
        "-" * len(head),
    ]
    for label, e in result["entries"].items():
        cpu_ratio = "-" if e["cpu_ratio_to_peer"] is None else f"{e['cpu_ratio_to_peer']:.2f}"
        lines.append(
            f"{label:<28} {e['wall_median_s']:>10.3f}s {e['wall_min_s']:>6.3f}s {e['wall_max_s']:>6.3f}s "
            f"{e['cpu_median_s']:>9.3f}s {e['wall_minus_peer_s']:>+7.3f}s {e['wall_ratio_to_peer']:>6.2f}x "
            f"{cpu_ratio:>10}"
        )
    lines.append("load average (1, 5, 15 min) at end:   {:.2f} {:.2f} {:.2f}".format(*result["loadavg_end"]))
    for label in ("gflat --version", "gflat --help"):
        over = result["entries"][label]["wall_minus_peer_s"]
        verdict = "within" if over <= result["budget_s"] else "OVER"
        lines.append(f"{label}: {over:+.3f} s over the peer ({verdict} the {result['budget_s']:g} s budget)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its table (or JSON).

    Parameters
    ----------
    argv : list of str, optional
        Command-line words (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0, or 2 when a command could not run.
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", "-n", type=int, default=5, help="runs of each command (default 5)")
    parser.add_argument("--gflat", help="the gflat console script (default: gflat on PATH)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs must be at least 1, got {args.runs}")
    try:
        result = measure(args.runs, args.gflat)
    except RuntimeError as exc:
        print(f"bench_cli_startup: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(result, indent=2) if args.json else format_table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
