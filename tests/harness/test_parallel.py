"""Worker processes of ``gflat paper``: results, errors and files as in one process; the open-loop run reused."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gna.errors import DomainError, GflatError, InputError
from harness.parallel import ForkPool, run_all
from harness.validation import ValidationCase, run_case

from .test_validation import short_scenario  # noqa: F401  (fixture)


class _Unpicklable(Exception):
    def __init__(self, message, extra):
        super().__init__(message)
        self.extra = lambda: extra


def _raise(exc):
    def fn():
        raise exc

    return fn


@pytest.mark.parametrize("jobs", [1, 2])
def test_pool_returns_every_result_and_raises_the_workers_errors(jobs):
    big = np.arange(100_000.0)
    with ForkPool(jobs) as pool:
        for i in range(5):
            pool.submit(i, lambda i=i: (i, os.getpid(), big.sum()), priority=i, what=f"task {i}")
        got = {}
        while pool.pending:
            key, value = pool.next_result()
            got[key] = value
    assert sorted(got) == list(range(5)) and all(v[0] == k and v[2] == big.sum() for k, v in got.items())
    assert (len({v[1] for v in got.values()} - {os.getpid()}) > 0) == (jobs > 1)
    assert [t["what"] for t in pool.log] and all(t["wall_s"] >= 0 for t in pool.log)
    with ForkPool(jobs) as pool:
        pool.submit("a", _raise(DomainError("x left the domain at t = 1 s")))
        with pytest.raises(DomainError, match="left the domain at t = 1 s"):
            pool.next_result()


@pytest.mark.parametrize("jobs", [1, 2])
def test_held_submissions_start_highest_priority_first(jobs):
    """Submitted inside held(), nothing starts before the block ends; then the highest priorities first."""
    with ForkPool(jobs) as pool:
        with pool.held():
            for i, p in enumerate((1.0, 5.0, -0.5, 3.0, 4.0)):
                pool.submit(i, lambda i=i: i, priority=p, what=f"task {i}")
            assert pool.pending == 5 and not pool._running
        assert {v[1] for v in pool._running.values()} == ({1, 4} if jobs > 1 else set())
        got = []
        while pool.pending:
            got.append(pool.next_result()[0])
    assert sorted(got) == list(range(5))
    if jobs == 1:  # in this process: exactly in the order of the priorities
        assert got == [1, 4, 3, 0, 2]


def test_poll_collects_the_finished_workers_and_starts_the_next():
    """poll() takes a finished worker's place at once; its results (and errors) come from next_result."""
    with ForkPool(2) as pool:
        with pool.held():
            for i in range(4):
                pool.submit(i, (lambda i=i: i) if i != 1 else _raise(DomainError("left at t = 3 s")), priority=-i)
        deadline = time.monotonic() + 60.0
        while len(pool._done) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
            pool.poll()
        assert len(pool._done) >= 2 and pool.pending == 4 and not pool._queue  # tasks 2 and 3 started
        got, errors = [], []
        while pool.pending:
            try:
                got.append(pool.next_result()[0])
            except DomainError as exc:
                errors.append(str(exc))
    assert sorted(got) == [0, 2, 3] and errors == ["left at t = 3 s"]
    pool.poll()  # nothing running: nothing to do


@pytest.mark.parametrize("jobs", [1, 2])
def test_start_ahead_runs_one_more_while_the_caller_is_busy(jobs):
    with ForkPool(jobs) as pool:
        with pool.held():
            for i in range(5):
                pool.submit(i, lambda i=i: i, priority=-i)
        pool.start_ahead()
        assert len(pool._running) == (jobs + 1 if jobs > 1 else 0)
        assert {v[1] for v in pool._running.values()} == (set(range(jobs + 1)) if jobs > 1 else set())
        got = []
        while pool.pending:
            got.append(pool.next_result()[0])
            assert len(pool._running) <= max(jobs + 1, 1)
    assert sorted(got) == list(range(5))


def test_errors_that_do_not_pickle_or_a_dying_worker_are_one_clear_error():
    with ForkPool(2) as pool:
        pool.submit("a", _raise(_Unpicklable("bad thing at t = 2 s", 3)))
        with pytest.raises(Exception, match="bad thing at t = 2 s"):
            pool.next_result()
        pool.submit("b", lambda: os._exit(3), what="flying the test case")
        with pytest.raises(GflatError, match=r"exit code 3\) while flying the test case"):
            pool.next_result()
    with pytest.raises(InputError, match="at least 1"):
        ForkPool(0)


