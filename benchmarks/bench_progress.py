"""Time to the first progress line of a long command, against the time its modules take to load, in the same run.

Runs a ``gflat`` command (default ``gflat paper --out <tmp> --replace``) with stderr on a pipe, so that its
progress is the plain timestamped lines of :mod:`harness.progress`, and prints every stderr line prefixed
with the seconds since the child was started (``ts -s`` style, the clock of this process), then the seconds
to the first line (``started``: printed as soon as the command is read) against the seconds to the line of
the command's modules loaded (when the first line would come without the early one), the whole run's wall
time and the number of stage lines::

    python benchmarks/bench_progress.py [--json] [-- COMMAND WORDS ...]

e.g. ``python benchmarks/bench_progress.py -- compare gtm-forward-slip --out /tmp/c --replace``.  The child
runs the checkout this script is in (its root first on ``PYTHONPATH``) with ``GFLAT_PROGRESS=plain`` and
``GFLAT_NATIVE_WAIT=1``; its stdout is discarded.  Nothing is asserted: the figures are the machine's.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: The stage line that ends the loading of the command's modules (:func:`harness.cli.main`).
LOADED = "loading the command's modules done"


def transcript(words: list[str]) -> dict:
    """Run ``python -m gflat WORDS`` and record each stderr line with its time since the start.

    Parameters
    ----------
    words : list of str
        The command-line words after ``gflat``.

    Returns
    -------
    dict
        ``lines`` (list of ``[seconds, text]``), ``first_line_s``, ``modules_loaded_s`` (None when no such
        line), ``wall_s``, ``status``.
    """
    env = dict(os.environ, GFLAT_PROGRESS="plain", GFLAT_NATIVE_WAIT="1")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *filter(None, [env.get("PYTHONPATH")])])
    lines: list[list] = []
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "gflat", *words],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=ROOT,
    )

    def read():
        for line in proc.stderr:
            lines.append([time.perf_counter() - t0, line.rstrip("\n")])

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    status = proc.wait()
    wall = time.perf_counter() - t0
    reader.join()
    loaded = next((s for s, text in lines if LOADED in text), None)
    return {
        "command": ["gflat", *words],
        "lines": lines,
        "first_line_s": lines[0][0] if lines else None,
        "modules_loaded_s": loaded,
        "wall_s": wall,
        "status": status,
    }


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its transcript and figures.

    Parameters
    ----------
    argv : list of str, optional
        This script's words (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 (the child's status is printed, not returned).
    """
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of the transcript")
    ap.add_argument("words", nargs="*", help="the gflat command (after --); default: gflat paper to a temporary folder")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="gflat-bench-progress-") as tmp:
        words = args.words or ["paper", "--out", str(Path(tmp) / "paper")]
        load0 = os.getloadavg()
        res = transcript(words)
        res["load_average_start"], res["load_average_end"] = load0, os.getloadavg()
    if args.json:
        print(json.dumps(res, indent=2))
        return 0
    print(f"$ {' '.join(res['command'])} 2>&1 >/dev/null | ts -s   (seconds since the start)")
    for s, text in res["lines"]:
        print(f"{s:7.2f} {text}")
    first, loaded = res["first_line_s"], res["modules_loaded_s"]
    print()
    print(f"first line after {first:.2f} s" if first is not None else "no line on stderr")
    if loaded is not None and first:
        print(f"the command's modules loaded after {loaded:.2f} s ({loaded / first:.1f} x the first line's time)")
    print(f"whole run {res['wall_s']:.1f} s, exit status {res['status']}, {len(res['lines'])} lines on stderr")
    print(
        "load average (1, 5, 15 min) at start {:.2f} {:.2f} {:.2f}, at end {:.2f} {:.2f} {:.2f}".format(
            *res["load_average_start"], *res["load_average_end"]
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
