"""OutputDir: destination checked first, atomic writes, no escape, stale files of a rerun removed, marker."""

from __future__ import annotations

import json
import math
import os
import sys

import pytest

from gna.errors import InputError
from harness.fileio import json_safe
from harness.outdir import INCOMPLETE, MARKER, OutputDir


def test_writes_are_recorded_and_marked(tmp_path):
    out = OutputDir(tmp_path / "run")
    out.write_text("a.txt", text="hello\n")
    out.write_json("s", "summary.json", obj={"x": 1.5, "n": [1, 2]})
    sub = out.sub("plan")
    sub.write_bytes("p.bin", data=b"\x00\x01")
    assert [str(p) for p in out.written] == ["a.txt", "s/summary.json", "plan/p.bin"]
    assert sub.written == out.written  # one shared record
    marker = json.loads(out.finish().read_text())
    assert [f["path"] for f in marker["files"]] == ["a.txt", "s/summary.json", "plan/p.bin"]
    assert all(len(f["sha256"]) == 64 for f in marker["files"]) and marker["date_utc"].endswith("+00:00")
    assert json.loads((tmp_path / "run" / "s" / "summary.json").read_text()) == {"x": 1.5, "n": [1, 2]}


def test_existing_file_as_out_is_refused(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        OutputDir(f)


def test_missing_parent_is_refused_unless_parents(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        OutputDir(tmp_path / "no" / "such" / "dir")
    out = OutputDir(tmp_path / "no" / "such" / "dir", parents=True)
    assert out.root.is_dir()  # made at once, to be locked
    out.release()
    assert list(tmp_path.iterdir()) == []  # nothing written: the folders made are removed
    out = OutputDir(tmp_path / "no" / "such" / "dir", parents=True)
    out.write_text("x.txt", text="1")
    out.release()
    assert (out.root / "x.txt").is_file()


def test_parent_is_a_file(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="is a file"):
        OutputDir(tmp_path / "f" / "out")


def test_read_only_parent_is_refused(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.access(ro, os.W_OK) and (os.geteuid() == 0 if hasattr(os, "geteuid") else False):
            pytest.skip("running as root: chmod does not stop root from writing")
        with pytest.raises(InputError, match="ro"):
            OutputDir(ro / "out")
        with pytest.raises(InputError, match="cannot write"):
            OutputDir(ro)
    finally:
        ro.chmod(0o755)


@pytest.mark.parametrize("parts", [("..", "x.txt"), ("a", "..", "..", "x.txt"), ("/etc/x.txt",), ("",)])
def test_escapes_are_refused(tmp_path, parts):
    out = OutputDir(tmp_path / "run")
    with pytest.raises(InputError):
        out.write_text(*parts, text="no")
    assert not (tmp_path / "x.txt").exists()


@pytest.mark.skipif(sys.platform == "win32", reason="symbolic links")
def test_symlink_out_of_the_folder_is_refused(tmp_path):
    out = OutputDir(tmp_path / "run")
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "run" / "link").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(InputError, match="leaves the output folder"):
        out.write_text("link", "x.txt", text="no")
    with pytest.raises(InputError, match="leaves"):
        out.sub("link")
    assert not (tmp_path / "elsewhere" / "x.txt").exists()


def test_rerun_removes_stale_files_only(tmp_path):
    first = OutputDir(tmp_path / "run")
    first.write_text("plan_j0.csv", text="0")
    first.write_text("plan_j1.csv", text="1")
    first.write_text("sub", "old.txt", text="1")
    first.finish()
    (tmp_path / "run" / "mine.txt").write_text("user's own file")
    second = OutputDir(tmp_path / "run")
    second.write_text("plan_j0.csv", text="0 again")
    assert not (tmp_path / "run" / MARKER).exists()  # being rewritten: not a complete set
    second.finish()
    names = sorted(p.name for p in (tmp_path / "run").rglob("*"))
    assert names == sorted([MARKER, "plan_j0.csv", "mine.txt"])
    assert not (tmp_path / "run" / "sub").exists()


def test_a_stale_name_turned_link_is_not_followed(tmp_path):
    """An earlier run's file replaced by a link to a file of the user's: the rerun does not remove the target."""
    first = OutputDir(tmp_path / "run")
    first.write_text("old.csv", text="0")
    first.finish()
    mine = tmp_path / "run" / "mine.txt"
    mine.write_text("user's own file")
    (tmp_path / "run" / "old.csv").unlink()
    (tmp_path / "run" / "old.csv").symlink_to(mine)
    second = OutputDir(tmp_path / "run")
    second.write_text("new.csv", text="1")
    second.finish()
    assert mine.read_text() == "user's own file" and (tmp_path / "run" / "old.csv").is_symlink()


def test_interrupted_rerun_then_smaller_run_leaves_no_stale_file(tmp_path):
    run = tmp_path / "run"
    first = OutputDir(run)  # a complete run: open and closed loop
    for name in ("open/a.csv", "closed/b.csv", "closed/c.csv", "index.html"):
        first.write_text(name, text="1")
    first.finish()
    (run / "mine.txt").write_text("user's own file")  # never listed: never deleted
    second = OutputDir(run)  # interrupted: writes, never finishes
    second.write_text("open/a.csv", text="2")
    second.write_text("open/new-name.csv", text="2")
    assert not (run / MARKER).exists() and (run / INCOMPLETE).is_file()
    second.release()  # the interrupted run has ended
    third = OutputDir(run)  # a smaller complete run
    third.write_text("open/a.csv", text="3")
    third.write_text("index.html", text="3")
    third.finish()
    names = sorted(str(p.relative_to(run)) for p in run.rglob("*") if p.is_file())
    assert names == sorted([MARKER, "index.html", "mine.txt", "open/a.csv"])
    assert not (run / "closed").exists()
    listed = [f["path"] for f in json.loads((run / MARKER).read_text())["files"]]
    assert listed == ["open/a.csv", "index.html"]


def test_marker_mode_follows_umask(tmp_path):
    old = os.umask(0o022)
    try:
        out = OutputDir(tmp_path / "run")
        out.write_text("a.txt", text="1")
        marker = out.finish()
    finally:
        os.umask(old)
    assert marker.stat().st_mode & 0o777 == 0o644 == (tmp_path / "run" / "a.txt").stat().st_mode & 0o777


def test_missing_folder_is_made_at_the_first_file_only(tmp_path):
    OutputDir(tmp_path / "run")  # checked, nothing written: nothing left
    OutputDir(tmp_path / "deep" / "er", parents=True).sub("plan")
    assert list(tmp_path.iterdir()) == []
    out = OutputDir(tmp_path / "deep" / "er", parents=True)
    out.sub("plan").write_text("p.csv", text="1")
    assert (tmp_path / "deep" / "er" / "plan" / "p.csv").is_file()
    empty = OutputDir(tmp_path / "empty")
    assert empty.finish().is_file()  # a complete run of no file still gets its marker


def test_no_clean_keeps_old_files(tmp_path):
    first = OutputDir(tmp_path / "run")
    first.write_text("old.txt", text="1")
    first.finish()
    second = OutputDir(tmp_path / "run", clean=False)
    second.write_text("new.txt", text="2")
    second.finish()
    assert (tmp_path / "run" / "old.txt").exists()


def test_interrupted_write_leaves_nothing_under_the_final_name(tmp_path):
    out = OutputDir(tmp_path / "run")
    with pytest.raises(RuntimeError):
        with out.atomic("fig.png") as tmp:
            assert tmp.parent == out.root and tmp.suffix == ".png"
            tmp.write_bytes(b"half")
            raise RuntimeError("interrupted")
    assert list((tmp_path / "run").iterdir()) == []
    assert out.written == []


def test_os_error_during_write_is_an_input_error(tmp_path):
    out = OutputDir(tmp_path / "run")
    with pytest.raises(InputError, match=r"cannot write .*data.bin: No space left"):
        with out.atomic("data.bin"):
            raise OSError(28, "No space left on device")
    assert list((tmp_path / "run").iterdir()) == []


def test_json_refuses_nan_unless_made_safe(tmp_path):
    out = OutputDir(tmp_path / "run")
    with pytest.raises(InputError, match="JSON"):
        out.write_json("s.json", obj={"x": math.nan})
    assert not (tmp_path / "run" / "s.json").exists()
    out.write_json("s.json", obj=json_safe({"x": math.nan, "y": (1, 2)}))
    assert json.loads((tmp_path / "run" / "s.json").read_text()) == {"x": None, "y": [1, 2]}


def test_unwritable_folder_is_refused_whoever_runs(tmp_path, monkeypatch):
    """The probe write fails as it would in a read-only folder (root ignores chmod, so the failure is simulated)."""
    import tempfile

    def refuse(*a, **k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with pytest.raises(
        InputError,
        match=r"output folder .*ro: cannot create it, its nearest existing folder "
        r".* takes no files: Permission denied",
    ):
        OutputDir(tmp_path / "ro")
    (tmp_path / "ro").mkdir()
    with pytest.raises(InputError, match=r"output folder .*ro: cannot write there: Permission denied"):
        OutputDir(tmp_path / "ro")


def test_files_get_the_permissions_of_the_users_umask(tmp_path):
    import os
    import stat

    old = os.umask(0o022)
    try:
        out = OutputDir(tmp_path / "o")
        p = out.write_text("a.txt", text="x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(p.stat().st_mode) == 0o644  # not private to the owner, as mkstemp would make it


def test_files_recorded_after_a_run_are_removed_by_the_next_run(tmp_path):
    """A report rendered again into a finished run's folder joins its files: the next run removes it if stale."""
    from harness.marker import record_in_marker

    od = OutputDir(tmp_path / "run")
    od.write_text("a.txt", text="a")
    od.finish()
    extra = tmp_path / "run" / "report.html"
    extra.write_text("later")
    assert record_in_marker(tmp_path / "run", [extra])
    assert record_in_marker(tmp_path / "run", [extra])  # recorded once, not twice
    files = [f["path"] for f in json.loads((tmp_path / "run" / ".gflat-complete.json").read_text())["files"]]
    assert files == ["a.txt", "report.html"]
    again = OutputDir(tmp_path / "run")
    again.write_text("a.txt", text="b")
    again.finish()
    assert not extra.exists() and (tmp_path / "run" / "a.txt").read_text() == "b"
    assert not record_in_marker(tmp_path / "elsewhere", [])  # no marker: nothing recorded


def test_a_new_folder_in_a_virtual_file_system_names_the_folder_asked_for(tmp_path):
    # /proc takes no new files (ENOENT): the message names the folder asked for and the folder that refused
    with pytest.raises(
        InputError,
        match=r"output folder /proc/gflat-x: cannot create it, its nearest existing "
        r"folder /proc takes no files: ",
    ):
        OutputDir("/proc/gflat-x")