def test_closed_loop_reuses_the_open_cases_run(short_scenario):  # noqa: F811
    open_case = run_case(ValidationCase(str(short_scenario)))
    closed = ValidationCase(str(short_scenario), loop="closed")
    reused = run_case(closed, plan=open_case.plan, scenario=open_case.scenario, open_loop=open_case.runs["inhouse"])
    flown = run_case(closed, plan=open_case.plan, scenario=open_case.scenario)
    assert reused.open_loop is open_case.runs["inhouse"]
    assert flown.open_loop.df.equals(reused.open_loop.df)
    assert json.dumps(reused.verdict()["runs"]) == json.dumps(flown.verdict()["runs"])  # NaN included


def test_paper_in_workers_writes_the_files_of_one_process(short_scenario, tmp_path, monkeypatch, capsys):  # noqa: F811
    from harness.cli import main
    from harness.commands import paper

    monkeypatch.setattr(paper, "PAPER_SCENARIOS", (str(short_scenario),))
    outs = {}
    for jobs in (1, 2):
        root = tmp_path / f"jobs{jobs}"
        assert main(["paper", "--jobs", str(jobs), "--out", str(root)]) == 0
        outs[jobs] = capsys.readouterr().out
        execution = json.loads((root / "manifest.json").read_text())["execution"]
        # 2 + 3 flights, 2 case folders (the pages and the PDF are this process's)
        assert execution["jobs"] == jobs and len(execution["tasks"]) == 7
    files = {
        j: sorted(p.relative_to(tmp_path / f"jobs{j}") for p in (tmp_path / f"jobs{j}").rglob("*") if p.is_file())
        for j in (1, 2)
    }
    assert files[1] == files[2]
    volatile = {
        "index.html",
        "case.html",
        "report.pdf",
        "manifest.json",
        "report.json",
        "summary.json",
    }
    for rel in files[1]:
        a, b = tmp_path / "jobs1" / rel, tmp_path / "jobs2" / rel
        if rel.suffix == ".parquet":  # JSBSim's metadata carries its wall times
            assert pd.read_parquet(a).equals(pd.read_parquet(b)), rel
        elif rel.name not in volatile:
            assert a.read_bytes() == b.read_bytes(), rel
    listed = [json.loads((tmp_path / f"jobs{j}" / "manifest.json").read_text())["files"] for j in (1, 2)]
    assert (
        [f["path"] for f in listed[0]]
        == [f["path"] for f in listed[1]]
        == [str(r) for r in files[1] if r.name != "manifest.json"]
    )
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging folder left
    strip = lambda text: [  # noqa: E731
        line
        for line in text.splitlines()
        if "time" not in line
        and "jobs" not in line  # noqa: E731
        and str(tmp_path) not in line
        and not line.startswith("  short ")
    ]
    assert strip(outs[1]) == strip(outs[2])


_INTERRUPTED_POOLS = r"""
import os, random, signal, sys, time
import tempfile
from pathlib import Path
from harness.parallel import ForkPool

def task(i):
    def fn():
        with tempfile.TemporaryDirectory() as tmp:     # a temporary folder the worker must remove when ended
            (Path(tmp) / f"f{i}.bin").write_bytes(b"x" * 1000)
            time.sleep(random.uniform(0.0, 0.03))
            if i % 3 == 1:
                raise ValueError(f"task {i} fails")    # the traceback-formatting path
        return b"r" * (1 << 20) if i % 3 == 2 else i   # a result larger than a pipe: the send blocks
    return fn

signal.signal(signal.SIGALRM, lambda *_: os.killpg(0, signal.SIGINT))   # Ctrl-C: the whole process group
random.seed(int(sys.argv[1]))
interrupted = 0
for round in range(int(sys.argv[2])):
    try:
        signal.setitimer(signal.ITIMER_REAL, random.uniform(0.0, 0.15))   # may fire before the next line
        with ForkPool(2) as pool:
            for i in range(12):
                pool.submit(i, task(i))
            while pool.pending:
                try:
                    pool.next_result()
                except ValueError:
                    pass
        signal.setitimer(signal.ITIMER_REAL, 0)
        time.sleep(0.01)                                # an interruption in flight lands here, not in the next round
    except KeyboardInterrupt:
        interrupted += 1
print(interrupted)
sys.exit(130 if interrupted else 0)
"""


