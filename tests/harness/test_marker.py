"""The completion marker: the earlier run's files a run that removes nothing keeps listed; a run's top folder."""

from __future__ import annotations

from harness.marker import earlier_files, run_folder
from harness.outdir import INCOMPLETE, MARKER


def test_earlier_files_are_those_still_there_inside_the_folder(tmp_path):
    root = tmp_path / "run"
    (root / "sub").mkdir(parents=True)
    for name in ("a.txt", "sub/b.txt", "c.txt", MARKER, INCOMPLETE):
        (root / name).write_text("x")
    (tmp_path / "outside.txt").write_text("x")
    (root / "link.txt").symlink_to(tmp_path / "outside.txt")
    previous = ["a.txt", "sub/b.txt", "gone.txt", "../outside.txt", "link.txt", "sub", MARKER, INCOMPLETE, "c.txt"]
    assert earlier_files(root, previous, written=["c.txt"]) == ["a.txt", "sub/b.txt"]


def test_the_run_folder_of_a_case_folder_is_the_one_holding_the_marker(tmp_path):
    case = tmp_path / "paper" / "s" / "open"
    case.mkdir(parents=True)
    assert run_folder(case) == case  # no run: the folder itself
    (tmp_path / "paper" / INCOMPLETE).write_text('{"command": "paper"}\n')
    assert run_folder(case) == tmp_path / "paper"
    (case / MARKER).write_text("{}")
    assert run_folder(case) == case
