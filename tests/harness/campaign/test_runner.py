"""Campaign runs: store, resume, rerun of one case, backends bit for bit, faults (worker and runner killed)."""

from __future__ import annotations

import io
import json
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from gna.errors import InputError
from harness.campaign import CampaignStore, rerun_case, run_campaign
from harness.campaign.runner import parse_dask
from harness.cli import main
from harness.progress import Progress

HERE = Path(__file__).parent
TINY = HERE / "tiny.toml"
ROOT = HERE.parents[2]


def _metrics(folder) -> dict:
    st = CampaignStore(folder)
    try:
        return {r["case_id"]: json.dumps(r["metrics"], sort_keys=True) for r in st.rows()}
    finally:
        st.close()


def _check_folder(folder, n: int) -> None:
    """n cases, all done, each with its files, nothing half-written, a sound database."""
    con = sqlite3.connect(Path(folder) / "campaign.sqlite")
    try:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        rows = con.execute("SELECT case_id, status, files FROM cases").fetchall()
    finally:
        con.close()
    assert len(rows) == n == len({r[0] for r in rows})
    assert all(r[1] == "done" for r in rows)
    cases = Path(folder) / "cases"
    assert sorted(p.name for p in cases.iterdir()) == sorted(r[0] for r in rows)
    for cid, _, files in rows:
        assert (
            sorted(p.name for p in (cases / cid).iterdir())
            == sorted(json.loads(files))
            == ["inhouse.parquet", "jsbsim.parquet"]
        )
    st = CampaignStore(folder)
    try:  # each file of the size and sha256 the store recorded
        assert [st.check(r) for r in st.rows()] == [None] * n
    finally:
        st.close()


@pytest.fixture(scope="module")
def inline(tmp_path_factory):
    out = tmp_path_factory.mktemp("camp") / "inline"
    shown = io.StringIO()
    res = run_campaign(TINY, out, workers=1, quiet=True, progress=Progress("campaign run", mode="plain", stream=shown))
    assert res["computed"] == 3 and res["done"] == 3
    (out.parent / "progress.txt").write_text(shown.getvalue())  # test_progress_a_line_per_case
    return out


def test_progress_a_line_per_case(inline):
    lines = (inline.parent / "progress.txt").read_text().splitlines()
    assert lines[0].endswith("gflat campaign run: started")
    cases = [line.split(": cases ", 1)[1] for line in lines[1:4]]
    assert [c.split(":")[0] for c in cases] == ["1/3", "2/3", "3/3"]
    assert cases[-1].endswith("(3 done, 0 failed)")
    assert "campaign tiny: cases done in" in lines[4]


def test_run_status_resume_and_one_case_again(inline, capsys):
    _check_folder(inline, 3)
    assert main(["campaign", "status", str(inline), "--json"]) == 0
    status = json.loads(capsys.readouterr().out)
    assert {k: status[k] for k in ("cases", "done", "failed", "pending")} == {
        "cases": 3,
        "done": 3,
        "failed": 0,
        "pending": 0,
    }
    assert main(["campaign", "run", str(TINY), "--out", str(inline), "--quiet"]) == 0
    assert "0 computed" in capsys.readouterr().err
    again = rerun_case(inline, "level.fit.0001")
    assert again["same_as_stored"] is True
    import pandas as pd

    df = pd.read_parquet(inline / "cases" / "level.fit.0001" / "inhouse.parquet")
    assert {"x", "V", "I1"} <= set(df.columns) and df.index.name == "t"


def test_more_samples_extend_and_other_campaign_is_refused(inline, tmp_path):
    out = tmp_path / "c"
    run_campaign(TINY, out, samples=1, workers=1, quiet=True)
    res = run_campaign(TINY, out, samples=2, workers=1, quiet=True)
    assert (res["computed"], res["skipped"], res["done"]) == (1, 1, 2)
    assert _metrics(out) == {k: v for k, v in _metrics(inline).items() if k in _metrics(out)}
    other = TINY.read_text().replace("seed = 7", "seed = 8")
    (tmp_path / "tiny.toml").write_text(other)
    (tmp_path / "tiny-level.toml").write_text((HERE / "tiny-level.toml").read_text())
    assert main(["campaign", "run", str(tmp_path / "tiny.toml"), "--out", str(out), "--quiet"]) == 2