def test_pool_interrupted_at_any_moment_ends_quietly(tmp_path):
    # Ctrl-C (SIGINT to the process group) at random moments: workers starting, running, formatting an error,
    # blocked sending a large result, or ending; the parent terminates them and nothing but its own message
    # reaches the terminal.
    import subprocess
    import sys

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    env = dict(os.environ, TMPDIR=str(scratch), PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    r = subprocess.run(
        [sys.executable, "-c", _INTERRUPTED_POOLS, "7", "40"],
        capture_output=True,
        text=True,
        env=env,
        start_new_session=True,
        timeout=120,
    )
    assert r.stderr == ""
    assert r.returncode == 130 and int(r.stdout) >= 20


def test_the_pools_pipes_and_processes_end_while_ctrl_c_waits(monkeypatch):
    # Python runs a signal's handler in the next function it enters: a Ctrl-C landing just before a pipe's
    # __del__ or a process's finalizer runs would be printed there ("Exception ignored in") and lost.  Every such
    # finalizer of the pool runs while SIGINT is blocked, and none is left to the garbage collector (a worker's
    # error raised again in the parent makes no reference cycle through next_result's frame).
    import gc
    import multiprocessing.connection
    import multiprocessing.util
    import signal

    blocked = []

    def record(*_):
        blocked.append(signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, ()))

    gc.collect()  # earlier tests' garbage ends before the recording starts
    gc.disable()
    try:
        monkeypatch.setattr(multiprocessing.connection.Connection, "__del__", record, raising=False)
        close_fds = multiprocessing.util.close_fds
        monkeypatch.setattr(multiprocessing.util, "close_fds", lambda *fds: (record(), close_fds(*fds)))
        with ForkPool(2) as pool:
            for i in range(6):
                pool.submit(i, _raise(ValueError(f"task {i} fails")) if i % 2 else (lambda i=i: i))
            while pool.pending:
                try:
                    pool.next_result()
                except ValueError:
                    pass
            pool.submit("left", lambda: time.sleep(5))  # ended by close()
        ends = len(blocked)
        gc.collect()
        assert len(blocked) == ends  # none of the pool's pipes was left to the garbage collector
    finally:
        gc.enable()
    assert ends >= 2 * 7 and all(blocked)


def test_a_ctrl_c_raised_by_the_blocking_call_leaves_sigint_unblocked(monkeypatch):
    # signal.pthread_sigmask raises a Ctrl-C that arrived before it was called *after* changing the mask: the pool
    # restores the mask, so that later Ctrl-C still interrupt the command.
    import signal

    real = signal.pthread_sigmask
    armed = [True]

    def sigmask(how, mask):
        old = real(how, mask)
        if armed[0] and how == signal.SIG_BLOCK and signal.SIGINT in set(mask):
            armed[0] = False
            raise KeyboardInterrupt
        return old

    monkeypatch.setattr(signal, "pthread_sigmask", sigmask)
    with pytest.raises(KeyboardInterrupt):
        with ForkPool(2) as pool:
            pool.submit("a", lambda: 1)
    assert not armed[0] and signal.SIGINT not in real(signal.SIG_BLOCK, ())


@pytest.mark.parametrize("jobs", [1, 2])
def test_run_all_returns_the_results_in_order(jobs):
    assert run_all([lambda i=i: i * i for i in range(5)], jobs, what="squaring") == [0, 1, 4, 9, 16]


def test_a_killed_worker_leaves_no_temporary_folder(tmp_path):
    # A worker killed at any moment (here inside its own temporary folder) leaves nothing in the system's temp dir:
    # its temporary files live in the pool's folder, which the pool removes.
    import signal
    import tempfile

    note = tmp_path / "where.txt"

    def dies():
        where = tempfile.mkdtemp(prefix="gflat-worker-")
        note.write_text(where)
        os.kill(os.getpid(), signal.SIGKILL)

    with ForkPool(2) as pool:
        if pool.jobs < 2:
            pytest.skip("no fork on this platform")
        pool.submit("k", dies, what="dying")
        with pytest.raises(GflatError, match="ended without a result"):
            pool.next_result()
        where = Path(note.read_text())
        assert where.exists() and where.parent.name.startswith("gflat-pool-")
    assert not where.exists() and not where.parent.exists()
    assert tempfile.gettempdir() != str(where.parent)  # the parent's own temp dir is untouched
