"""The report model: saved per case as strict JSON, built from the result objects alone."""

from __future__ import annotations

import json
import math
import re

import pytest

from reports.html import fmt
from reports.model import REPORT_JSON, case_model, json_safe, load_case_models

from .conftest import CASE_FOLDERS, SCENARIO


def _strict(text):
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def test_every_case_folder_holds_its_model_as_strict_json(report_run):
    cases = load_case_models(report_run.root)
    assert [m["loop"] for _, m in cases] == ["open", "closed"]
    for loop, folder in CASE_FOLDERS.items():
        path = report_run.root / SCENARIO / folder / REPORT_JSON
        model = _strict(path.read_text(encoding="utf-8"))
        result = report_run.results[loop]
        assert model["loop"] == loop and model["passed"] == result.verdict()["pass"]
        assert model["scenario"]["name"] == SCENARIO and model["scenario"]["aircraft"]["id"] == "gtm"
        assert "zeta_value" in model["scenario"]["flat_outputs"] and "[flat_outputs]" in model["scenario"]["toml"]
        assert model["plan"]["J"] == result.plan.J and model["plan"]["feasible"]
        conv = model["plan"]["convergence"]
        assert conv["columns"][:2] == ["t", "variable"] and len(conv["columns"]) == 2 + result.plan.J + 1
        assert model["plan"]["singularity"]["condition"] == "stalling_cond"
        # the aircraft's surface limits, drawn on the controls figure (GTM ailerons +-20 deg)
        assert model["limits"]["dl"] == pytest.approx([-math.radians(20), math.radians(20)])
        assert {t["window"] for t in model["tables"]["engines"]} == {"first 10 s", "whole span"}
        assert [t["engine"] for t in model["tables"]["plan"]] == ["inhouse", "jsbsim"]
        files = [f["file"] for f in model["figures"]]
        for f in files:
            assert (path.parent / f).stat().st_size > 0
        assert {"states.png", "controls.png", "differences.png", "singularity.png"} <= set(files)
        for f in model["figures"]:  # every axis of every figure labelled with its unit (PNG metadata)
            assert f["axes"] and all(re.fullmatch(r".+ \[[^\]]+\]", a) for a in f["axes"]), f
        axes = {a for f in model["figures"] for a in f["axes"]}
        assert {"h = -z [m]", "x (north) [m]", "y (east) [m]", "alpha [deg]", "p [deg/s]", "dl [deg]"} <= axes
        assert ("tracking.png" in files) == (loop == "closed")
        assert (model["closed_loop"] is not None) == (loop == "closed")
        assert model["provenance"]["jsbsim"]
        # undefined numbers are null, as in summary.json and --json (never the string "nan")
        text = path.read_text(encoding="utf-8")
        assert '"nan"' not in text and '"inf"' not in text and '"-inf"' not in text
        deltas = [row[t["columns"].index("delta_pct")] for t in model["tables"]["engines"] for row in t["rows"]]
        assert None in deltas and all(d is None or math.isfinite(d) for d in deltas)
        assert all(
            d is None
            for d in model["verdict"]["differences"]["jsbsim"]["delta_pct"].values()
            if not isinstance(d, float)
        )
        assert "whole span" in model["verdict"]["delta_pct_definition"]


def test_the_model_is_a_function_of_the_result(report_run):
    result = report_run.results["open"]
    saved = json.loads((report_run.root / SCENARIO / CASE_FOLDERS["open"] / REPORT_JSON).read_text())
    again = case_model(result, saved["figures"], scenario=report_run.scenario)
    assert again == saved


def test_json_safe_and_cell_format():
    import numpy as np

    assert json_safe({"a": (np.float64(1.5), float("nan"), np.int64(3), np.bool_(True), -math.inf)}) == {
        "a": [1.5, None, 3, True, None]
    }  # null, as in summary.json and --json
    assert [fmt(None), fmt(True), fmt(False), fmt(3), fmt(0.25), fmt(1.2344e-7), fmt("nan"), fmt(-1.9, ".8g")] == [
        "-",
        "on",
        "off",
        "3",
        "0.25",
        "1.234e-07",
        "nan",
        "-1.9",
    ]
