"""Hardening, third round, kind 3: a campaign store trusts nothing unchecked.

The store records each case's files with their size and sha256.  On resume a case marked done whose files are
missing, truncated or changed is computed again (never skipped); ``campaign report`` refuses it in one line
(never renders it); ``--only CASE`` replaces a truncated Parquet; a read-only store, a NULL metric, a malformed
row, a hostile case id or a linked ``cases`` folder is one line, never a traceback.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import sqlite3
import subprocess
from pathlib import Path

import pytest

from harness.campaign import CampaignStore, run_campaign
from harness.cli import main

from .harness.campaign.test_runner import TINY, _check_folder

CASE = "level.fit.0001"


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    """The tiny campaign, 2 samples, done (copied by each test)."""
    out = tmp_path_factory.mktemp("store") / "done"
    res = run_campaign(TINY, out, samples=2, workers=1, quiet=True)
    assert res["done"] == 2
    return out


@pytest.fixture
def folder(campaign, tmp_path) -> Path:
    d = tmp_path / "C"
    shutil.copytree(campaign, d)
    return d


def _sql(folder: Path, statement: str, *args) -> None:
    con = sqlite3.connect(folder / "campaign.sqlite")
    try:
        with con:
            con.execute(statement, args)
    finally:
        con.close()


def _run(folder, capsys, *extra) -> tuple[int, str]:
    rc = main(["campaign", "run", str(TINY), "--out", str(folder), "--samples", "2", "--workers", "1", *extra])
    return rc, capsys.readouterr().err


def _one_line(rc, capsys, *words) -> str:
    out = capsys.readouterr()
    assert rc == 2 and out.out == "" and len(out.err.strip().splitlines()) == 1, out
    for w in words:
        assert w in out.err, out.err
    return out.err


def _truncate(p: Path) -> None:
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 3])


def _flip(p: Path) -> None:
    data = bytearray(p.read_bytes())
    data[len(data) // 2] ^= 0xFF
    p.write_bytes(bytes(data))


DAMAGE = {
    "truncated": (_truncate, "its file inhouse.parquet is shorter than recorded ("),
    "deleted": (lambda p: p.unlink(), "its file inhouse.parquet is missing"),
    "changed in place": (_flip, "its file inhouse.parquet is changed since it was recorded (sha256 differs)"),
    "folder deleted": (lambda p: shutil.rmtree(p.parent), "its file inhouse.parquet is missing"),
    "a link to another case's": (
        lambda p: (p.unlink(), p.symlink_to(p.parents[1] / "level.fit.0000" / "inhouse.parquet")),
        "its file inhouse.parquet is a symbolic link",
    ),
}


@pytest.mark.parametrize("damage", DAMAGE)
def test_a_damaged_case_is_refused_by_the_report_and_computed_again_on_resume(folder, capsys, damage):
    hurt, cause = DAMAGE[damage]
    hurt(folder / "cases" / CASE / "inhouse.parquet")
    _one_line(main(["campaign", "report", str(folder), "--no-pdf"]), capsys, f"case {CASE}: {cause}", "no report")
    assert not (folder / "report").exists()
    rc, err = _run(folder, capsys, "--quiet")
    assert rc == 0 and f"campaign: case {CASE}: {cause}" in err and ": computed again" in err
    assert "1 computed" in err and "1 skipped" in err  # the sound case kept, the damaged one computed again
    _check_folder(folder, 2)
    assert main(["campaign", "report", str(folder), "--no-pdf"]) == 0


def test_only_replaces_a_truncated_parquet(folder, capsys):
    _truncate(folder / "cases" / CASE / "jsbsim.parquet")
    rc, err = _run(folder, capsys, "--quiet", "--only", CASE)
    assert rc == 0 and "its file jsbsim.parquet is shorter than recorded" in err and "1 computed" in err
    _check_folder(folder, 2)
    cmd = ["campaign", "run", str(TINY), "--out", str(folder), "--samples", "2", "--quiet", "--only", CASE]
    assert main(cmd) == 0  # a sound case: computed aside and compared with the store
    assert json.loads(capsys.readouterr().out)["same_as_stored"] is True


@pytest.mark.parametrize(
    "column, value, cause",
    [
        ("metrics", None, "it is recorded done without metrics"),
        ("metrics", "{broken", "its metrics column is not JSON"),
        (
            "metrics",
            '{"runs": {}, "differences": {}, "pass": true}',
            "it is recorded done without the metrics of every engine",
        ),
        ("files", '"inhouse.parquet"', "its files column is malformed"),
        ("files", '{"../../../x": {}}', "file '../../../x': not a plain name"),
        ("params", "[", "its params column is not JSON"),
        ("metrics", "RUNS:max_position_error_m=far", "its metric max_position_error_m of engine inhouse is missing or"),
        ("metrics", "RUNS:saturated_s=DROP", "its metric saturated_s of engine inhouse is missing or not a number"),
        ("metrics", "DIFF:max_position_m=DROP", "its difference metric max_position_m of engine jsbsim is missing"),
    ],
)
def test_a_null_or_malformed_row_is_one_line(folder, capsys, column, value, cause):
    if value is not None and value.startswith(("RUNS:", "DIFF:")):  # one metric changed in the stored JSON
        where, change = value.split(":", 1)
        key, new = change.split("=")
        con = sqlite3.connect(folder / "campaign.sqlite")
        m = json.loads(con.execute("SELECT metrics FROM cases WHERE case_id = ?", (CASE,)).fetchone()[0])
        con.close()
        tables = m["runs"].values() if where == "RUNS" else m["differences"].values()
        for t in tables:
            t.pop(key) if new == "DROP" else t.__setitem__(key, new)
        value = json.dumps(m)
    _sql(folder, f"UPDATE cases SET {column} = ? WHERE case_id = ?", value, CASE)
    _one_line(main(["campaign", "report", str(folder), "--no-pdf"]), capsys, f"case {CASE}: {cause}")
    assert main(["campaign", "status", str(folder)]) == 0  # status reads what is there, and names the damage
    assert "2 cases" in (out := capsys.readouterr().out) and f"untrusted {CASE}: {cause}" in out
    rc, err = _run(folder, capsys, "--quiet")
    if column == "params":  # the case's parameters are what the store is checked against
        assert rc == 2 and "stored with other parameters" in err and len(err.strip().splitlines()) == 1
    else:
        assert rc == 0 and f"case {CASE}: {cause}" in err
        _check_folder(folder, 2)


def test_a_campaign_value_that_is_not_json_is_one_line(folder, capsys):
    _sql(folder, "UPDATE campaign SET value = '{' WHERE key = 'campaign'")
    for cmd in (["campaign", "report", str(folder), "--no-pdf"], ["campaign", "run", str(TINY), "--out", str(folder)]):
        _one_line(main(cmd), capsys, "the campaign's 'campaign' is not JSON", "use a new folder")


def test_a_failed_case_without_an_error_text_is_listed(folder, capsys):
    _sql(folder, "UPDATE cases SET status = 'failed', metrics = NULL, error = '' WHERE case_id = ?", CASE)
    shutil.rmtree(folder / "cases" / CASE)
    assert main(["campaign", "status", str(folder)]) == 0
    assert f"failed {CASE}: (no error recorded)" in capsys.readouterr().out
    assert main(["campaign", "report", str(folder), "--no-pdf"]) == 0


@pytest.mark.parametrize("case_id", ["../../../escaped", "/tmp/escaped", "a b", ".."])
def test_a_hostile_case_id_is_refused_and_nothing_is_written_outside(folder, capsys, case_id):
    _sql(folder, "UPDATE cases SET case_id = ? WHERE case_id = ?", case_id, CASE)
    before = sorted(p.name for p in folder.parent.iterdir())
    _one_line(main(["campaign", "report", str(folder), "--no-pdf"]), capsys, f"case id {case_id!r}: not a plain name")
    rc, err = _run(folder, capsys, "--quiet")
    assert rc == 2 and "use a new folder" in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in folder.parent.iterdir()) == before and not Path("/tmp/escaped.html").exists()


def test_a_linked_cases_folder_is_refused(folder, tmp_path, capsys):
    elsewhere = tmp_path / "elsewhere"
    shutil.move(folder / "cases", elsewhere)
    (folder / "cases").symlink_to(elsewhere, target_is_directory=True)
    for cmd in (["campaign", "report", str(folder)], ["campaign", "status", str(folder)]):
        _one_line(main(cmd), capsys, "its cases folder is a symbolic link")
    _one_line(main(["campaign", "run", str(TINY), "--out", str(folder)]), capsys, "its cases folder is a symbolic link")


@contextlib.contextmanager
def _read_only(folder: Path):
    """``folder`` on a read-only file system (root ignores permission bits: a read-only tmpfs then)."""
    if os.geteuid() != 0:
        for p in (folder, *folder.rglob("*")):
            p.chmod(p.stat().st_mode & ~0o222)
        try:
            yield folder
        finally:
            for p in (folder, *folder.rglob("*")):
                p.chmod(p.stat().st_mode | 0o200)
        return
    mnt = folder.parent / "ro"
    mnt.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64m", "tmpfs", str(mnt)], check=True)
    try:
        shutil.copytree(folder, mnt / "C")
        subprocess.run(["mount", "-o", "remount,ro", str(mnt)], check=True)
        yield mnt / "C"
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=True)


def test_a_read_only_store_is_one_line(folder, capsys):
    with _read_only(folder) as ro:
        for cmd in (["campaign", "report", str(ro), "--no-pdf"], ["campaign", "run", str(TINY), "--out", str(ro)]):
            err = _one_line(main(cmd), capsys)
            assert str(ro) in err and ("Read-only file system" in err or "Permission denied" in err), err
        rc = main(["campaign", "status", str(ro)])  # status only reads: a read-only medium is read
        out = capsys.readouterr()
        assert (rc, out.err) == (0, ""), out
        assert "2 cases: 2 done" in out.out


def test_files_are_recorded_with_size_and_sha256(campaign):
    st = CampaignStore(campaign)
    try:
        row = st.rows()[0]
    finally:
        st.close()
    assert sorted(row["files"]) == ["inhouse.parquet", "jsbsim.parquet"]
    for name, rec in row["files"].items():
        p = campaign / "cases" / row["case_id"] / name
        assert rec["bytes"] == p.stat().st_size and len(rec["sha256"]) == 64
    assert json.loads(json.dumps(row["files"])) == row["files"]


# --- fourth round (docs/hardening.md) ------------------------------------------------------------------------


def test_status_writes_nothing_and_refuses_an_empty_or_foreign_index(tmp_path, capsys):
    for name, make in (("empty", lambda p: p.write_bytes(b"")), ("foreign", _foreign_sqlite)):
        d = tmp_path / name
        d.mkdir()
        make(d / "campaign.sqlite")
        before = (d / "campaign.sqlite").read_bytes()
        for cmd in (["campaign", "status", str(d)], ["campaign", "report", str(d), "--no-pdf"]):
            err = _one_line(main(cmd), capsys, "is no campaign index", "not a campaign folder")
            assert "\n" not in err.strip()
        assert (d / "campaign.sqlite").read_bytes() == before
        assert sorted(p.name for p in d.iterdir() if not p.name.startswith("campaign.sqlite")) == []  # no cases/


def _foreign_sqlite(path: Path) -> None:
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE t (x)")
    con.commit()
    con.close()


def test_a_linked_index_is_refused_and_never_written_through(folder, tmp_path, capsys):
    elsewhere = tmp_path / "elsewhere.sqlite"
    shutil.move(folder / "campaign.sqlite", elsewhere)
    (folder / "campaign.sqlite").symlink_to(elsewhere)
    before = elsewhere.read_bytes()
    for cmd in (
        ["campaign", "status", str(folder)],
        ["campaign", "report", str(folder), "--no-pdf"],
        ["campaign", "run", str(TINY), "--out", str(folder), "--samples", "3", "--workers", "1"],
    ):
        _one_line(main(cmd), capsys, "its index campaign.sqlite is a symbolic link")
    assert elsewhere.read_bytes() == before


def test_an_index_that_is_a_folder_is_named_so(folder, capsys):
    (folder / "campaign.sqlite").unlink()
    (folder / "campaign.sqlite").mkdir()
    _one_line(main(["campaign", "status", str(folder)]), capsys, "campaign.sqlite is a folder")


def test_resume_leaves_a_folder_of_no_case_in_cases(folder, capsys):
    mine = folder / "cases" / "my-notes"
    mine.mkdir()
    (mine / "a.txt").write_text("mine")
    stale = folder / "cases" / f".tmp-{CASE}-99"
    stale.mkdir()
    rc, _ = _run(folder, capsys)
    assert rc == 0
    assert (mine / "a.txt").read_text() == "mine"  # not the campaign's: never removed
    assert not stale.exists()  # a half-written folder of one of its cases: removed
