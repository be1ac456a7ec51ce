"""``gflat report DIR``: holds the run's folder as every run does, and adds its files to that run's own list."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from gna.errors import InputError
from harness.cli import main
from harness.marker import amending
from harness.outdir import INCOMPLETE, MARKER, OutputDir
from harness.outguard import previous_run

from .test_outguard import _files
from .test_validation import SHORT

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    """A finished ``gflat compare --out`` run (the short scenario, J = 0): a run folder of one case."""
    base = tmp_path_factory.mktemp("report")
    (base / "short.toml").write_text(SHORT)
    run = base / "run"
    assert main(["compare", str(base / "short.toml"), "--J", "0", "--out", str(run)]) == 0
    return run


def _copy(run: Path, to: Path) -> Path:
    shutil.copytree(run, to)
    return to


def _listed(folder: Path) -> list[str]:
    return [f["path"] for f in json.loads((folder / MARKER).read_text())["files"]]


_HOLDER = r"""
import sys
from harness.outdir import OutputDir
out = OutputDir(sys.argv[1], command="compare")
print("holding", flush=True)
sys.stdin.readline()
"""


def test_report_is_refused_while_a_run_writes_the_folder(compared, tmp_path):
    run = _copy(compared, tmp_path / "run")
    before = _files(run)
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(run)], cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline() == "holding\n"  # gflat compare --out DIR is running again
        second = subprocess.run(
            [sys.executable, "-m", "harness.cli", "report", str(run), "--no-pdf"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        holder.communicate("\n", timeout=60)
    assert second.returncode == 2, second.stderr
    assert second.stderr == (
        f"gflat report: error: output folder {run} is in use by another gflat run (it holds "
        f"the folder until it ends): wait for it to end\n"
    )
    assert _files(run) == before  # nothing changed
    assert main(["report", str(run), "--no-pdf"]) == 0  # free again


def test_a_run_into_the_folder_is_refused_while_report_writes_it(compared, tmp_path, capsys):
    run = _copy(compared, tmp_path / "run")
    before = _files(run)
    with amending(run):  # what gflat report holds while it renders
        assert main(["compare", "gtm-aileron-roll", "--J", "0", "--out", str(run)]) == 2
        assert main(["report", str(run), "--no-pdf"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and all(f"output folder {run} is in use by another gflat run" in e for e in err)
    assert err[0].startswith("gflat compare: error:") and err[1].startswith("gflat report: error:")
    assert _files(run) == before


def test_a_case_folder_inside_a_run_is_held_with_its_run(compared, tmp_path, capsys):
    # a gflat paper run of one case: the case folder is below the run's top folder, which holds the marker
    top = tmp_path / "paper"
    out = OutputDir(top, command="paper")
    for rel, data in _files(compared).items():
        if rel != MARKER:
            out.write_bytes("short", "open", *rel.split("/"), data=data)
    out.finish()
    case = top / "short" / "open"
    with amending(top):
        assert main(["report", str(case), "--self-contained", "--no-pdf"]) == 2
    assert "is in use by another gflat run" in capsys.readouterr().err
    assert main(["report", str(case), "--self-contained", "--no-pdf"]) == 0
    assert _listed(top)[-1] == "short/open/report.html"  # listed in the run's marker, relative to its top
    assert json.loads((top / MARKER).read_text())["command"] == "paper"


def test_report_adds_its_files_to_the_run_of_another_command_and_a_rerun_replaces_them(compared, tmp_path, capsys):
    run = _copy(compared, tmp_path / "run")
    listed = _listed(run)
    assert main(["report", str(run), "--self-contained", "--no-pdf"]) == 0  # a gflat compare run: not refused
    marker = json.loads((run / MARKER).read_text())
    assert marker["command"] == "compare"  # still the run of gflat compare
    assert [f["path"] for f in marker["files"]] == [*listed, "report.html"]  # the run's list kept, the page added
    assert main(["report", str(run), "--self-contained", "--no-pdf"]) == 0
    assert _listed(run) == [*listed, "report.html"]  # once
    capsys.readouterr()
    # gflat compare run again there: the single page of the earlier results is one of the run's stale files
    assert main(["compare", str(compared.parent / "short.toml"), "--J", "0", "--out", str(run)]) == 0
    assert f"{run}: removed 1 file(s) of the folder's earlier run" in capsys.readouterr().err
    assert not (run / "report.html").exists() and "report.html" not in _listed(run)
    assert (run / "index.html").is_file() and (run / "case.html").is_file()


def test_report_of_an_interrupted_run_lists_its_files_in_the_in_progress_record(compared, tmp_path, capsys):
    run = _copy(compared, tmp_path / "run")
    listed = _listed(run)
    (run / INCOMPLETE).write_text(
        json.dumps({"command": "compare"}) + "\n" + "".join(json.dumps(f) + "\n" for f in listed) + '"cut sho'
    )
    (run / MARKER).unlink()  # interrupted: the record, its last line cut short
    assert main(["report", str(run), "--self-contained", "--no-pdf"]) == 0
    assert "warning: incomplete run" in capsys.readouterr().err
    prev = previous_run(run)
    assert prev.command == "compare" and not prev.complete and prev.files == [*listed, "report.html"]
    with pytest.raises(InputError, match="holds an interrupted run of 'gflat compare'"):
        OutputDir(run, command="plan")  # the page counts as the run's, like its other files


def test_report_of_a_run_by_an_earlier_gflat_keeps_its_marker(compared, tmp_path):
    run = _copy(compared, tmp_path / "run")
    marker = json.loads((run / MARKER).read_text())
    del marker["command"]  # an earlier gflat named no command
    (run / MARKER).write_text(json.dumps(marker))
    assert main(["report", str(run), "--self-contained", "--no-pdf"]) == 0
    after = json.loads((run / MARKER).read_text())
    assert "command" not in after and [f["path"] for f in after["files"]] == [
        *(f["path"] for f in marker["files"]),
        "report.html",
    ]


def test_a_stale_pdf_removed_by_report_leaves_the_marker(compared, tmp_path, capsys):
    run = _copy(compared, tmp_path / "run")
    assert main(["report", str(run), "--self-contained", "--no-pdf"]) == 0
    pdf = run / "report.pdf"
    pdf.write_bytes(b"%PDF- printed from earlier results")
    old = (run / "report.json").stat().st_mtime - 100
    os.utime(pdf, (old, old))
    from harness.marker import record_in_marker

    assert record_in_marker(run, [pdf])  # as an earlier gflat report --pdf recorded it
    assert "report.pdf" in _listed(run)
    assert main(["report", str(run), "--no-pdf"]) == 0
    assert "removed the stale" in capsys.readouterr().out and not pdf.exists()
    assert "report.pdf" not in _listed(run) and "report.html" in _listed(run)


def test_report_into_a_folder_that_takes_no_files_is_one_line(tmp_path, capsys):
    assert main(["report", "/proc/self"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot write there" in err
    assert main(["report", str(tmp_path / "missing")]) == 2
    assert capsys.readouterr().err == f"gflat report: error: {tmp_path / 'missing'} is not a folder\n"
