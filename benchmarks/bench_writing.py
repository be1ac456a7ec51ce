"""CPU of writing ``gflat paper``'s reports without its flights: the six case folders and the PDF, in rounds.

Runs ``gflat paper`` once in this process (flights included) to get its six case results, then, each round,
writes the six case folders in forked workers as the command does (:class:`harness.parallel.ForkPool`, two
workers by default), then renders the pages and the PDF (:func:`reports.html.render_run`, in this process),
into a fresh folder; prints the CPU of each part (the processes' and their children's, :func:`harness.artefacts.cpu_time`) per round::

    python benchmarks/bench_writing.py [--rounds 3] [--jobs 2] [--json]

Run it with another tree first on ``PYTHONPATH`` to measure that tree's writing (this script only calls
the project's functions).  Nothing is asserted: the figures are the machine's.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    import harness.commands.paper as paper
    import reports.html as html
    from harness.artefacts import cpu_time
    from harness.cli import main as gflat
    from harness.parallel import ForkPool

    tasks = []
    write_task = paper._write_task

    def capture(result, root, sub, plan_sub, csv, progress=None):
        tasks.append((result, sub, plan_sub))
        return write_task(result, root, sub, plan_sub, csv, progress)

    tmp = Path(tempfile.mkdtemp(prefix="bench-writing-"))
    try:
        paper._write_task = capture
        t0 = time.perf_counter()
        with open(tmp / "paper.txt", "w") as sink:
            import contextlib

            with contextlib.redirect_stdout(sink):
                gflat(["-q", "paper", "--out", str(tmp / "run"), "--replace"])
        paper._write_task = write_task
        manifest = json.loads((tmp / "run" / "manifest.json").read_text())
        print(f"gflat paper (flights included): {time.perf_counter() - t0:.1f} s wall, {len(tasks)} case folders")
        rounds = []
        for _ in range(args.rounds):
            root = tmp / "round"
            shutil.rmtree(root, ignore_errors=True)
            root.mkdir()
            c0 = cpu_time()
            with ForkPool(args.jobs) as pool:
                for result, sub, plan_sub in tasks:
                    pool.submit(sub, write_task(result, root, sub, plan_sub, False), what="writing")
                while pool.pending:
                    pool.next_result()
            cases = cpu_time() - c0
            c1 = cpu_time()
            html.render_run(root, manifest=manifest)
            pdf = cpu_time() - c1
            rounds.append({"cases_cpu_s": cases, "pages_and_pdf_cpu_s": pdf, "write_cpu_s": cases + pdf})
            print("  " + ", ".join(f"{k} {v:.2f}" for k, v in rounds[-1].items()))
        if args.json:
            print(json.dumps(rounds))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