def test_failed_cases_retried_only_when_asked(tmp_path, capsys):
    """A case that passes the campaign's checks but fails while planning (the flight 20 km below sea level
    leaves the ISA model: a DomainError of the planner) is recorded failed, and run again only when asked."""
    (tmp_path / "bad.toml").write_text(TINY.read_text())
    below = (HERE / "tiny-level.toml").read_text().replace('z = "0"', 'z = "20000"')
    assert 'z = "20000"' in below
    (tmp_path / "tiny-level.toml").write_text(below)
    res = run_campaign(tmp_path / "bad.toml", tmp_path / "out", samples=1, workers=1, quiet=True)
    assert (res["failed"], res["pending"]) == (1, 0)
    assert run_campaign(tmp_path / "bad.toml", tmp_path / "out", samples=1, workers=1, quiet=True)["computed"] == 0
    again = run_campaign(tmp_path / "bad.toml", tmp_path / "out", samples=1, workers=1, quiet=True, retry_failed=True)
    assert again["computed"] == 1
    st = CampaignStore(tmp_path / "out")
    row = st.rows()[0]
    st.close()
    assert row["attempts"] == 2 and row["error"] and not (tmp_path / "out" / "cases" / row["case_id"]).exists()
    assert row["error"].startswith("DomainError") and "ISA" in row["error"]


