"""Output folders a run must not write into: a root or the home folder, another command's run, a folder in use."""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from gna.errors import InputError
from harness.cli import main
from harness.marker import record_in_marker
from harness.outdir import INCOMPLETE, MARKER, OutputDir

from .test_validation import short_scenario  # noqa: F401  (fixture)

ROOT = Path(__file__).resolve().parents[2]


def _run(folder: Path, command: str | None, names=("a.txt", "sub/b.txt"), finish: bool = True) -> OutputDir:
    out = OutputDir(folder, command=command)
    for name in names:
        out.write_text(*name.split("/"), text=name)
    if finish:
        out.finish()
    else:
        out.release()  # an interrupted run: its process has ended
    return out


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# ---- another command's run -----------------------------------------------------------------------


def test_the_marker_names_the_command(tmp_path):
    _run(tmp_path / "run", "paper")
    assert json.loads((tmp_path / "run" / MARKER).read_text())["command"] == "paper"
    out = OutputDir(tmp_path / "run", command="paper")
    out.write_text("c.txt", text="c")
    assert json.loads((tmp_path / "run" / INCOMPLETE).read_text().splitlines()[0]) == {"command": "paper"}


@pytest.mark.parametrize("finish", [True, False])
def test_a_run_of_another_command_is_refused_before_anything_is_written(tmp_path, finish):
    _run(tmp_path / "run", "paper", finish=finish)
    before = _files(tmp_path / "run")
    what = "a complete run" if finish else "an interrupted run"
    with pytest.raises(
        InputError,
        match=rf"output folder .*run holds {what} of 'gflat paper' \(2 files\); "
        r"'gflat plan' would remove those it does not write again: give another "
        r"folder with --out, or remove this one first",
    ):
        OutputDir(tmp_path / "run", command="plan")
    with pytest.raises(InputError, match="'gflat export-jsbsim' would mix its files with them"):
        OutputDir(tmp_path / "run", command="export-jsbsim", clean=False)
    with pytest.raises(InputError, match="of 'gflat paper'.*this run would remove"):
        OutputDir(tmp_path / "run")  # through the Python API too
    assert _files(tmp_path / "run") == before
    OutputDir(tmp_path / "run", command="paper").release()  # the same command may write there again


def test_a_run_whose_files_are_gone_is_no_obstacle(tmp_path):
    _run(tmp_path / "run", "paper")
    for name in ("a.txt", "sub/b.txt"):
        (tmp_path / "run" / name).unlink()
    OutputDir(tmp_path / "run", command="plan").finish()


def test_a_marker_naming_no_command_is_refused_when_its_files_would_be_removed(tmp_path):
    _run(tmp_path / "run", None)  # as an earlier gflat wrote it: no command
    marker = json.loads((tmp_path / "run" / MARKER).read_text())
    del marker["command"]
    (tmp_path / "run" / MARKER).write_text(json.dumps(marker))
    with pytest.raises(
        InputError,
        match=r"holds a complete run whose marker names no command \(an earlier gflat, "
        r"or the Python API\): 'gflat paper' would remove those of its 2 files it "
        r"does not write again \(a.txt, sub/b.txt\): give another folder",
    ):
        OutputDir(tmp_path / "run", command="paper")
    OutputDir(tmp_path / "run", command="export-jsbsim", clean=False).release()  # removes nothing: allowed
    OutputDir(tmp_path / "run").release()  # the Python API, as before


