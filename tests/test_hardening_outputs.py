"""Hardening, fourth round: what a command writes, and how it says no.

Test names carry the kind they cover: ``test_o1_*`` one output file (``gflat fit --out FILE``), written whole and
refused when it exists unless ``--replace``, through the one ``--out`` helper every command uses; ``test_o2_*``
a campaign folder never adopted when it holds anything else; ``test_o3_*`` step and size flags bounded by the
scenario's span and a sane maximum; ``test_o5_*`` ``gflat report``'s messages naming the real cause;
``test_o6_*`` option errors in one line.  SIGTERM (kind 4) is tested with a real subprocess in
``tests/harness/test_rundir.py``.
"""

from __future__ import annotations

import ast
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from gna.errors import InputError
from harness.cli import main
from harness.rundir import MANIFEST, OutputFile, RunDir

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "planners" / "scenarios" / "gtm-aileron-roll.toml"
COMMANDS = ROOT / "harness" / "commands"


def _one_line_exit_2(argv, capsys) -> str:
    """The one line a refused command line prints (exit status 2, from argparse or from the command)."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # an option error
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err.strip()


def _tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def no_fit(monkeypatch):
    """Reading a source or fitting fails the test: the output is checked first."""
    import gna.fit.pipeline
    import gna.fit.sources.gtm

    def fail(*args, **kwargs):
        pytest.fail("the source was read before --out was checked")

    monkeypatch.setattr(gna.fit.sources.gtm, "GTMSource", fail)
    monkeypatch.setattr(gna.fit.pipeline, "fit_source", fail)


# ---------------------------------------------------------------------------------------------------
# Kind 1: one output file, and one --out helper
# ---------------------------------------------------------------------------------------------------

FIT = ["fit", "gtm", "--samples", "200", "--test", "50", "--no-trim-check"]


def test_o1_fit_refuses_an_existing_out_file_and_replaces_it_only_when_asked(tmp_path, capsys):
    out = tmp_path / "mine.toml"
    out.write_text("the user's file\n")
    os.chmod(out, 0o600)
    err = _one_line_exit_2([*FIT, "--out", out], capsys)
    assert err == (
        f"gflat fit: error: output file {out} exists: give --replace to replace it once the new one is written, "
        f"or another --out"
    )
    assert out.read_text() == "the user's file\n"
    assert main([*FIT, "--out", str(out), "--replace"]) == 0
    assert out.read_text().startswith("#") and "[aero]" in out.read_text()
    assert stat.S_IMODE(out.stat().st_mode) == 0o600  # a file replaced keeps its permissions
    assert sorted(os.listdir(tmp_path)) == ["mine.toml"]  # no temporary file beside it


def test_o1_the_default_file_is_not_overwritten_either(tmp_path, monkeypatch, no_fit, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "gtm-fit.toml").write_text("mine")
    err = _one_line_exit_2(["fit", "gtm"], capsys)
    assert "output file gtm-fit.toml exists: give --replace" in err
    assert (tmp_path / "gtm-fit.toml").read_text() == "mine"


def test_o1_a_symbolic_link_is_refused_even_with_replace(tmp_path, no_fit, capsys):
    target = tmp_path / "target.toml"
    target.write_text("kept")
    (tmp_path / "link.toml").symlink_to(target)
    for extra in ([], ["--replace"]):
        err = _one_line_exit_2(["fit", "gtm", "--out", tmp_path / "link.toml", *extra], capsys)
        assert err.endswith(
            f"output file {tmp_path / 'link.toml'} is a symbolic link: give the file itself, or another --out"
        )
    assert target.read_text() == "kept" and (tmp_path / "link.toml").is_symlink()


def test_o1_a_file_written_meanwhile_is_not_overwritten(tmp_path):
    out = OutputFile(tmp_path / "a.toml")  # checked: no file yet
    (tmp_path / "a.toml").write_text("another process's")
    with pytest.raises(InputError, match="written by another process meanwhile: this file is discarded"):
        out.write("mine")
    assert (tmp_path / "a.toml").read_text() == "another process's"
    assert sorted(os.listdir(tmp_path)) == ["a.toml"]


def test_o1_an_interrupted_write_leaves_the_old_file_and_no_temporary_one(tmp_path, monkeypatch):
    (tmp_path / "a.toml").write_text("old")
    out = OutputFile(tmp_path / "a.toml", replace=True)

    def interrupted(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        out.write("new")
    assert (tmp_path / "a.toml").read_text() == "old" and sorted(os.listdir(tmp_path)) == ["a.toml"]


def test_o1_an_abandoned_temporary_file_is_removed_by_the_next_write(tmp_path):
    stale = tmp_path / ".a.toml.gflat-0123456789ab.tmp"  # a write killed outright (SIGKILL)
    stale.write_text("half")
    other = tmp_path / ".b.toml.gflat-0123456789ab.tmp"  # another file's
    other.write_text("x")
    OutputFile(tmp_path / "a.toml").write("whole")
    assert sorted(os.listdir(tmp_path)) == [".b.toml.gflat-0123456789ab.tmp", "a.toml"]


WRITERS = {
    "plan": ["plan", SCENARIO],
    "compare": ["compare", SCENARIO],
    "paper": ["paper"],
    "export-jsbsim": ["export-jsbsim", "f16c"],
    "export-jsbsim-script": ["export-jsbsim-script", SCENARIO],
    "fit regenerate": ["fit", "regenerate", "gtm"],
}


@pytest.mark.parametrize("command", WRITERS)
def test_o1_every_command_refuses_an_existing_out_folder_the_same_way(command, tmp_path, capsys):
    out = tmp_path / "D"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    err = _one_line_exit_2([*WRITERS[command], "--out", out], capsys)
    assert err.endswith(
        f"error: output folder {out} exists: give --replace to replace it once the new run is complete, or another "
        f"--out"
    )
    err = _one_line_exit_2([*WRITERS[command], "--out", out, "--replace"], capsys)  # not a run: never replaced
    assert f"{out} is not the folder of a gflat run (no manifest.json in {out})" in err
    assert _tree(out) == {"notes.txt": b"mine"} and sorted(os.listdir(tmp_path)) == ["D"]


def test_o1_one_helper_declares_and_opens_every_out():
    # The --out of every command comes from harness/commands/_output.py (add_out, run_dir, output_file); no
    # command module declares --out or opens a RunDir itself, but report (a run's own folder) and campaign (its
    # report folder, and a campaign folder, which is no run).
    own = {"_output.py", "report.py", "campaign.py"}
    for path in sorted(COMMANDS.glob("*.py")):
        if path.name in own:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                name = getattr(node.func, "id", getattr(node.func, "attr", None))
                assert name not in ("RunDir", "OutputFile", "write_file") or path.name == "export_jsbsim.py", (
                    f"{path.name}:{node.lineno} calls {name}"
                )
                if name == "add_argument" and node.args and isinstance(node.args[0], ast.Constant):
                    assert node.args[0].value not in ("--out", "--replace"), f"{path.name}:{node.lineno}"


def test_o1_fit_regenerate_into_a_folder_is_a_run(tmp_path, monkeypatch):
    import gna.fit.regenerate

    def quick(out_dir=None, ids=None, check=False, today=None, committed_dir=None, write=None):
        write(Path(out_dir) / "gtm.toml", "x = 1\n")
        return {"gtm": []}

    monkeypatch.setattr(gna.fit.regenerate, "regenerate", quick)
    assert main(["fit", "regenerate", "gtm", "--out", str(tmp_path / "R")]) == 0
    files = sorted(os.listdir(tmp_path / "R"))
    assert files == ["gtm.toml", MANIFEST] and sorted(os.listdir(tmp_path)) == ["R"]


# ---------------------------------------------------------------------------------------------------
# Kind 2: a campaign folder is never adopted
# ---------------------------------------------------------------------------------------------------


def test_o2_a_non_empty_folder_that_is_no_campaign_folder_is_refused(tmp_path, capsys):
    folder = tmp_path / "mine"
    folder.mkdir()
    for name in ("a.txt", "b.txt", "c.txt", "d.txt"):
        (folder / name).write_text(name)
    (folder / "sub").mkdir()
    before = _tree(folder)
    err = _one_line_exit_2(["campaign", "run", "paper-dispersions", "--out", folder, "--samples", "1"], capsys)
    assert err.endswith(
        f"campaign folder {folder} is not a campaign folder (no campaign.sqlite) and is not empty: it holds a.txt, "
        f"b.txt, c.txt and 2 more; give a new or empty folder as --out"
    )
    assert _tree(folder) == before and sorted(os.listdir(folder)) == ["a.txt", "b.txt", "c.txt", "d.txt", "sub"]


@pytest.mark.parametrize("where", ["/", "package"])
def test_o2_the_root_and_the_package_folder_are_refused(where, capsys):
    folder = Path("/") if where == "/" else ROOT / "harness"
    err = _one_line_exit_2(["campaign", "run", "paper-dispersions", "--out", folder, "--samples", "1"], capsys)
    assert f"campaign folder {folder} is not a campaign folder (no campaign.sqlite) and is not empty" in err
    assert not (folder / "campaign.sqlite").exists()


def test_o2_an_empty_folder_or_a_campaign_folder_is_taken(tmp_path):
    from harness.campaign.runner import _campaign_folder

    (tmp_path / "empty").mkdir()
    assert _campaign_folder(tmp_path / "empty") == tmp_path / "empty"
    (tmp_path / "camp").mkdir()
    (tmp_path / "camp" / "campaign.sqlite").write_bytes(b"")
    (tmp_path / "camp" / "cases").mkdir()
    assert _campaign_folder(tmp_path / "camp") == tmp_path / "camp"  # resumed (the store checks the campaign)


# ---------------------------------------------------------------------------------------------------
# Kind 3: step and size flags bounded
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "flags, words",
    [
        (["--jsbsim-dt", "1e9"], "--jsbsim-dt 1e+09 s is above its bound 0.02 s"),
        (["--jsbsim-dt", "0.03"], "--jsbsim-dt 0.03 s is above its bound 0.02 s"),
        (["--dt-out", "1e9"], "--dt-out 1e+09 s is above its bound 8 s (gtm-aileron-roll's span)"),
        (["--dt-out", "9"], "--dt-out 9 s is above its bound 8 s (gtm-aileron-roll's span)"),
    ],
)
def test_o3_step_and_output_interval_are_bounded_before_any_work(flags, words, tmp_path, capsys):
    err = _one_line_exit_2(["compare", SCENARIO, *flags, "--out", tmp_path / "o"], capsys)
    assert err.endswith(
        f"error: compare: {words}"
        if "(" in words
        else f"{words} (gflat's largest JSBSim step: the GTM diverges at 0.05 s)"
    )
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("flags", [["--jsbsim-dt", "0.021"], ["--dt-out", "61"]])
def test_o3_paper_bounds_them_the_same_way(flags, tmp_path, capsys):
    err = _one_line_exit_2(["paper", *flags, "--out", tmp_path / "o"], capsys)
    assert f"error: paper: {flags[0]} {flags[1]} s is above its bound" in err
    assert not (tmp_path / "o").exists()


def test_o3_a_scenario_files_step_is_named_by_its_key(tmp_path, capsys):
    path = tmp_path / "roll.toml"
    path.write_text(SCENARIO.read_text() + "\n[compare]\njsbsim_dt = 1.0\n")
    err = _one_line_exit_2(["compare", path, "--out", tmp_path / "o"], capsys)
    assert f"compare: {path} [compare] jsbsim_dt 1 s is above its bound 0.02 s" in err


def test_o3_the_jsbsim_engine_refuses_a_step_beyond_the_bound():
    from harness.engines.jsbsim.engine import JSBSimEngine
    from harness.engines.jsbsim.run import MAX_JSBSIM_DT

    JSBSimEngine(dt=MAX_JSBSIM_DT)
    with pytest.raises(InputError, match=r"JSBSim step dt = 0\.5 s is above the bound 0\.02 s"):
        JSBSimEngine(dt=0.5)


@pytest.mark.parametrize("value", ["1e300", "3601", "inf", "0", "-1"])
def test_o3_the_dask_timeout_is_bounded(value, tmp_path, capsys):
    err = _one_line_exit_2(
        [
            "campaign",
            "run",
            "paper-dispersions",
            "--out",
            tmp_path / "c",
            "--dask",
            "tcp://127.0.0.1:9",
            "--dask-timeout",
            value,
        ],
        capsys,
    )
    assert "argument --dask-timeout" in err
    assert not (tmp_path / "c").exists()


def test_o3_an_output_interval_longer_than_the_span_says_so():
    from gna.trajectory import output_grid

    with pytest.raises(InputError, match=r"dt_out = 100 s is longer than the span \[0, 8\] s, its bound"):
        output_grid(0.0, 8.0, 100.0)


# ---------------------------------------------------------------------------------------------------
# Kind 5: gflat report names the real cause
# ---------------------------------------------------------------------------------------------------


@pytest.fixture
def plan_run(tmp_path) -> Path:
    """A gflat run folder whose manifest each test breaks its own way (a plan run's manifest, quickly written)."""
    with RunDir(tmp_path / "run", command="compare") as out:
        out.write_text("case", "summary.json", text="{}")
        out.commit()
    return tmp_path / "run"


@pytest.mark.parametrize(
    "text, cause",
    [
        ("{not json", "manifest.json is not valid JSON (Expecting property name enclosed in double quotes: line 1"),
        ("[1, 2]", "manifest.json is a JSON list, not an object"),
        ('"x"', "manifest.json is a JSON string, not an object"),
        ('{"tool": "other", "files": []}', "manifest.json names tool 'other', not 'gflat'"),
        ('{"tool": "gflat", "files": {"a": 1}}', "manifest.json: 'files' is a JSON object, not a list"),
        ('{"tool": "gflat", "files": [{"path": "a", "bytes": "1", "sha256": "0"}]}', "lacks a string path, an integer"),
    ],
)
def test_o5_a_broken_manifest_is_named_with_what_is_wrong(plan_run, text, cause, capsys):
    (plan_run / MANIFEST).write_text(text)
    before = _tree(plan_run)
    for where in (plan_run, plan_run / "case"):  # the run, or a folder inside it
        err = _one_line_exit_2(["report", where, "--no-pdf"], capsys)
        assert f"{plan_run / MANIFEST}"[: -len(MANIFEST)] in err and cause in err, err
        assert "no manifest.json" not in err and "--out" not in err
    assert _tree(plan_run) == before


def test_o5_a_manifest_that_is_no_file_is_named_so(plan_run, capsys):
    (plan_run / MANIFEST).unlink()
    (plan_run / MANIFEST).mkdir()
    err = _one_line_exit_2(["report", plan_run], capsys)
    assert f"{plan_run / MANIFEST} is not a regular file" in err
    (plan_run / MANIFEST).rmdir()
    (plan_run / MANIFEST).write_bytes(b"\xff\xfe{}")
    err = _one_line_exit_2(["report", plan_run], capsys)
    assert f"{plan_run / MANIFEST} is not UTF-8 text (byte 0)" in err


def test_o5_a_run_without_a_report_and_a_missing_folder_are_named_so(tmp_path, capsys):
    with RunDir(tmp_path / "P", command="plan") as out:
        out.write_text("summary.json", text="{}")
        out.commit()
    err = _one_line_exit_2(["report", tmp_path / "P"], capsys)
    assert err.endswith(
        f"{tmp_path / 'P'} is the folder of a gflat plan run, which holds no report: gflat report renders the runs "
        f"of gflat paper and gflat compare"
    )
    err = _one_line_exit_2(["report", tmp_path / "nothing"], capsys)
    assert err.endswith(f"{tmp_path / 'nothing'} does not exist: give the folder of a gflat paper or gflat compare run")
    err = _one_line_exit_2(["report", tmp_path / "P" / "summary.json"], capsys)
    assert "summary.json is a file, not a folder" in err


def test_o5_a_foreign_file_in_a_run_names_no_out_option(plan_run, capsys):
    (plan_run / "mine.txt").write_text("x")
    err = _one_line_exit_2(["report", plan_run, "--no-pdf"], capsys)
    assert "holds mine.txt, which is not a file of its gflat run" in err
    assert err.endswith("move that file away") and "--out" not in err


# ---------------------------------------------------------------------------------------------------
# Kind 6: option errors in one line
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, prog, words",
    [
        (["plan"], "gflat plan", "the following arguments are required: scenario"),
        (["plan", "x", "--bogus"], "gflat plan", "unrecognized arguments: --bogus"),
        (["compare", "x", "--loop", "sideways"], "gflat compare", "argument --loop: invalid choice: 'sideways'"),
        (["campaign", "run"], "gflat campaign run", "required: NAME_OR_FILE, --out"),
        (["campaign", "run", "x", "--out", "d", "--bogus"], "gflat campaign run", "unrecognized arguments: --bogus"),
        (["campaign"], "gflat campaign", "required: ACTION"),
        (["nosuch"], "gflat", "argument COMMAND: invalid choice: 'nosuch'"),
        ([], "gflat", "required: COMMAND"),
        (["trim", "f16c", "--speed", "x"], "gflat trim", "argument --speed: not a number: 'x'"),
        (["fit", "gtm", "--samples", "10000000"], "gflat fit gtm", "argument --samples: 10000000 is above the bound"),
    ],
)
def test_o6_an_option_error_is_one_line_naming_the_command(argv, prog, words, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "usage:" not in err
    assert err.startswith(f"{prog}: error: ") and words in err and err.endswith(f" (see {prog} --help)\n"), err


def test_o6_help_is_unchanged():
    proc = subprocess.run(
        [sys.executable, "-m", "gflat", "plan", "--help"],
        capture_output=True,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        check=False,
    )
    assert proc.returncode == 0 and proc.stdout.startswith("usage: gflat plan [-h]") and "--replace" in proc.stdout
    assert proc.stdout.count("\n") > 10 and proc.stderr == ""


# ---------------------------------------------------------------------------------------------------
# Found by the attack on this round's work
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, words",
    [
        (["fit", "gtm", "--out", "-"], "argument --out: '-': gflat writes the file to a path, not to the standard"),
        (["plan", "x", "--out", "-"], "argument --out: '-': gflat writes a run to a folder, not to the standard"),
        (["fit", "gtm", "--out", "new-folder/"], "argument --out: 'new-folder/' ends with a '/', a folder's name"),
        (["fit", "gtm", "--beta", "1e300"], "argument --beta: 1e+300 is above the bound of 90"),
        (["fit", "gtm", "--alpha", "-1e300", "1e300"], "argument --alpha: -1e+300 is outside its bounds -90 .. 90"),
        (["fit", "gtm", "--dl", "-100", "5"], "argument --dl: -100 is outside its bounds -90 .. 90"),
        (["fit", "gtm", "--phat", "2"], "argument --phat: 2 is above the bound of 1"),
        (["fit", "gtm", "--dm-band", "-5"], "argument --dm-band: -5 is outside its bounds 0 .. 180"),
    ],
)
def test_a_out_names_and_design_flags_are_checked_at_parse_time(argv, words, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert words in _one_line_exit_2(argv, capsys)
    assert os.listdir(tmp_path) == []  # "-" and "new-folder" not written as files


def test_a_out_file_expands_the_home_folder(tmp_path, monkeypatch):
    from harness.commands._output import out_file, out_path

    monkeypatch.setenv("HOME", str(tmp_path))
    assert out_file("~/a.toml") == tmp_path / "a.toml" and out_path("~/D") == tmp_path / "D"


@pytest.mark.parametrize(
    "flags, words",
    [
        (["--speed", "1e300"], "--speed 1e+300 m/s is outside the physical domain [1, 3000] m/s"),
        (["--speed", "50", "--altitude", "1e9"], "altitude 1e+09 m (--altitude) is outside the ISA model"),
    ],
)
def test_a_fit_reference_condition_is_checked_before_the_source_is_read(flags, words, tmp_path, no_fit, capsys):
    assert words in _one_line_exit_2(["fit", "gtm", *flags, "--out", tmp_path / "f.toml"], capsys)


def test_a_folder_inside_another_runs_staging_folder_is_refused(tmp_path, capsys):
    staging = tmp_path / ".D.gflat-0123456789ab.tmp"  # a run working (or killed) into D
    staging.mkdir()
    err = _one_line_exit_2(["plan", SCENARIO, "--out", staging / "x"], capsys)
    assert f"lies inside {staging}, the staging folder of another gflat run" in err
    err = _one_line_exit_2(["fit", "gtm", "--out", staging / "x.toml"], capsys)
    assert f"{staging} is the staging folder of another gflat run" in err
    assert os.listdir(staging) == []


def test_a_folder_named_like_a_pattern_removes_only_its_own_abandoned_staging(tmp_path):
    other = tmp_path / ".D.gflat-aaaaaaaaaaaa.tmp"  # D's abandoned staging: not that of a folder named "*"
    other.mkdir()
    with RunDir(tmp_path / "*", command="plan") as run:
        run.commit()
    assert other.is_dir() and (tmp_path / "*" / MANIFEST).is_file()


def test_a_message_naming_a_file_with_a_line_break_stays_one_line(tmp_path, capsys):
    err = _one_line_exit_2(["plan", SCENARIO, "--out", tmp_path / "no\nsuch" / "x"], capsys)
    assert "no\\nsuch" in err


def test_a_missing_folder_of_an_output_file_is_named(tmp_path, no_fit, capsys):
    err = _one_line_exit_2(["fit", "gtm", "--out", tmp_path / "none" / "x.toml"], capsys)
    assert err.endswith(f"No such file or directory: its folder {tmp_path / 'none'} does not exist")


def test_an_output_grid_of_absurdly_many_samples_is_one_line(tmp_path, capsys):
    err = _one_line_exit_2(["export-jsbsim-script", SCENARIO, "--out", tmp_path / "o", "--dt-out", "1e-300"], capsys)
    assert "dt_out = 1e-300 s makes 8e+300 output intervals over the span [-2.5, 5.5] s, above the bound 1e+09" in err
    assert not (tmp_path / "o").exists()
