"""``gflat fit`` from the command line: a fit written to a file, and one-line errors."""

from __future__ import annotations

import tomllib
from importlib import resources

from gna.aircraft import load_aircraft
from harness.cli import main

CSV = str(resources.files("gna") / "data" / "sources" / "twin_otter" / "aircraft_dat_clean.csv")


def test_fit_linear_model_to_file(tmp_path, capsys):
    out = tmp_path / "to.toml"
    rc = main(
        [
            "fit",
            "linear",
            CSV,
            "--speed",
            "72",
            "--engines",
            "2",
            "--engine-offset",
            "2.8",
            "--samples",
            "300",
            "--test",
            "100",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "held-out statistics" in text and "level trim" in text
    a = load_aircraft(str(out))
    assert a.propulsion.count == 2 and abs(a.propulsion.y_p - 2.8) < 1e-12
    doc = tomllib.loads(out.read_text())
    assert doc["fit"]["design"]["blocks"]["box"]["n_fit"] == 300
    assert doc["provenance"]["regenerate"].startswith("gflat fit linear")
    assert abs(doc["fit"]["trim"]["difference"]["alpha_deg"]) < 0.01


def test_errors_are_one_line(tmp_path, capsys):
    assert main(["fit", "jsbsim", "NoSuchPlane", "--mach", "0.5", "--altitude", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("gflat fit: error: unknown JSBSim aircraft 'NoSuchPlane'") and "\n" not in err
    assert main(["fit", "gtm", "--alpha", "-10", "10", "--out", str(tmp_path / "g.toml")]) == 2
    assert "alpha = -10 deg" in capsys.readouterr().err
    assert main(["fit", "gtm", "--samples", "5", "--out", str(tmp_path / "g.toml")]) == 2
    assert "5 samples for 10 terms" in capsys.readouterr().err


def test_regenerate_check_passes(capsys):
    assert main(["fit", "regenerate", "--check", "gtm"]) == 0
    assert "gtm: current" in capsys.readouterr().out