def test_a_campaign_with_cases_pending_is_resumed_in_place(tmp_path, capsys):
    # The store's transactions are the record: a run that leaves cases pending is resumed by the same command.
    out = tmp_path / "c"
    cmd = ["campaign", "run", str(TINY), "--out", str(out), "--samples", "2", "--workers", "1", "--quiet"]
    assert main([*cmd, "--only", "level.fit.0000"]) == 1
    capsys.readouterr()
    assert main(["campaign", "status", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["pending"] == 1
    assert main(cmd) == 0
    assert main(["campaign", "status", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["pending"] == 0
    assert sorted(p.name for p in out.iterdir()) == ["campaign.sqlite", "cases"]  # no marker, no record


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl,
        distributed.Client(cl) as client,
    ):
        client.run(lambda: __import__("harness.campaign.execute"))  # gflat imported before the clock starts
        yield cl, client


def test_process_pool_and_dask_give_the_same_metrics_bit_for_bit(inline, cluster, tmp_path):
    run_campaign(TINY, tmp_path / "pool", workers=2, quiet=True)
    assert _metrics(tmp_path / "pool") == _metrics(inline)
    assert (
        main(
            [
                "campaign",
                "run",
                str(TINY),
                "--out",
                str(tmp_path / "dask"),
                "--quiet",
                "--dask",
                cluster[0].scheduler_address,
                "--dask-timeout",
                "10",
            ]
        )
        == 0
    )
    assert _metrics(tmp_path / "dask") == _metrics(inline)
    _check_folder(tmp_path / "dask", 3)


def test_dask_worker_killed_mid_campaign(inline, cluster, tmp_path):
    cl, client = cluster
    pids = list(client.run(os.getpid).values())
    out = tmp_path / "killed"
    result = {}
    runner = threading.Thread(
        target=lambda: result.update(run_campaign(TINY, out, samples=5, dask=cl.scheduler_address, quiet=True))
    )
    runner.start()
    _until(lambda: runner.is_alive() and all(client.processing().get(w) for w in client.processing()))
    os.kill(pids[0], signal.SIGKILL)  # a worker busy on a case (every worker has one in hand)
    runner.join(120)
    assert result["done"] == 5 and result["pending"] == 0 and result["failed"] == 0
    _check_folder(out, 5)
    assert {k: v for k, v in _metrics(out).items() if k in _metrics(inline)} == _metrics(inline)


def test_dask_option_parsing():
    assert parse_dask("local:2") == ("local", 2) and parse_dask("tcp://h:8786") == ("address", "tcp://h:8786")
    assert parse_dask(None) is None
    with pytest.raises(InputError, match="local:N"):
        parse_dask("local:0")
    # a host named local... is an address, not a local cluster of 8786 workers
    for address in ("localhost:8786", "tls://10.0.0.1:8786", "tcp://[::1]:8786", "ws://sched.example:80"):
        assert parse_dask(address) == ("address", address)
    for bad in ("bogus", "tcp://bogus", "foo://h:1", "h:0", "h:99999", "tcp://h:8786/x", "h: 1", ""):
        with pytest.raises(InputError) as exc:
            parse_dask(bad)
        msg = str(exc.value)
        assert repr(bad) in msg and "local:N" in msg and "HOST:PORT" in msg and "\n" not in msg


def _until(event, what: str = "the awaited event"):
    """Wait until ``event()`` is true (returned) or 300 s have passed (a failure: the event never came)."""
    deadline = time.monotonic() + 300
    while (value := event()) in (None, False, [], 0):
        assert time.monotonic() < deadline, f"{what} did not happen"
        time.sleep(0.02)
    return value


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def _cpu_s(pid: int) -> float:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _busy_children(pid: int, n: int) -> list[int]:
    """The child processes of ``pid`` once ``n`` of them have each run 0.5 s of CPU (inside a case), else []."""
    kids = [c for c in _children(pid) if _cpu_s(c) > 0.5]
    return kids if len(kids) >= n else []


def _where_waiting(pid: int) -> str:
    """Each thread's state and kernel wait channel of ``pid`` and of its children (a hang's diagnosis)."""
    out = []
    for p in [pid, *_children(pid)]:
        threads = []
        for task in sorted(Path(f"/proc/{p}/task").glob("*")):
            try:
                state = (task / "stat").read_text().rsplit(")", 1)[1].split()[0]
                threads.append(f"{task.name} {state} {(task / 'wchan').read_text() or '-'}")
            except OSError:
                continue
        out.append(f"pid {p}: " + "; ".join(threads))
    return " | ".join(out)


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _free_port() -> int:
    """A TCP port nothing listens on (bound, then released)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_bad_dask_address_or_scheduler_refused_before_the_folder_exists(tmp_path, capsys):
    """A malformed --dask and a scheduler that cannot be reached: one line, exit 2, no folder (nothing written)."""
    pytest.importorskip("distributed")
    out = tmp_path / "camp"
    assert main(["campaign", "run", str(TINY), "--out", str(out), "--samples", "1", "--dask", "bogus"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--dask 'bogus': expected local:N" in err and len(err.splitlines()) == 1
    assert not out.exists()
    address = f"tcp://127.0.0.1:{_free_port()}"
    cmd = ["campaign", "run", str(TINY), "--out", str(out), "--samples", "1", "--dask", address]
    assert main([*cmd, "--dask-timeout", "0.5"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"gflat campaign: error: cannot connect to the Dask scheduler at {address}: ")
    assert "after 0.5 s" in err  # the timeout asked for, not Dask's default
    assert len(err.splitlines()) == 1 and "cannot write" not in err
    assert not out.exists()
    with pytest.raises(InputError, match="dask-timeout"):
        run_campaign(TINY, out, dask=address, dask_timeout=0)


def test_runner_killed_with_sigkill_then_resumed(inline, tmp_path):
    out = tmp_path / "sigkill"
    cmd = [
        sys.executable,
        "-m",
        "harness.cli",
        "campaign",
        "run",
        str(TINY),
        "--out",
        str(out),
        "--samples",
        "5",
        "--workers",
        "1",
        "--quiet",
    ]
    proc = subprocess.Popen(cmd, cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 60
        done = 0
        while time.time() < deadline and done < 2:
            time.sleep(0.1)
            if (out / "campaign.sqlite").exists():
                con = sqlite3.connect(out / "campaign.sqlite", timeout=5)
                try:
                    done = con.execute("SELECT COUNT(*) FROM cases WHERE status = 'done'").fetchone()[0]
                except sqlite3.OperationalError:
                    done = 0
                finally:
                    con.close()
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(30)
    assert 2 <= done < 5
    con = sqlite3.connect(out / "campaign.sqlite")
    assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    before = dict(con.execute("SELECT case_id, metrics FROM cases WHERE status = 'done'").fetchall())
    con.close()
    res = run_campaign(TINY, out, samples=5, workers=1, quiet=True)
    assert res["skipped"] >= len(before) and res["done"] == 5
    _check_folder(out, 5)
    after = _metrics(out)
    assert all(after[k] == json.dumps(json.loads(v), sort_keys=True) for k, v in before.items())
    assert {k: v for k, v in after.items() if k in _metrics(inline)} == _metrics(inline)


def test_the_campaign_folder_is_guarded(inline, tmp_path, capsys):
    # Another command never writes over a campaign folder: it exists (no --replace), and it is no gflat run
    # (--replace removes only those) ...
    before = sorted(p.relative_to(inline) for p in inline.rglob("*"))
    assert main(["plan", "gtm-aileron-roll", "--out", str(inline)]) == 2
    assert "exists: give --replace" in capsys.readouterr().err
    assert main(["plan", "gtm-aileron-roll", "--out", str(inline), "--replace"]) == 2
    assert "is not the folder of a gflat run" in capsys.readouterr().err
    assert sorted(p.relative_to(inline) for p in inline.rglob("*")) == before
    # ... a campaign refuses a gflat run's folder or one inside it (runs are never changed), and a file
    from harness.rundir import RunDir

    with RunDir(tmp_path / "paper", command="paper") as paper:
        paper.write_text("summary.json", text="{}")
        paper.commit()
    for where, what in ((tmp_path / "paper", "is the folder"), (tmp_path / "paper" / "c", "lies inside")):
        with pytest.raises(InputError, match=what):
            run_campaign(TINY, where, workers=1, quiet=True)
    assert sorted(p.name for p in (tmp_path / "paper").iterdir()) == ["manifest.json", "summary.json"]
    with pytest.raises(InputError, match="a file of that name exists"):
        run_campaign(TINY, tmp_path / "paper" / "summary.json", workers=1, quiet=True)
    # ... and while another campaign run (or report) holds the store, a second run is refused
    from harness.campaign.store import locked

    with locked(inline), pytest.raises(InputError, match="in use by another gflat campaign run or report"):
        run_campaign(TINY, inline, workers=1, quiet=True)


def test_a_campaign_keeps_the_users_files_in_its_folder(tmp_path):
    # a file the user puts into a campaign folder stays through reruns; a non-empty folder that is no campaign
    # folder is never adopted (tests/test_hardening_outputs.py)
    folder = tmp_path / "c"
    assert run_campaign(TINY, folder, samples=1, workers=1, quiet=True)["pending"] == 0
    (folder / "notes.txt").write_text("mine")
    assert run_campaign(TINY, folder, samples=2, workers=1, quiet=True)["pending"] == 0  # a rerun, one case more
    assert (folder / "notes.txt").read_text() == "mine"


def test_the_campaign_report_is_written_whole_and_never_follows_a_link(inline, tmp_path, capsys):
    import shutil

    folder = tmp_path / "K"
    shutil.copytree(inline, folder)
    assert main(["campaign", "report", str(folder), "--no-pdf"]) == 0
    manifest = json.loads((folder / "report" / "manifest.json").read_text())
    assert manifest["command"] == "campaign report" and "index.html" in [f["path"] for f in manifest["files"]]
    first = manifest["run_id"]
    assert main(["campaign", "report", str(folder), "--no-pdf"]) == 0  # the earlier report replaced whole
    assert json.loads((folder / "report" / "manifest.json").read_text())["run_id"] != first
    assert not [p for p in folder.iterdir() if p.name.startswith(".report")]  # no staging left
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("keep")
    shutil.rmtree(folder / "report")
    (folder / "report").symlink_to(elsewhere)
    capsys.readouterr()
    assert main(["campaign", "report", str(folder), "--no-pdf"]) == 2
    assert "is a symbolic link" in capsys.readouterr().err
    assert sorted(p.name for p in elsewhere.iterdir()) == ["keep.txt"]


@pytest.mark.parametrize("answer", ["bytes", "silence"])
def test_an_address_where_no_dask_scheduler_answers_is_one_line(tmp_path, capsys, monkeypatch, answer):
    # Something else listens there: it answers bytes Dask reads as an absurd message size, or never answers.
    import socket

    import harness.campaign.runner as runner

    pytest.importorskip("distributed")
    monkeypatch.setattr(runner, "CONNECT_MARGIN_S", 0.5)
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    held = []

    def serve():
        while True:
            try:
                c, _ = srv.accept()
            except OSError:
                return
            if answer == "bytes":
                c.sendall(b"HTTP/1.0 200 OK\r\n\r\nnot dask" * 4)
                c.close()
            else:
                held.append(c)

    threading.Thread(target=serve, daemon=True).start()
    try:
        port = srv.getsockname()[1]
        code = main(
            [
                "campaign",
                "run",
                str(TINY),
                "--out",
                str(tmp_path / "c"),
                "--quiet",
                "--dask",
                f"tcp://127.0.0.1:{port}",
                "--dask-timeout",
                "1",
            ]
        )
    finally:
        srv.close()
        for c in held:
            c.close()
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert f"cannot connect to the Dask scheduler at tcp://127.0.0.1:{port}" in err
    assert not (tmp_path / "c").exists()


def test_ctrl_c_in_a_process_pool_ends_at_once_and_the_run_resumes(tmp_path):
    # Ctrl-C while the pool's workers run cases: exit 130 within seconds (the running workers are ended, the
    # queued cases dropped, not waited for), cases committed before stay; a rerun computes the rest.
    out = tmp_path / "ctrlc"
    cmd = [
        sys.executable,
        "-m",
        "harness.cli",
        "campaign",
        "run",
        "paper-dispersions",
        "--out",
        str(out),
        "--samples",
        "3",
        "--workers",
        "2",
        "--quiet",
    ]
    proc = subprocess.Popen(
        cmd, cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    try:
        workers = _until(lambda: _busy_children(proc.pid, 2))  # the two workers inside their first cases
        proc.send_signal(signal.SIGINT)  # to gflat alone (`timeout -s INT`, `kill -INT`): the
        #                                                   workers go on unless gflat ends them
        try:
            code = proc.wait(120)
        except subprocess.TimeoutExpired:  # a hang seen once under load: say where each process waits
            pytest.fail(f"gflat still running 120 s after SIGINT: {_where_waiting(proc.pid)}")
        alive = [w for w in workers if _alive(w)]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(30)
    err = proc.stderr.read()
    assert code == 130 and "interrupted" in err and "Traceback" not in err
    assert alive == []  # the running workers were ended with gflat, not left to finish their cases
    con = sqlite3.connect(out / "campaign.sqlite")
    try:
        statuses = [r[0] for r in con.execute("SELECT status FROM cases")]
    finally:
        con.close()
    assert len(statuses) == 9 and "pending" in statuses  # what a rerun computes
    from harness.campaign.store import locked

    with locked(out):  # the store is free again: the lock went with the process
        pass


_CAMPAIGN_HOLDER = r"""
import sys
from harness.campaign.store import locked
with locked(sys.argv[1]):
    print("holding", flush=True)
    sys.stdin.readline()
"""


def test_the_report_of_a_campaign_being_written_is_refused(inline, tmp_path):
    """``gflat campaign report K`` while ``gflat campaign run --out K`` runs: one line, exit 2, nothing written."""
    import shutil

    folder = tmp_path / "K"
    shutil.copytree(inline, folder)
    before = sorted(p for p in folder.rglob("*"))
    holder = subprocess.Popen(
        [sys.executable, "-c", _CAMPAIGN_HOLDER, str(folder)],
        cwd=ROOT,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline() == "holding\n"
        out = subprocess.run(
            [sys.executable, "-m", "harness.cli", "campaign", "report", str(folder), "--no-pdf"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        holder.communicate("\n", timeout=60)
    assert out.returncode == 2, out.stderr
    assert out.stderr == (
        f"gflat campaign: error: campaign folder {folder} is in use by another gflat campaign run or report: "
        f"wait for it to end\n"
    )
    assert sorted(p for p in folder.rglob("*")) == before


def test_a_local_dask_cluster_keeps_its_scratch_files_in_the_campaign_folder(tmp_path):
    pytest.importorskip("distributed")
    tmp = tmp_path / "tmp"  # Dask's default scratch folder: $TMPDIR/dask-scratch-space
    tmp.mkdir()
    out = tmp_path / "camp"
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "harness.cli",
            "campaign",
            "run",
            str(TINY),
            "--out",
            str(out),
            "--samples",
            "1",
            "--dask",
            "local:1",
            "--quiet",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "TMPDIR": str(tmp)},
    )
    assert res.returncode == 0, res.stderr
    assert list(tmp.iterdir()) == []  # nothing outside the campaign folder
    assert not (out / ".dask-scratch").exists()  # removed when the cluster ended


def _case_waits(task):
    """A case that takes as long as the test wants: it waits on the file named by the task, a case's
    ``finally`` recorded in that file (the case unwound)."""
    path = Path(task)
    try:
        path.write_text("running")
        while True:
            time.sleep(0.01)
    finally:
        path.write_text("unwound")


@pytest.mark.parametrize("in_case", [True, False], ids=["in-a-case", "waiting-for-one"])
def test_a_pool_worker_ended_by_the_runner_leaves_at_once(tmp_path, monkeypatch, in_case):
    # The runner ends its workers with SIGTERM (_end_workers). Forked inside InterruptsWait (as _local_pool
    # does), a worker inherited handlers that only record the signal: it went on with its case until killed
    # WORKER_END_S later (a Ctrl-C of a campaign took 10-20 s to end). It must leave by the signal itself, after
    # the case's finally blocks ran, or at once when it waits for a case (where a Python handler could wait
    # forever: the signal may reach the queue-feeding thread while the main thread is blocked reading the queue).
    from concurrent.futures import ProcessPoolExecutor

    import harness.campaign.runner as runner
    from harness.cli import _signals_raise
    from harness.parallel import InterruptsWait

    monkeypatch.setattr(runner, "run_sample", _case_waits)  # inherited by the forked worker
    mark = tmp_path / "case"
    with _signals_raise():  # the worker forked as under `gflat campaign run` (runner._local_pool)
        pool = ProcessPoolExecutor(max_workers=1, initializer=runner._worker_starts)
        with InterruptsWait():
            started = pool.submit(int, 0)
        started.result()
    try:
        if in_case:
            pool.submit(runner._case_in_worker, str(mark))
            _until(lambda: mark.exists() and mark.read_text() == "running", "the case's start")
        # else: the worker started, now waiting for a case
        (proc,) = pool._processes.values()
        proc.terminate()
        proc.join(300)  # ends on the process's end; a worker that stayed would be killed by the runner
        assert not _alive(proc.pid)  # ended by the signal alone (nothing else ends it here)
        # in a case: 143, the worker's own exit once the case unwound; waiting for one: the signal's default
        # action. None: the pool's manager thread reaped the worker first (it waits for its workers too).
        assert proc.exitcode in (143 if in_case else -signal.SIGTERM, None), proc.exitcode
        if in_case:
            assert mark.read_text() == "unwound"
    finally:
        for p in list(getattr(pool, "_processes", {}).values()):
            p.kill()
        pool.shutdown(wait=False, cancel_futures=True)
