"""``gflat report DIR``: renders a copy of the run and swaps it in place; the run is never changed in place."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from harness.cli import main
from harness.rundir import MANIFEST, RunDir

from .test_rundir import _matches_manifest, _staging, _tree
from .test_validation import SHORT


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


def _manifest(folder: Path) -> dict:
    return json.loads((folder / MANIFEST).read_text())


def test_report_renders_a_copy_of_the_run_and_swaps_it_in(compared, tmp_path, capsys):
    run = _copy(compared, tmp_path / "run")
    before = _manifest(run)
    assert main(["report", str(run), "--self-contained", "--no-pdf"]) == 0
    after = _manifest(run)
    assert after["command"] == "compare" and after["run_id"] != before["run_id"]  # still gflat compare's run
    assert after["command_line"] == before["command_line"] and after["date_utc"] == before["date_utc"]
    assert [f["path"] for f in after["files"]] == sorted([f["path"] for f in before["files"]] + ["report.html"])
    _matches_manifest(run)
    assert _staging(tmp_path, "run") == [] and sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    assert f"report: {run / 'index.html'} (1 case page(s))" in capsys.readouterr().out


def test_a_case_folder_inside_a_run_renders_that_run(compared, tmp_path):
    # a gflat paper run of one case: the case folder is below the run's top folder, which holds the manifest
    with RunDir(tmp_path / "paper", command="paper") as out:
        for rel in _tree(compared):
            if rel != MANIFEST:
                out.write_bytes("short", "open", *rel.split("/"), data=(compared / rel).read_bytes())
        out.commit()
    case = tmp_path / "paper" / "short" / "open"
    assert main(["report", str(case), "--self-contained", "--no-pdf"]) == 0
    assert (tmp_path / "paper" / "report.html").is_file() and (tmp_path / "paper" / "index.html").is_file()
    assert _manifest(tmp_path / "paper")["command"] == "paper"
    _matches_manifest(tmp_path / "paper")


def test_a_rerun_with_replace_replaces_the_rendered_pages_too(compared, tmp_path):
    run = _copy(compared, tmp_path / "run")
    assert main(["report", str(run), "--self-contained", "--no-pdf"]) == 0
    assert (run / "report.html").is_file()
    assert main(["compare", str(compared.parent / "short.toml"), "--J", "0", "--out", str(run), "--replace"]) == 0
    assert not (run / "report.html").exists() and (run / "index.html").is_file()
    _matches_manifest(run)


def test_refusals_are_one_line_and_change_nothing(compared, tmp_path, capsys):
    holder = tmp_path / "runs"
    run = _copy(compared, holder / "run")
    assert main(["report", str(holder), "--no-pdf"]) == 2  # a folder holding runs is none
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{holder} is not the folder of a gflat run" in err
    (run / "mine.txt").write_text("the user's")
    before = _tree(run)
    assert main(["report", str(run), "--no-pdf"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds mine.txt, which is not a file of its gflat run" in err
    assert "--out" not in err and err.rstrip().endswith("move that file away")  # report has no --out
    assert _tree(run) == before
    (run / "mine.txt").unlink()
    (run / "states.png").unlink()  # a file the manifest lists, gone
    assert main(["report", str(run), "--no-pdf"]) == 2
    assert "states.png, listed in its manifest, is missing" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "missing")]) == 2
    assert capsys.readouterr().err == (
        f"gflat report: error: {tmp_path / 'missing'} does not exist: give the folder of a gflat paper or gflat "
        f"compare run\n"
    )
    assert _staging(holder, "run") == []
