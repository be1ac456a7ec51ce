"""The gflat command line: trim, aircraft, error messages."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from gna.errors import InputError
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


def test_plan_command_writes_outputs(tmp_path, capsys):
    assert main(["plan", "gtm-aileron-roll", "--J", "2", "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "convergence table" in out and "worst Newton residual" in out and "J=2" in out
    for f in ("plan_series.npz", "convergence.csv", "summary.json", "singularities.parquet"):
        assert (tmp_path / "out" / f).is_file(), f
    assert sorted(p.name for p in (tmp_path / "out").glob("plan-j*")) == [f"plan-j{j}.parquet" for j in range(3)]
    assert not list((tmp_path / "out").glob("*.csv"))[1:]  # convergence.csv only: the rest with --csv


def test_plan_unknown_scenario(capsys):
    assert main(["plan", "barrel-roll"]) == 2
    err = capsys.readouterr().err
    assert "unknown scenario 'barrel-roll'" in err
    assert "gtm-aileron-roll" in err and "car-two-trailers" in err  # every name gflat plan takes


def test_compare_command_prints_tables(tmp_path, capsys):
    scen = tmp_path / "short.toml"
    scen.write_text(
        'name = "short"\naircraft = "a7"\n[time]\nt0 = 0.0\nt1 = 4.0\nstep = 0.5\n'
        '[flat_outputs]\nx = "130*t"\ny = "20*sin(t/3)"\nz = "-1500"\nzeta = "beta"\n'
        'zeta_value = "0"\n[generalized]\nJ = 2\n'
    )
    assert main(["compare", str(scen), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "[first 10 s]" in out and "[whole span]" in out
    engine_part = out.split("[inhouse against the plan")[0]
    assert engine_part.count("overall: PASS") == 2 and "FAIL" not in engine_part
    assert "no tolerances given" in out  # the tables against the plan are informative
    plan_part = out.split("[inhouse against the plan")[1]
    assert "overall: PASS" not in plan_part  # an informative table has no verdict line
    assert (tmp_path / "out" / "states.png").is_file()
    assert (tmp_path / "out" / "report.pdf").read_bytes()[:5] == b"%PDF-"  # as docs/cli.md says
    assert main(["compare", str(scen), "--engines", "inhouse"]) == 2


def test_compare_fails_when_engines_diverge(tmp_path, capsys):
    """A plan that leaves the physical domain open loop: the comparison fails with exit status 1."""
    scen = tmp_path / "fast.toml"
    scen.write_text(
        'name = "fast"\naircraft = "f16c"\n[time]\nt0 = 0.0\nt1 = 10.0\nstep = 0.5\n'
        '[flat_outputs]\nx = "150*t"\ny = "400*sin(t)"\nz = "-3000 + 300*sin(2*t)"\nzeta = "beta"\n'
        'zeta_value = "0"\n'
    )
    rc = main(["compare", str(scen), "--out", str(tmp_path / "out")])
    out = capsys.readouterr()
    assert rc in (1, 2), out.out[-2000:]
    assert "FAIL" in out.out or "not feasible" in out.err


def test_position_error_of_a_run_that_ended_early_is_not_nan():
    from harness.commands.compare import error_text

    assert error_text(1.5e-3, 10.0) == "1.500e-03 m"
    assert error_text(float("nan"), 3.25) == "n/a (run ended at t = 3.25 s)"


@pytest.mark.parametrize(
    "command",
    [
        ["compare", "gtm-aileron-roll"],
        ["paper"],
        ["plan", "gtm-aileron-roll"],
        ["export-jsbsim", "f16c"],
        ["export-jsbsim-script", "gtm-aileron-roll"],
        ["fit", "regenerate"],
    ],
)
def test_an_empty_out_is_refused(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([*command, "--out", ""])
    assert exc.value.code == 2 and "--out: an empty path" in capsys.readouterr().err


def test_a_repeated_window_name_is_refused(tmp_path, capsys):
    assert (
        main(["compare", "gtm-aileron-roll", "--window", "a=1", "--window", "a=2", "--out", str(tmp_path / "o")]) == 2
    )
    assert "--window: each name once, 'a' given 2 times" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
    from harness.validation import ValidationCase

    with pytest.raises(InputError, match="windows: each name once, 'a' repeated"):
        ValidationCase("x", windows=[("a", 1.0), ("a", 2.0)])


def test_an_input_error_after_the_checks_leaves_no_output_folder(tmp_path, capsys):
    scen = tmp_path / "high.toml"
    scen.write_text(
        'name = "high"\naircraft = "a7"\n[time]\nt0 = 0.0\nt1 = 4.0\nstep = 0.5\n'
        '[flat_outputs]\nx = "130*t"\ny = "0"\nz = "-1e6"\nzeta = "beta"\nzeta_value = "0"\n'
    )
    assert main(["plan", str(scen), "--out", str(tmp_path / "D")]) == 2
    assert "outside the ISA model" in capsys.readouterr().err
    assert not (tmp_path / "D").exists()


def test_a_bad_series_backend_is_one_line_not_a_traceback():
    """GFLAT_SERIES_BACKEND is read when the planners are imported: still one line and exit 2."""
    import os
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-m", "harness.cli", "plan", "gtm-aileron-roll"],
        capture_output=True,
        text=True,
        env={**os.environ, "GFLAT_SERIES_BACKEND": "bogus"},
    )
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        "gflat: error: environment variable GFLAT_SERIES_BACKEND='bogus': the series backend must be one of "
        "numpy, compiled, native"
    ]


def test_trim_that_does_not_converge_is_a_negative_verdict(capsys):
    """Newton ran (60 iterations) without finding a steady flight: exit 1 with the cause, not a usage error."""
    assert main(["trim", "f16c", "--speed", "10", "--altitude", "1000"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no steady flight found" in err[0] and "did not converge" in err[0]
    assert main(["trim", "f16c", "--speed", "10", "--altitude", "1000", "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    assert d["converged"] is False and "did not converge" in d["message"]


def test_dt_out_not_dividing_the_span_names_no_python_argument(tmp_path, capsys):
    assert main(["compare", "gtm-aileron-roll", "--J", "0", "--dt-out", "3", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "dt_out = 3 s does not divide the span" in err and "choose a divisor of 8 s" in err
    assert "t_eval" not in err


def test_fit_writes_its_file_atomically_and_refuses_a_folder(tmp_path, capsys):
    assert main(["fit", "gtm", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "a folder; give the aircraft file's name" in err
    assert main(["fit", "gtm", "--out", str(tmp_path / "gtm-fit.toml"), "--no-trim-check"]) == 0
    assert (tmp_path / "gtm-fit.toml").read_text().startswith("#") and [p.name for p in tmp_path.iterdir()] == [
        "gtm-fit.toml"
    ]  # no temporary file left


# --- the lazy command line: a command's modules load only when it runs ---------------------------


def test_the_static_command_table_is_what_the_command_modules_register():
    """``gflat --help`` lists COMMANDS without loading a module: the same text as with every module loaded."""
    import argparse
    import importlib

    from harness.cli import COMMANDS, build_parser

    assert build_parser([]).format_help() == build_parser().format_help()
    for name, (module, _) in COMMANDS.items():
        sub = argparse.ArgumentParser().add_subparsers()
        importlib.import_module(module).register(sub)
        assert list(sub.choices) == [name], module


def _loaded_after(code: str) -> list[str]:
    """Our modules and numpy loaded by a fresh interpreter after running ``code`` (SystemExit caught)."""
    probe = (
        "import sys\ntry:\n" + "".join(f"    {line}\n" for line in code.splitlines()) + "except SystemExit:\n    pass\n"
        "print('\\nloaded:', *sorted(m for m in sys.modules if m.split('.')[0] in "
        "('numpy', 'gna', 'planners', 'harness', 'reports', 'gflat')))"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    last = out.stdout.splitlines()[-1].split()
    assert last[0] == "loaded:", out.stdout
    return last[1:]


@pytest.mark.parametrize("words", [["--version"], ["--help"], [], ["no-such-command"], ["-v", "-q", "--help"]])
def test_version_and_help_load_no_command_and_no_numpy(words):
    loaded = _loaded_after(f"from harness.cli import main\nmain({words!r})")
    assert "numpy" not in loaded
    assert not [m for m in loaded if m.startswith(("harness.commands.", "planners", "reports"))], loaded


def test_a_command_loads_its_own_module_only():
    loaded = _loaded_after("from harness.cli import main\nmain(['-q', 'trim', '--help'])")
    commands = [m for m in loaded if m.startswith("harness.commands.") and not m.startswith("harness.commands._")]
    assert commands == ["harness.commands.trim"]
    loaded = _loaded_after("from harness.cli import main\nmain(['aircraft', 'f16c', '--json'])")
    own = [m for m in loaded if m.startswith("harness.commands.") and not m.startswith("harness.commands._")]
    assert own == ["harness.commands.aircraft"]


@pytest.mark.parametrize(
    "words, command",
    [(["trim", "x"], "trim"), (["-v", "-q", "plan", "-v"], "plan"), (["--", "fit"], "fit"), (["-v"], None), ([], None)],
)
def test_command_word(words, command):
    from harness.cli import command_word

    assert command_word(words) == command


def test_python_m_gflat_is_the_command_line():
    r = subprocess.run([sys.executable, "-m", "gflat", "--version"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.startswith("gflat ")
    r = subprocess.run(
        [sys.executable, "-m", "gflat", "trim", "concorde", "--speed", "100"], capture_output=True, text=True
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "unknown aircraft 'concorde'" in r.stderr
