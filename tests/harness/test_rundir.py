"""A run's folder appears complete or not at all (harness.rundir.RunDir), in process and through the command line.

The command-line tests run ``python -m harness.cli`` in a subprocess that stops itself (SIGSTOP, from a Python
audit hook) at a chosen event -- the staging folder about to be made, a file of the run about to be written,
``manifest.json`` about to be written, the swapped-out old run about to be removed -- and is then killed with
SIGKILL: a wait on the event, never on time.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gna.errors import InputError
from harness.rundir import MANIFEST, RunDir, check_output_file, write_file

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = "twin-otter-single-engine"


def _tree(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` -> its sha256."""
    return {
        p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _matches_manifest(folder: Path) -> None:
    """The folder holds exactly the files its manifest lists, with their sha256 and sizes."""
    data = json.loads((folder / MANIFEST).read_text())
    assert data["tool"] == "gflat" and data["run_id"]
    listed = {f["path"]: f["sha256"] for f in data["files"]}
    assert [f["path"] for f in data["files"]] == sorted(listed)
    tree = _tree(folder)
    tree.pop(MANIFEST)
    assert tree == listed
    for f in data["files"]:
        assert (folder / f["path"]).stat().st_size == f["bytes"]


def _visible(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if not p.name.startswith("."))


def _staging(parent: Path, name: str = "D") -> list[Path]:
    return sorted(parent.glob(f".{name}.gflat-*.tmp"))


# ---- in process ----------------------------------------------------------------------------------------------


@pytest.fixture(params=["renameat2", "two renames"])
def renames(request, monkeypatch):
    """Linux's renameat2, and the checked renames used where the system has none."""
    import harness.rundir

    if request.param != "renameat2":
        monkeypatch.setattr(harness.rundir, "_renameat2", lambda *args: False)
    return request.param


def test_commit_puts_the_folder_in_place_with_the_manifest_last(tmp_path):
    out = tmp_path / "D"
    with RunDir(out, command="plan") as run:
        assert run.out == out and run.root.parent == tmp_path and run.root.name.startswith(".D.gflat-")
        run.write_text("b.txt", text="b")
        run.write_bytes("sub", "a.bin", data=b"\x00\x01")
        run.write_json("c.json", obj={"x": np.float64(1.5), "n": np.arange(2)})
        assert run.sub("empty", "deeper").is_dir()
        assert not out.exists()  # nothing visible before the commit
        assert run.commit({"command_line": ["gflat", "plan"], "files": "ignored"}) == out
    assert _staging(tmp_path) == [] and _visible(tmp_path) == ["D"]
    data = json.loads((out / MANIFEST).read_text())
    assert data["command"] == "plan" and data["command_line"] == ["gflat", "plan"] and data["date_utc"]
    assert [f["path"] for f in data["files"]] == ["b.txt", "c.json", "sub/a.bin"]
    assert json.loads((out / "c.json").read_text()) == {"x": 1.5, "n": [0, 1]}
    _matches_manifest(out)


@pytest.mark.parametrize("parts", [("..", "x"), ("/etc/passwd",), ("a", "..", "..", "x"), (), ("",), (MANIFEST,)])
def test_paths_stay_in_the_run(tmp_path, parts):
    with RunDir(tmp_path / "D", command="plan") as run, pytest.raises(InputError):
        run.path(*parts)


def test_json_refuses_nan(tmp_path):
    with RunDir(tmp_path / "D", command="plan") as run, pytest.raises(InputError, match="as JSON"):
        run.write_json("x.json", obj={"v": float("nan")})


@pytest.mark.parametrize("how", [RuntimeError, KeyboardInterrupt])
def test_leaving_without_commit_removes_the_staging_folder(tmp_path, how):
    with pytest.raises(how), RunDir(tmp_path / "D", command="plan") as run:
        run.write_text("a.txt", text="a")
        raise how("stop")
    assert list(tmp_path.iterdir()) == []


def test_an_existing_folder_is_refused_without_replace(tmp_path):
    (tmp_path / "D").mkdir()
    (tmp_path / "D" / "mine.txt").write_text("keep")
    with pytest.raises(InputError, match=r"output folder .*D exists: give --replace"):
        RunDir(tmp_path / "D", command="plan")
    with pytest.raises(InputError, match="not the folder of a gflat run"):  # no manifest: never removed
        RunDir(tmp_path / "D", command="plan", replace=True)
    assert (tmp_path / "D" / "mine.txt").read_text() == "keep" and _staging(tmp_path) == []


def test_replace_swaps_a_run_and_never_removes_a_foreign_file(tmp_path, renames):
    with RunDir(tmp_path / "D", command="plan") as run:
        run.write_text("old.txt", text="old")
        run.commit()
    (tmp_path / "D" / "notes.txt").write_text("the user's")
    with pytest.raises(InputError, match="holds notes.txt, which is not a file of its gflat run"):
        RunDir(tmp_path / "D", command="plan", replace=True)
    (tmp_path / "D" / "notes.txt").unlink()
    with RunDir(tmp_path / "D", command="plan", replace=True) as run:
        run.write_text("new.txt", text="new")
        assert (tmp_path / "D" / "old.txt").is_file()  # the old run stays until the new one is complete
        run.commit()
    assert sorted(p.name for p in (tmp_path / "D").iterdir()) == [MANIFEST, "new.txt"]
    assert _staging(tmp_path) == []


def test_other_refusals(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="a file of that name exists"):
        RunDir(tmp_path / "f", command="plan", replace=True)
    with pytest.raises(InputError, match="its parent folder .* does not exist"):
        RunDir(tmp_path / "no" / "D", command="plan")
    with RunDir(tmp_path / "made" / "D", command="plan", parents=True) as run:
        run.commit()
    with pytest.raises(InputError, match="lies inside .*made/D, the folder of a gflat run"):
        RunDir(tmp_path / "made" / "D" / "case", command="plan", parents=True)
    (tmp_path / "link").symlink_to(tmp_path / "made" / "D")
    with pytest.raises(InputError, match="is a symbolic link"):
        RunDir(tmp_path / "link", command="plan", replace=True)
    with pytest.raises(InputError, match="a file-system root"):
        RunDir("/", command="plan", replace=True)


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no procfs")
def test_a_folder_that_takes_no_files_is_refused():
    with pytest.raises(InputError, match="cannot write in /proc: /proc exists, but its file system creates no new"):
        RunDir("/proc/gflat-x", command="plan")


def test_stale_staging_is_removed_and_a_running_one_kept(tmp_path):
    stale = tmp_path / ".D.gflat-0123456789ab.tmp"
    (stale / "sub").mkdir(parents=True)
    (stale / "sub" / "x").write_text("left by a killed run")
    other = tmp_path / ".other.gflat-0123456789ab.tmp"  # another folder's staging: not this run's business
    other.mkdir()
    with RunDir(tmp_path / "D", command="plan") as running:
        with RunDir(tmp_path / "D", command="plan") as second:  # a concurrent run into the same folder
            assert not stale.exists() and running.root.is_dir() and other.is_dir()
            assert sorted(_staging(tmp_path)) == sorted([running.root, second.root])


def test_of_two_runs_into_one_new_folder_the_first_to_finish_wins(tmp_path, renames):
    with RunDir(tmp_path / "D", command="plan") as a, RunDir(tmp_path / "D", command="plan") as b:
        a.write_text("who", text="a")
        b.write_text("who", text="b")
        b.commit()
        with pytest.raises(InputError, match="written by another run meanwhile"):
            a.commit()
    assert (tmp_path / "D" / "who").read_text() == "b" and _staging(tmp_path) == []


def test_of_two_replacing_runs_the_first_to_finish_wins(tmp_path, renames):
    with RunDir(tmp_path / "D", command="plan") as run:
        run.commit()
    with (
        RunDir(tmp_path / "D", command="plan", replace=True) as a,
        RunDir(tmp_path / "D", command="plan", replace=True) as b,
    ):
        a.write_text("who", text="a")
        b.write_text("who", text="b")
        a.commit()
        with pytest.raises(InputError, match="replaced by another run meanwhile"):
            b.commit()  # swapped back: a's run stays
    assert (tmp_path / "D" / "who").read_text() == "a" and _staging(tmp_path) == []
    _matches_manifest(tmp_path / "D")


def test_default_folders_are_replaced_only_when_they_are_gflat_runs(tmp_path, monkeypatch):
    from harness.commands import _output

    monkeypatch.setattr(_output, "DEFAULT_ROOT", tmp_path / "reports" / "out")
    for text in ("first", "second"):  # no --replace needed: the tool owns its default folders
        with _output.default_out("s", "plan", command="plan") as run:
            run.write_text("x.txt", text=text)
            run.commit()
    folder = tmp_path / "reports" / "out" / "s" / "plan"
    assert (folder / "x.txt").read_text() == "second"
    (folder / "mine.txt").write_text("the user's")
    with pytest.raises(InputError, match="holds mine.txt"):
        _output.default_out("s", "plan", command="plan")
    with pytest.raises(InputError, match="leaves"):
        _output.default_out("..", "..", command="plan")


def test_single_files(tmp_path):
    p = write_file(tmp_path / "a.toml", "x = 1\n")
    assert p.read_text() == "x = 1\n" and sorted(os.listdir(tmp_path)) == ["a.toml"]
    assert check_output_file(tmp_path / "a.toml") == tmp_path / "a.toml"
    with pytest.raises(InputError, match="not a regular file"):
        check_output_file(tmp_path)
    with RunDir(tmp_path / "D", command="plan") as run:
        run.commit()
    with pytest.raises(InputError, match="folder of a gflat run"):
        check_output_file(tmp_path / "D" / "a.toml")
    with pytest.raises(InputError, match="No such file or directory"):
        check_output_file(tmp_path / "none" / "a.toml")


# ---- the command line, killed at chosen moments -------------------------------------------------------------

#: Runs the CLI with an audit hook that stops the process (SIGSTOP) at the STOP_COUNT-th (default first) event
#: EVENT on a path matching GLOB (for "open": opened for writing; GLOB empty: any such event).
DRIVER = """
import fnmatch, os, runpy, signal, sys
event, pattern, hit = os.environ["STOP_EVENT"], os.environ["STOP_AT"], []
count, pid = int(os.environ.get("STOP_COUNT", "1")), os.getpid()
def hook(name, args):
    if len(hit) >= count or name != event or os.getpid() != pid:  # a forked worker never stops
        return
    if pattern:  # an event on a path (none: any event of that name, e.g. os.fork)
        if not args or not isinstance(args[0], (str, bytes, os.PathLike)):
            return
        if name == "open" and not (isinstance(args[1], str) and any(c in args[1] for c in "wxa")):
            return
        if not fnmatch.fnmatch(os.fsdecode(args[0]), pattern):
            return
    hit.append(1)
    if len(hit) == count:
        os.kill(os.getpid(), signal.SIGSTOP)
sys.addaudithook(hook)
sys.argv = ["gflat", *sys.argv[1:]]
runpy.run_module("harness.cli", run_name="__main__")
"""


def _hangup_default() -> None:
    """SIGHUP as a terminal's session gives it, also when the suite runs under ``nohup`` (inherited ignored)."""
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


def _start(tmp_path, args, event="none", at="", name="run", preexec_fn=_hangup_default, **extra):
    driver = tmp_path / "driver.py"
    driver.write_text(DRIVER)
    env = dict(os.environ, PYTHONPATH=str(ROOT), STOP_EVENT=event, STOP_AT=at, MPLBACKEND="Agg", **extra)
    out, err = (open(tmp_path / f"{name}.{k}", "w") for k in ("out", "err"))
    with out, err:
        return subprocess.Popen(
            [sys.executable, str(driver), *map(str, args)],
            cwd=tmp_path,
            env=env,
            stdout=out,
            stderr=err,
            preexec_fn=preexec_fn,
        )


def _stopped(proc) -> None:
    """Wait until ``proc`` stops itself at its event (fails if it ends instead)."""
    _, status = os.waitpid(proc.pid, os.WUNTRACED)
    assert os.WIFSTOPPED(status), f"the run ended (status {status}) before its stop event"


def _kill_at(tmp_path, args, event, at) -> None:
    proc = _start(tmp_path, args, event, at)
    _stopped(proc)
    proc.send_signal(signal.SIGKILL)
    assert proc.wait() == -signal.SIGKILL


def _run(tmp_path, args, name="run") -> tuple[int, str]:
    proc = _start(tmp_path, args, name=name)
    rc = proc.wait()
    return rc, (tmp_path / f"{name}.err").read_text()


@pytest.fixture(scope="module")
def old_run(tmp_path_factory) -> Path:
    """A complete ``gflat compare`` run, copied by each test that needs one."""
    where = tmp_path_factory.mktemp("old")
    rc, err = _run(where, ["compare", SCENARIO, "--out", where / "D"])
    assert rc == 0, err
    return where / "D"


def _copy(old_run, tmp_path) -> tuple[Path, dict]:
    d = tmp_path / "runs" / "D"
    d.parent.mkdir()
    shutil.copytree(old_run, d, symlinks=True)
    return d, _tree(d)


MOMENTS = {
    "before the staging folder exists": ("os.mkdir", "*/.D.gflat-*.tmp"),
    "while its files are written": ("open", "*/.D.gflat-*.tmp/differences.txt"),
    "right at the commit": ("open", f"*/.D.gflat-*.tmp/{MANIFEST}"),
}


@pytest.mark.parametrize("moment", MOMENTS)
def test_a_killed_compare_leaves_no_folder_and_the_next_run_removes_its_staging(tmp_path, moment):
    runs = tmp_path / "runs"
    runs.mkdir()
    _kill_at(tmp_path, ["compare", SCENARIO, "--out", runs / "D"], *MOMENTS[moment])
    assert _visible(runs) == []  # no D, nothing visible
    assert len(_staging(runs)) == (0 if moment.startswith("before") else 1)
    rc, err = _run(tmp_path, ["compare", SCENARIO, "--out", runs / "D"])
    assert rc == 0, err
    assert _visible(runs) == ["D"] and _staging(runs) == []
    _matches_manifest(runs / "D")


def test_an_existing_folder_is_refused_in_one_line_and_left_unchanged(old_run, tmp_path):
    d, before = _copy(old_run, tmp_path)
    rc, err = _run(tmp_path, ["compare", SCENARIO, "--out", d])
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "exists: give --replace" in err
    assert _tree(d) == before and _staging(d.parent) == []


@pytest.mark.parametrize("moment", ["while its files are written", "right at the commit"])
def test_a_killed_replacing_run_leaves_the_old_folder_complete_and_unchanged(old_run, tmp_path, moment):
    d, before = _copy(old_run, tmp_path)
    _kill_at(tmp_path, ["compare", SCENARIO, "--out", d, "--replace"], *MOMENTS[moment])
    assert _tree(d) == before and _visible(d.parent) == ["D"]
    _matches_manifest(d)
    rc, err = _run(tmp_path, ["compare", SCENARIO, "--out", d, "--replace"])
    assert rc == 0, err
    assert _staging(d.parent) == [] and _tree(d) != before
    _matches_manifest(d)


def test_a_run_killed_after_the_swap_leaves_the_new_folder_complete(old_run, tmp_path):
    d, before = _copy(old_run, tmp_path)
    # the old run, swapped out to the staging path, about to be removed
    _kill_at(tmp_path, ["compare", SCENARIO, "--out", d, "--replace"], "shutil.rmtree", "*/.D.gflat-*.tmp")
    _matches_manifest(d)
    assert (
        json.loads((d / MANIFEST).read_text())["run_id"] != json.loads(old_run.joinpath(MANIFEST).read_text())["run_id"]
    )
    (left,) = _staging(d.parent)
    assert _tree(left) == before  # the old run, hidden
    rc, err = _run(tmp_path, ["report", d, "--no-pdf"])  # the next run into D removes it
    assert rc == 0, err
    assert _staging(d.parent) == []


def test_of_two_concurrent_runs_into_one_new_folder_one_wins(tmp_path):
    runs = tmp_path / "runs"
    runs.mkdir()
    args = ["compare", SCENARIO, "--out", runs / "D"]
    a = _start(tmp_path, args, "open", f"*/.D.gflat-*.tmp/{MANIFEST}", name="a")
    b = _start(tmp_path, args, "open", f"*/.D.gflat-*.tmp/{MANIFEST}", name="b")
    _stopped(a)
    _stopped(b)  # both complete but for their manifests
    a.send_signal(signal.SIGCONT)
    assert a.wait() == 0, (tmp_path / "a.err").read_text()
    b.send_signal(signal.SIGCONT)
    assert b.wait() != 0
    err = (tmp_path / "b.err").read_text().strip().splitlines()
    assert len(err) == 1 and "written by another run meanwhile" in err[0]
    assert _visible(runs) == ["D"] and _staging(runs) == []
    _matches_manifest(runs / "D")


def test_a_killed_report_leaves_the_run_as_it_was(old_run, tmp_path):
    d, before = _copy(old_run, tmp_path)
    _kill_at(tmp_path, ["report", d / "plan", "--no-pdf"], "open", "*/.D.gflat-*.tmp/index.html")
    assert _tree(d) == before
    _matches_manifest(d)
    rc, err = _run(tmp_path, ["report", d, "--no-pdf", "--self-contained"])
    assert rc == 0, err
    _matches_manifest(d)
    assert (d / "report.html").is_file() and _staging(d.parent) == []


def test_replace_of_a_folder_holding_a_users_file_is_refused(old_run, tmp_path):
    d, _ = _copy(old_run, tmp_path)
    (d / "plan" / "my-notes.txt").write_text("mine")
    before = _tree(d)
    rc, err = _run(tmp_path, ["compare", SCENARIO, "--out", d, "--replace"])
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "plan/my-notes.txt" in err
    assert _tree(d) == before and _staging(d.parent) == []
    rc, err = _run(tmp_path, ["report", d, "--no-pdf"])  # nor is it re-rendered
    assert rc == 2 and "plan/my-notes.txt" in err and _tree(d) == before


def test_ctrl_c_removes_the_staging_folder(tmp_path):
    runs = tmp_path / "runs"
    runs.mkdir()
    proc = _start(tmp_path, ["compare", SCENARIO, "--out", runs / "D"], *MOMENTS["while its files are written"])
    _stopped(proc)
    assert len(_staging(runs)) == 1
    proc.send_signal(signal.SIGINT)  # delivered when it runs again
    proc.send_signal(signal.SIGCONT)
    assert proc.wait() == 130
    assert list(runs.iterdir()) == []  # no D, no staging folder


# ---- SIGTERM, handled as Ctrl-C (exit status 143) -----------------------------------------------------------


#: The exit status and the last line of an interruption by each signal.
ENDINGS = {
    signal.SIGINT: (130, "interrupted"),
    signal.SIGTERM: (143, "terminated (SIGTERM)"),
    signal.SIGHUP: (129, "hung up (SIGHUP)"),
}


def _terminated(proc, tmp_path, name="run", signals=(signal.SIGTERM,)) -> None:
    """Send ``signals`` to the stopped ``proc``, let it run on, and check it ends as interrupted by one of them
    (the one Python handles first), in one line."""
    for s in signals:  # delivered when it runs again
        proc.send_signal(s)
    proc.send_signal(signal.SIGCONT)
    rc = proc.wait()
    err = (tmp_path / f"{name}.err").read_text().strip().splitlines()
    assert (rc, err[-1].removeprefix("gflat: ")) in {ENDINGS[s] for s in signals}, (rc, err)
    assert not any("Traceback" in e for e in err)


def _token_processes(token: str) -> list[str]:
    """The processes whose environment holds ``token`` (workers left behind)."""
    left = []
    for p in Path("/proc").glob("[0-9]*"):
        try:
            if token.encode() in (p / "environ").read_bytes():
                left.append(p.name)
        except OSError:
            continue
    return left


@pytest.mark.parametrize("moment", MOMENTS)
def test_sigterm_removes_the_staging_folder_at_any_moment(tmp_path, moment):
    runs = tmp_path / "runs"
    runs.mkdir()
    proc = _start(tmp_path, ["compare", SCENARIO, "--out", runs / "D"], *MOMENTS[moment])
    _stopped(proc)
    assert len(_staging(runs)) == (0 if moment.startswith("before") else 1)
    _terminated(proc, tmp_path)
    assert list(runs.iterdir()) == []  # no D, no staging folder


def test_sigterm_during_a_replacing_run_leaves_the_old_folder_as_it_was(old_run, tmp_path):
    d, before = _copy(old_run, tmp_path)
    proc = _start(tmp_path, ["compare", SCENARIO, "--out", d, "--replace"], *MOMENTS["right at the commit"])
    _stopped(proc)
    _terminated(proc, tmp_path)
    assert _tree(d) == before and _visible(d.parent) == ["D"] and _staging(d.parent) == []


def test_sigterm_at_the_swap_waits_for_it_to_end(old_run, tmp_path):
    # the old run, swapped out to the staging path, about to be removed: the signal waits until it is
    d, before = _copy(old_run, tmp_path)
    proc = _start(tmp_path, ["compare", SCENARIO, "--out", d, "--replace"], "shutil.rmtree", "*/.D.gflat-*.tmp")
    _stopped(proc)
    _terminated(proc, tmp_path)
    _matches_manifest(d)
    assert _tree(d) != before and _staging(d.parent) == [] and _visible(d.parent) == ["D"]


def test_sigterm_ends_the_worker_processes_too(tmp_path):
    # gflat paper --jobs 2 stopped before it forks its second worker (the first one planning), then SIGTERM: the
    # workers are ended and joined before gflat exits; none is left (each carries the token in its environment)
    token = f"gflat-test-{os.getpid()}-{tmp_path.name}"
    runs = tmp_path / "runs"
    runs.mkdir()
    proc = _start(
        tmp_path,
        ["paper", "--loop", "open", "--jobs", "2", "--out", runs / "D"],
        "os.fork",
        "",
        STOP_COUNT="2",
        GFLAT_TEST_TOKEN=token,
    )
    _stopped(proc)
    _terminated(proc, tmp_path)
    assert list(runs.iterdir()) == [] and _token_processes(token) == []


@pytest.mark.parametrize(
    "signals",
    [(signal.SIGTERM, signal.SIGINT), (signal.SIGINT, signal.SIGINT, signal.SIGTERM), (signal.SIGHUP,)],
    ids=["term-int", "int-int-term", "hup"],
)
def test_a_second_signal_waits_for_the_first_ones_cleanup(tmp_path, signals):
    runs = tmp_path / "runs"
    runs.mkdir()
    proc = _start(tmp_path, ["compare", SCENARIO, "--out", runs / "D"], *MOMENTS["while its files are written"])
    _stopped(proc)
    _terminated(proc, tmp_path, signals=signals)
    assert list(runs.iterdir()) == []


def test_an_ignored_sighup_stays_ignored(tmp_path):
    # under nohup: the run goes on and completes
    runs = tmp_path / "runs"
    runs.mkdir()
    proc = _start(
        tmp_path,
        ["compare", "gtm-aileron-roll", "--out", runs / "D"],
        *MOMENTS["while its files are written"],
        preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN),
    )
    _stopped(proc)
    proc.send_signal(signal.SIGHUP)
    proc.send_signal(signal.SIGCONT)
    assert proc.wait() in (0, 1), (tmp_path / "run.err").read_text()
    assert _visible(runs) == ["D"] and _staging(runs) == []
    _matches_manifest(runs / "D")


def test_sigterm_during_a_campaign_ends_its_workers_and_the_rerun_resumes(tmp_path):
    # stopped before the pool forks its second worker process (the first one running a case)
    token = f"gflat-test-{os.getpid()}-{tmp_path.name}"
    spec = ROOT / "tests" / "harness" / "campaign" / "tiny.toml"
    for f in ("tiny.toml", "tiny-level.toml"):
        shutil.copy(spec.parent / f, tmp_path / f)
    args = ["campaign", "run", tmp_path / "tiny.toml", "--out", tmp_path / "C", "--samples", "2", "--workers", "2"]
    proc = _start(tmp_path, args, "os.fork", "", STOP_COUNT="2", GFLAT_TEST_TOKEN=token)
    _stopped(proc)
    _terminated(proc, tmp_path)
    assert _token_processes(token) == []
    rc, err = _run(tmp_path, [*args, "-q"], name="rerun")
    assert rc == 0, err
    assert "0 pending of 2" in err