def test_the_report_case_plan_into_a_paper_folder_is_refused(tmp_path, capsys):
    """The fresh-clone test: ``gflat plan --out`` a copy of a paper run deleted 109 of its 123 files."""
    _run(tmp_path / "full3", "paper", names=("manifest.json", "report.pdf", "index.html", "s/open/case.html"))
    before = _files(tmp_path / "full3")
    assert main(["plan", "gtm-aileron-roll", "--out", str(tmp_path / "full3")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"output folder {tmp_path / 'full3'} holds a complete run of 'gflat paper'" in err
    assert _files(tmp_path / "full3") == before


def test_a_rerun_of_the_same_command_says_what_it_removed(tmp_path, caplog):
    _run(tmp_path / "run", "plan", names=("a.txt", "b.txt", "c.txt", "d.txt", "e.txt"))
    again = OutputDir(tmp_path / "run", command="plan")
    again.write_text("a.txt", text="again")
    with caplog.at_level(logging.WARNING, logger="harness.outdir"):
        again.finish()
    assert [r.getMessage() for r in caplog.records] == [
        f"{tmp_path / 'run'}: removed 4 file(s) of the folder's earlier run that this run did not write again "
        f"(b.txt, c.txt, d.txt, ...)"
    ]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="harness.outdir"):
        _run(tmp_path / "run", "plan", names=("a.txt",))  # nothing removed: nothing said
    assert caplog.records == []


def test_the_rerun_warning_is_one_line_on_stderr_hidden_by_quiet(tmp_path, capsys):
    out = tmp_path / "plan"
    assert main(["plan", "gtm-aileron-roll", "--J", "1", "--out", str(out)]) == 0
    for quiet in ((), ("-q",)):
        (out / "notes.txt").write_text("an earlier file of the run")
        assert record_in_marker(out, [out / "notes.txt"])
        capsys.readouterr()
        assert main(["plan", "gtm-aileron-roll", "--J", "1", "--out", str(out), *quiet]) == 0
        err = capsys.readouterr().err
        assert not (out / "notes.txt").exists()
        assert err == (
            ""
            if quiet
            else f"gflat: WARNING: {out}: removed 1 file(s) of the folder's earlier run that "
            f"this run did not write again (notes.txt)\n"
        )


# ---- a root or the home folder -------------------------------------------------------------------


def test_a_root_is_refused():
    with pytest.raises(InputError, match=r"output folder /: a file-system root is not an output folder"):
        OutputDir("/")
    with pytest.raises(InputError, match="file-system root"):
        OutputDir("/tmp/..")


def test_the_home_folder_is_refused_its_sub_folders_are_not(tmp_path, monkeypatch, capsys):
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    assert main(["plan", "gtm-aileron-roll", "--out", str(home)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"gflat plan: error: output folder {home}: your home folder itself is not an output folder (a run "
        f"removes its earlier files there); give a folder of its own, e.g. --out ~/gflat-out\n"
    )
    with pytest.raises(InputError, match="home folder"):
        OutputDir("~")
    assert list(home.iterdir()) == []
    OutputDir(home / "out").release()


# ---- a folder in use -----------------------------------------------------------------------------

_HOLDER = r"""
import sys, time
from harness.outdir import OutputDir
out = OutputDir(sys.argv[1], command="paper")
out.write_text("a.txt", text="a")
print("holding", flush=True)
sys.stdin.readline()
"""


def _holder(folder: Path) -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(folder)], cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout.readline() == "holding\n"
    return proc


def test_a_folder_in_use_is_refused_to_a_second_process(tmp_path):
    folder = tmp_path / "run"
    proc = _holder(folder)
    try:
        second = subprocess.run(
            [sys.executable, "-m", "harness.cli", "paper", "--out", str(folder)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert second.returncode == 2, second.stderr
        assert second.stderr == (
            f"gflat paper: error: output folder {folder} is in use by another gflat run (it "
            f"holds the folder until it ends): wait for it to end, or give another folder with "
            f"--out\n"
        )
        with pytest.raises(InputError, match="in use by another gflat run"):
            OutputDir(folder, command="paper")
    finally:
        proc.communicate("\n", timeout=60)  # the first run ends without finishing
    assert proc.returncode == 0
    assert sorted(os.listdir(folder)) == [INCOMPLETE, "a.txt"]  # no lock file left
    OutputDir(folder, command="paper").finish()  # free again


def test_ctrl_c_releases_the_folder(tmp_path):
    folder = tmp_path / "run"
    proc = _holder(folder)
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=60)
    assert proc.returncode != 0
    OutputDir(folder, command="paper").release()


def test_the_lock_is_released_by_finish_and_kept_for_the_report(tmp_path):
    first = OutputDir(tmp_path / "run", command="compare")
    first.write_text("a.txt", text="a")
    first.finish(release=False)  # the report is written after the marker
    with pytest.raises(InputError, match="in use"):
        OutputDir(tmp_path / "run", command="compare")
    first.release()
    OutputDir(tmp_path / "run", command="compare").finish()
    OutputDir(tmp_path / "run", command="compare").finish()  # finish released it


def test_a_forked_worker_ending_does_not_release_the_folder(tmp_path):
    out = OutputDir(tmp_path / "run", command="paper")
    pid = os.fork()
    if pid == 0:  # a worker leaving as Python does, finalizers run
        out.release()
        os._exit(0)
    os.waitpid(pid, 0)
    with pytest.raises(InputError, match="in use"):
        OutputDir(tmp_path / "run", command="paper")
    out.release()


def test_a_run_that_writes_nothing_leaves_no_folder(tmp_path):
    OutputDir(tmp_path / "a" / "b", parents=True, command="plan")  # collected at once: released
    assert list(tmp_path.iterdir()) == []
    out = OutputDir(tmp_path / "c", command="plan")
    assert out.root.is_dir()
    out.release()
    assert not (tmp_path / "c").exists()


# ---- export-jsbsim into the repository's aircraft_xml/ ------------------------------------------


def test_export_jsbsim_leaves_no_marker_in_the_default_folder(tmp_path, monkeypatch, capsys):
    from harness.engines.jsbsim import files as jf

    folder = tmp_path / "aircraft_xml"
    monkeypatch.setattr(jf, "default_root", lambda: folder)
    folder.mkdir()
    (folder / INCOMPLETE).write_text('"f16c/f16c.xml"\n')  # left by earlier versions
    assert main(["export-jsbsim", "f16c", "a7"]) == 0
    assert sorted(str(p.relative_to(folder)) for p in folder.rglob("*")) == ["a7", "a7/a7.xml", "f16c", "f16c/f16c.xml"]
    assert main(["export-jsbsim", "--all", "--check"]) == 1  # a folder of two aircraft, read as before
    assert main(["export-jsbsim", "f16c", "--out", str(tmp_path / "x")]) == 0
    assert json.loads((tmp_path / "x" / MARKER).read_text())["command"] == "export-jsbsim"
    assert not (tmp_path / "x" / INCOMPLETE).exists()


# ---- gflat paper run again into its folder -------------------------------------------------------


def test_paper_rerun_with_one_loop_says_what_it_removed_and_leaves_no_orphan_page(
    short_scenario,  # noqa: F811
    tmp_path,  # noqa: F811
    monkeypatch,
    capsys,
):
    from harness.commands import paper

    monkeypatch.setattr(paper, "PAPER_SCENARIOS", (str(short_scenario),))
    run = tmp_path / "full"
    assert main(["paper", "--out", str(run)]) == 0
    assert (run / "short" / "closed" / "case.html").is_file()
    capsys.readouterr()
    assert main(["paper", "--loop", "open", "--out", str(run)]) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"gflat: WARNING: {run}: removed ") and err.count("\n") == 1
    assert "short/closed/" in err and not (run / "short" / "closed").exists()  # no orphaned page either
    pages = sorted(str(p.relative_to(run)) for p in run.rglob("*.html"))
    assert pages == ["index.html", "short/open/case.html"]
    listed = {f["path"] for f in json.loads((run / MARKER).read_text())["files"]}
    assert all((run / f).is_file() for f in listed) and json.loads((run / MARKER).read_text())["command"] == "paper"
    assert main(["plan", str(short_scenario), "--out", str(run)]) == 2
    assert "holds a complete run of 'gflat paper'" in capsys.readouterr().err


def test_a_run_that_removes_nothing_keeps_the_earlier_runs_files_listed(tmp_path, capsys):
    """A marker naming no command (an earlier gflat): a run that removes nothing writes there and lists the earlier
    files next to its own -- one rule for every such command (export-jsbsim --out, export-jsbsim-script, campaign)."""
    _run(tmp_path / "run", None)
    marker = json.loads((tmp_path / "run" / MARKER).read_text())
    del marker["command"]
    (tmp_path / "run" / MARKER).write_text(json.dumps(marker))
    for craft, listed in (
        ("f16c", ["a.txt", "sub/b.txt", "f16c/f16c.xml"]),
        ("a7", ["a.txt", "sub/b.txt", "f16c/f16c.xml", "a7/a7.xml"]),
    ):
        assert main(["export-jsbsim", craft, "--out", str(tmp_path / "run")]) == 0
        marker = json.loads((tmp_path / "run" / MARKER).read_text())
        assert marker["command"] == "export-jsbsim" and [f["path"] for f in marker["files"]] == listed
    assert (tmp_path / "run" / "a.txt").read_text() == "a.txt"
    capsys.readouterr()
    assert main(["plan", "gtm-aileron-roll", "--out", str(tmp_path / "run")]) == 2
    assert "holds a complete run of 'gflat export-jsbsim' (4 files)" in capsys.readouterr().err
