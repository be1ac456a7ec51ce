"""A small real run, made once per session: the GTM aileron roll (8 s) flown open and closed loop on the
in-house model and JSBSim, its case folders written as ``gflat paper`` writes them, and the reports rendered."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import pytest

from harness.artefacts import write_manifest, write_plan_iterates
from harness.commands.plan import write_plan
from harness.outdir import OutputDir
from harness.validation import ValidationCase, plan_case, run_case
from reports.case_files import write_case
from reports.html import render_run

#: Folder of each loop's case under a scenario's folder (the layout of ``gflat paper --out DIR``).
CASE_FOLDERS = {"open": "open", "closed": "closed"}

SCENARIO = "gtm-aileron-roll"

#: Render date of the fixture's reports (the date is the only part allowed to change between renders).
DATE = "2000-01-01T00:00:00+00:00"


@dataclass
class Run:
    root: Path
    results: dict            # loop -> CaseResult
    scenario: object
    render_s: float          # wall time of render_run (HTML, single file and PDF)
    written: dict


@pytest.fixture(scope="session")
def report_run(tmp_path_factory) -> Run:
    root = tmp_path_factory.mktemp("run")
    out = OutputDir(root)
    case = ValidationCase(SCENARIO, engines=("inhouse", "jsbsim"))
    planned = plan_case(case)
    name = planned.scenario.name
    write_plan(planned.scenario, planned.plan, planned.planning_time_s, out.sub(name, "plan"))
    results = {}
    for loop, folder in CASE_FOLDERS.items():       # as gflat paper writes them
        r = run_case(replace(case, loop=loop), plan=planned.plan, scenario=planned.scenario)
        write_case(r, out.sub(name, folder), plan=False, manifest=False)
        results[loop] = r
    write_plan_iterates(out.sub(name, "plan"), planned.plan, results["open"].runs["inhouse"].df.index)
    write_manifest(out, list(results.values()))
    out.finish()
    t0 = time.perf_counter()
    written = render_run(root, self_contained=True, pdf=True, date=DATE)
    return Run(root=root, results=results, scenario=planned.scenario, render_s=time.perf_counter() - t0,
               written=written)
