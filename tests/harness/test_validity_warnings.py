"""The validity box of the aerodynamic data said aloud (:class:`gna.limits.ValidityWarnings`): a trim, a plan and a
flight outside it warn once per command and quantity (the aircraft, the quantity, the worst value, its time, the
box); an aircraft file without ``[envelope]`` warns once that its validity is unknown; no verdict changes."""

from __future__ import annotations

import json
import logging
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gna.aircraft import load_aircraft
from gna.limits import SUBSONIC_MACH, ValidityWarnings, limit_violations, validity_limits
from harness.cli import main
from harness.validation import ValidationCase, run_case
from harness.validation.validity import check_result, check_run

AIRCRAFT = Path(__file__).resolve().parents[2] / "gna" / "data" / "aircraft"

#: Level flight of the F-16C at 300 m/s, 100 m up: Mach 0.88, above the subsonic range its file implies.
FAST = """
name = "f16c-fast"
aircraft = "f16c"
time = { t0 = 0.0, t1 = 4.0, step = 1.0 }
generalized = { J = 2 }
[flat_outputs]
x = "300*t"
y = "0"
z = "-100"
zeta = "beta"
zeta_value = "0"
"""


def _warned(err: str) -> list[str]:
    return [line for line in err.splitlines() if "outside the validity box" in line or "validity of its" in line]


def test_trim_at_mach_1_5_warns_once(capsys):
    assert main(["trim", "f16c", "--speed", "500"]) == 0  # converges: the verdict is unchanged
    out = capsys.readouterr()
    (line,) = _warned(out.err)
    assert line.startswith("gflat: WARNING: f16c: Mach 1.47 (trim at 500 m/s, 0 m)")
    assert f"Mach 0 .. {SUBSONIC_MACH:g}" in line and "no [envelope] mach_min, mach_max" in line
    assert "converged" in out.out
    assert main(["trim", "f16c", "--speed", "150"]) == 0  # Mach 0.44: nothing to say
    assert not _warned(capsys.readouterr().err)


def test_an_aircraft_file_without_envelope_warns_that_its_validity_is_unknown(tmp_path, capsys):
    text = (AIRCRAFT / "twin-otter.toml").read_text()
    start = text.index("[envelope]")
    end = text.index("\n[", start + 1)
    path = tmp_path / "no-box.toml"
    path.write_text(text[:start] + text[end + 1 :])
    ac = load_aircraft(path)
    assert not ac.envelope.declared and load_aircraft("twin-otter").envelope.declared
    assert main(["trim", str(path), "--speed", "70"]) == 0
    (line,) = _warned(capsys.readouterr().err)
    assert "its aircraft file has no [envelope] table: the validity of its aerodynamic data is unknown" in line
    assert "alpha -10.0 .. 30.0 deg" in line
    warn = ValidityWarnings()  # once per command, however many checks
    assert len(warn.check_point(ac, V=70, altitude=0, alpha=0.05, beta=0, what="trim")) == 1
    assert warn.check_point(ac, V=70, altitude=0, alpha=0.05, beta=0, what="trim") == []


def test_one_line_per_quantity_with_the_worst_value_its_time_and_the_box(caplog):
    ac = load_aircraft("twin-otter")
    t = np.linspace(0.0, 10.0, 11)
    alpha = np.radians(np.where(t > 4, 14.0 + t, 5.0))  # worst 24 deg at t = 10 s; the box ends at 12 deg
    beta = np.radians(np.where(t == 3, -17.0, 0.0))
    frame = pd.DataFrame({"z": -300.0, "V": 60.0, "alpha": alpha, "beta": beta}, index=pd.Index(t, name="t"))
    warn = ValidityWarnings()
    with caplog.at_level(logging.WARNING, logger="gna.limits"):
        lines = warn.check(ac, frame, "plan of test, j = 1")
        assert warn.check(ac, frame, "inhouse flight of test, open loop") == []  # said once per command
    assert [r.getMessage() for r in caplog.records] == lines == warn.said
    a, b = lines
    assert a.startswith("twin-otter: alpha 24.00 deg at t = 10 s (plan of test, j = 1)")
    assert a.endswith("alpha -5.0 .. 12.0 deg ([envelope] alpha_min, alpha_max)")
    assert b.startswith("twin-otter: beta -17.00 deg at t = 3 s") and "|beta| <= 15.0 deg" in b
    assert [lim.name for lim in validity_limits(ac)] == ["alpha", "beta", "mach"]
    assert "mach" not in {v.name for v in limit_violations(ac, frame.assign(V=400.0))}  # the verdict's limits


@pytest.fixture(scope="module")
def fast_case(tmp_path_factory):
    path = tmp_path_factory.mktemp("validity") / "fast.toml"
    path.write_text(FAST)
    return path, run_case(ValidationCase(str(path), engines=("inhouse", "jsbsim")))


def test_a_plan_outside_the_box_warns_on_the_command_line(fast_case, tmp_path, capsys):
    path, _ = fast_case
    assert main(["plan", str(path), "--out", str(tmp_path / "plan")]) == 0
    (line,) = _warned(capsys.readouterr().err)
    assert re.match(r"gflat: WARNING: f16c: Mach 0\.88\d at t = \S+ s \(plan of f16c-fast, j = 2\)", line), line


def test_a_flight_outside_the_box_warns_once_for_the_case(fast_case):
    _, result = fast_case
    lines = check_result(ValidityWarnings(), result)  # the plan, then each flight: Mach once
    assert len(lines) == 1 and "(plan of f16c-fast, j = 2)" in lines[0]
    (line,) = check_run(ValidityWarnings(), result.plan.aircraft, result.runs["jsbsim"], "jsbsim flight of fast")
    mach = float(re.search(r"Mach (\d\.\d+) at t", line)[1])
    assert math.isclose(mach, 0.88, abs_tol=0.01) and "(jsbsim flight of fast)" in line


def test_compare_json_on_stdout_progress_and_one_warning_on_stderr(fast_case, tmp_path, monkeypatch, capsys):
    path, _ = fast_case
    monkeypatch.setenv("GFLAT_PROGRESS", "plain")
    main(["compare", str(path), "--json", "--out", str(tmp_path / "cmp")])
    out = capsys.readouterr()
    assert json.loads(out.out)["runs"]  # stdout: the one JSON object, no progress line
    stages = [line.split(": ", 1)[1] for line in out.err.splitlines() if line.startswith("[")]
    assert stages[0] == "started" and any(s.startswith("flying f16c-fast (open loop, jsbsim) done in") for s in stages)
    (line,) = _warned(out.err)  # the plan and both flights leave the box: said once
    assert "(plan of f16c-fast, j = 2)" in line
