"""``gflat report DIR`` touches only the files of the run it renders; bad saved files are one line, exit 2."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from harness.cli import main
from harness.outdir import MARKER

from .test_outguard import _files
from .test_report_command import compared  # noqa: F401  (fixture)


def _one_line(capsys, code, *args) -> str:
    assert main(["report", *map(str, args), "--no-pdf"]) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


def test_a_kept_page_beside_the_run_is_not_removed(compared, tmp_path, capsys):  # noqa: F811
    """demo/ holds a run and a folder with a kept case.html and no report.json: the page stays."""
    demo = tmp_path / "demo"
    shutil.copytree(compared, demo)
    kept = demo / "kept-pages"
    kept.mkdir()
    shutil.copy(demo / "case.html", kept / "case.html")
    assert main(["report", str(demo), "--no-pdf"]) == 0
    assert (kept / "case.html").is_file()
    # a page the run's marker lists whose case is gone is the run's own orphan: removed
    (demo / "case2").mkdir()
    shutil.copy(demo / "report.json", demo / "case2" / "report.json")
    marker = json.loads((demo / MARKER).read_text())
    marker["files"].append({"path": "case2/report.json"})  # a case of the run's own
    (demo / MARKER).write_text(json.dumps(marker))
    assert main(["report", str(demo), "--no-pdf"]) == 0
    assert "case2/case.html" in [f["path"] for f in json.loads((demo / MARKER).read_text())["files"]]
    (demo / "case2" / "report.json").unlink()
    assert main(["report", str(demo), "--no-pdf"]) == 0
    assert not (demo / "case2").exists() and (kept / "case.html").is_file()


def test_a_case_the_runs_marker_does_not_list_is_not_shown(compared, tmp_path, capsys):  # noqa: F811
    """A copy of a case's report.json put into a run's folder is not the run's: not rendered, not linked."""
    run = tmp_path / "run"
    shutil.copytree(compared, run)
    (run / "extra").mkdir()
    shutil.copy(run / "report.json", run / "extra" / "report.json")
    assert main(["report", str(run), "--no-pdf"]) == 0
    assert "(1 case page(s))" in capsys.readouterr().out
    assert not (run / "extra" / "case.html").exists()
    assert "extra/" not in (run / "index.html").read_text()


def test_a_folder_of_separate_runs_is_refused_naming_them(compared, tmp_path, capsys):  # noqa: F811
    w = tmp_path / "w"
    for name in ("a", "b"):
        shutil.copytree(compared, w / name)
    before = _files(w)
    err = _one_line(capsys, 2, w)
    assert (
        f"{w} is not a run's folder; it holds 2 separate run(s) (a, b): render each with gflat report {w / 'a'}" in err
    )
    assert _files(w) == before
    assert main(["report", str(w / "a"), "--no-pdf"]) == 0  # each run alone
    assert "(1 case page(s))" in capsys.readouterr().out


def test_a_run_holding_another_run_renders_its_own_cases_only(compared, tmp_path, capsys):  # noqa: F811
    run = tmp_path / "run"
    shutil.copytree(compared, run)
    shutil.copytree(compared, run / "inner")  # a run inside (made before the output-folder rules)
    assert main(["report", str(run), "--no-pdf"]) == 0
    assert "inner/case.html" not in (run / "index.html").read_text()
    assert "(1 case page(s))" in capsys.readouterr().out


@pytest.mark.parametrize("where", ["/", "~"])
def test_a_root_or_the_home_folder_is_refused(where, tmp_path, monkeypatch, capsys):
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    target = Path(where).expanduser()
    err = _one_line(capsys, 2, target)
    assert "is no run's output folder" in err
    assert list(home.iterdir()) == []


@pytest.mark.parametrize("name", ["manifest.json", "report.json"])
@pytest.mark.parametrize(
    "text, cause",
    [
        ("[1, 2]", "a JSON array, not an object"),
        ('"str"', "a JSON string, not an object"),
        ("NaN", "NaN is not a JSON number"),
        ('{"x": NaN}', "NaN is not a JSON number"),
        ('{"x":', "invalid JSON: Expecting value"),
    ],
)
def test_a_bad_saved_file_is_one_line(compared, tmp_path, capsys, name, text, cause):  # noqa: F811
    run = tmp_path / "m"
    shutil.copytree(compared, run)
    (run / name).write_text(text)
    before = _files(run)
    err = _one_line(capsys, 2, run)
    assert f"{run / name}: not a gflat " in err and cause in err
    assert _files(run) == before


@pytest.mark.parametrize(
    "text, cause", [('{"cases": 5}', "'cases' is not a list"), ('{"cases": [{"scenario": 5, "loop": []}]}', None)]
)
def test_a_manifest_with_bad_cases_is_one_line_or_ignored(compared, tmp_path, capsys, text, cause):  # noqa: F811
    """'cases' not a list: one line naming the file; entries of the wrong kind only lose their place in the order."""
    run = tmp_path / "m"
    shutil.copytree(compared, run)
    (run / "manifest.json").write_text(text)
    if cause is None:
        assert main(["report", str(run), "--no-pdf"]) == 0
        return
    before = _files(run)
    err = _one_line(capsys, 2, run)
    assert f"{run / 'manifest.json'}: not a gflat run manifest ({cause})" in err
    assert _files(run) == before
