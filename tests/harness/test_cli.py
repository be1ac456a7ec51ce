"""The gflat command line: trim, aircraft, error messages."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from harness.cli import main


def test_trim_json_issue_condition(capsys):
    assert main(["trim", "f16c", "--speed", "152.4", "--altitude", "3048", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["converged"] and d["values"]["alpha"]["unit"] == "rad" and d["values"]["F"]["unit"] == "N"
    assert d["max_residual"] <= 1e-9
    assert all(abs(v) <= 1e-9 for v in d["residuals"].values())
    assert len(d["residuals"]) == 9


def test_trim_text(capsys):
    assert main(["trim", "a7", "--speed", "120", "--altitude", "1000", "--turn-rate", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "converged" in out and "deg" in out and "max |residual|" in out


def test_unknown_aircraft_is_one_line(capsys):
    assert main(["trim", "concorde", "--speed", "100"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown aircraft 'concorde'" in err and "f16c" in err


@pytest.mark.parametrize("value", ["-3", "0", "nan", "abc"])
def test_bad_speed_refused(value, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["trim", "f16c", "--speed", value])
    assert exc.value.code == 2
    assert "--speed" in capsys.readouterr().err


def test_aircraft_lists_with_provenance(capsys):
    assert main(["aircraft"]) == 0
    out = capsys.readouterr().out
    assert "f16c" in out and "a7" in out and "source:" in out
    assert main(["aircraft", "f16c", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["aero"]["terms"] == 45 and d["provenance"]["date"]


def test_console_script_installed():
    r = subprocess.run([sys.executable, "-m", "harness.cli", "aircraft"], capture_output=True, text=True)
    assert r.returncode == 0 and "f16c" in r.stdout
