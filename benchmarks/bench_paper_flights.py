"""CPU of each flight of ``gflat paper``'s six cases, flown in this process (no assertions).

Plans the paper's three scenarios, sets their open- and closed-loop cases up as the command does
(:func:`harness.validation.flights.case_flights`) and flies every flight ``--repeats`` times, interleaved;
prints the minimum and median CPU time of each and the sum of the medians.  Run it with two trees in turn to
compare them (each on ``PYTHONPATH``)::

    PYTHONPATH=TREE python benchmarks/bench_paper_flights.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import time

from harness.commands.paper import PAPER_SCENARIOS, paper_cases
from harness.validation import plan_case
from harness.validation.flights import case_flights


def main() -> None:
    """Fly the flights and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    flights = {}
    for loop in ("open", "closed"):
        for case in paper_cases(loop=loop):
            planned = plan_case(case)
            cf = case_flights(case, plan=planned.plan, scenario=planned.scenario)
            for name, fly in cf.flights.items():
                flights[(case.scenario, loop, name)] = fly
    cpu = {key: [] for key in flights}
    for _ in range(args.repeats):
        for key, fly in flights.items():
            c0 = time.process_time()
            fly()
            cpu[key].append(time.process_time() - c0)
    print(f"CPU per flight [s], {args.repeats} repeats, min and median")
    order = sorted(flights, key=lambda k: (PAPER_SCENARIOS.index(k[0]), k[1] != "open", k[2]))
    for key in order:
        print(f"  {min(cpu[key]):7.3f} {statistics.median(cpu[key]):7.3f}  {key[0]}, {key[1]} loop, {key[2]}")
    print(f"  sum of the medians {sum(statistics.median(v) for v in cpu.values()):.3f} s")


if __name__ == "__main__":
    main()
