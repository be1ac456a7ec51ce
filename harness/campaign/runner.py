"""Running a campaign: pending cases mapped over a process pool or a Dask cluster, each committed as it ends.

Backends: in this process (``workers=1``), a local
:class:`concurrent.futures.ProcessPoolExecutor` (default, ``workers`` processes),
or Dask distributed (``dask="tcp://host:port"`` for a running scheduler,
``dask="local:N"`` for a :class:`distributed.LocalCluster` of N one-thread
worker processes).  Every case is a pure function of its task
(:func:`harness.campaign.execute.run_sample`), so the metrics are bit-for-bit
the same whatever the backend and number of workers.  Only this process
writes the store.  A worker that dies mid-case: the pool is restarted (the
Dask scheduler reruns the case elsewhere) and the case computed again; the
runner itself killed: the cases committed stay done, the rest pending, and
the same command resumes.
"""

from __future__ import annotations

import contextlib
import json
import logging
import multiprocessing
import os
import re
import shutil
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from gna.errors import InputError, describe, expand_home

from ..artefacts import read_manifest
from ..parallel import INTERRUPTS, InterruptsWait, check_workers
from ..recorded import safe_name
from ..validation import provenance
from .checks import MAX_DASK_TIMEOUT_S
from .execute import run_sample
from .spec import Campaign, load_campaign
from .store import DB_NAME, CampaignStore, locked

__all__ = ["run_campaign", "rerun_case", "parse_dask", "DASK_SCHEMES", "DASK_TIMEOUT_S"]

#: Times a broken process pool is restarted before the remaining cases are left pending.
MAX_POOL_RESTARTS = 3
#: Seconds an ended worker is given to unwind (its temporary files) before it is killed.
WORKER_END_S = 10.0


#: Address schemes of a Dask scheduler (``distributed.comm``; ``inproc`` only reaches this process).
DASK_SCHEMES: tuple[str, ...] = ("tcp", "tls", "ws", "wss", "ucx")

#: Seconds to wait for a Dask scheduler at an address (``--dask-timeout``): Dask retries a refused connection
#: until then.
DASK_TIMEOUT_S = 20.0

_ADDRESS = re.compile(
    r"^(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[^\s:/\[\]]+)"
    r":(?P<port>[0-9]{1,5})$"
)


def parse_dask(spec: str | None):
    """Interpret ``--dask``: None, ``("local", n)`` or ``("address", address)``.

    Parameters
    ----------
    spec : str or None
        ``local:N`` or a scheduler address ``[SCHEME://]HOST:PORT`` (scheme one of
        :data:`DASK_SCHEMES`, default tcp; an IPv6 host in brackets).

    Returns
    -------
    tuple or None

    Raises
    ------
    InputError
        ``local:`` without a positive worker count, or anything that is not
        one of the two forms (one line naming the value and the forms).
    """
    if spec is None:
        return None
    forms = (
        f"local:N (a local cluster of N workers) or a scheduler address [SCHEME://]HOST:PORT "
        f"(SCHEME one of {', '.join(DASK_SCHEMES)}; e.g. tcp://127.0.0.1:8786)"
    )
    if spec == "local" or spec.startswith("local:"):
        _, _, n = spec.partition(":")
        if not n.isdigit() or int(n) < 1:
            raise InputError(f"--dask local:N needs a positive number of workers, got {spec!r}")
        return ("local", check_workers(int(n), "--dask local:N with N ="))
    m = _ADDRESS.match(spec)
    if m is None or (m["scheme"] or "tcp") not in DASK_SCHEMES or not 1 <= int(m["port"]) <= 65535:
        raise InputError(f"--dask {spec!r}: expected {forms}")
    return ("address", spec)


def _distributed():
    """The ``distributed`` module, or one line saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise InputError("--dask needs Dask distributed: pip install 'gflat[campaign]'") from None
    return distributed


#: Seconds waited beyond ``--dask-timeout`` for the connection to a scheduler to end either way.
CONNECT_MARGIN_S = 5.0


#: Scratch folder of a ``--dask local:N`` cluster (its workers' and scheduler's work folders and lock files), in
#: the campaign folder rather than Dask's default ``<tmp>/dask-scratch-space``; removed when the cluster ends.
DASK_SCRATCH = ".dask-scratch"


def _connect(where, timeout: float, scratch: Path | None = None):
    """A Dask client for ``where`` (:func:`parse_dask`) and the LocalCluster started for it (or None); a local
    cluster keeps its scratch files in ``scratch`` (Dask's ``temporary-directory``: by default, ``/tmp``)."""
    Client, LocalCluster = _distributed().Client, _distributed().LocalCluster
    kind, arg = where
    if kind == "local":
        import dask

        local = {} if scratch is None else {"local_directory": str(scratch)}
        with dask.config.set({"temporary-directory": str(scratch)} if scratch is not None else {}):
            cluster = LocalCluster(
                n_workers=arg,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
                **local,
            )
        return Client(cluster), cluster
    # In a thread of its own, waited for at most the timeout and a margin: a server that is not a Dask
    # scheduler may accept the connection and never answer (Dask's timeout does not cover the handshake),
    # or answer bytes Dask reads as a message of absurd size (a MemoryError).
    box: dict = {}

    def connect():
        try:
            box["client"] = Client(arg, timeout=f"{timeout}s")
        except BaseException as exc:  # noqa: BLE001  (reported below, in one line)
            box["error"] = exc

    worker = threading.Thread(target=connect, name="gflat-dask-connect", daemon=True)
    worker.start()
    worker.join(timeout + CONNECT_MARGIN_S)
    if worker.is_alive():
        raise InputError(
            f"cannot connect to the Dask scheduler at {arg}: no answer within {timeout:g} s "
            f"(+{CONNECT_MARGIN_S:g} s): is a Dask scheduler listening there?"
        )
    exc = box.get("error")
    if exc is not None:
        why = (
            "a malformed address"
            if isinstance(exc, ValueError)
            else "refused, unreachable or timed out"
            if isinstance(exc, OSError)
            else "not a Dask scheduler?"
        )
        raise InputError(
            f"cannot connect to the Dask scheduler at {arg}: {type(exc).__name__}: {describe(exc)} ({why})"
        ) from None
    return box["client"], None


def _local_pool(tasks, workers: int, commit):
    """Run tasks in a process pool, restarting it when a worker dies."""
    remaining = {t.case_id: t for t in tasks}
    for attempt in range(MAX_POOL_RESTARTS + 1):
        if not remaining:
            return []
        pool = ProcessPoolExecutor(max_workers=workers, initializer=_worker_starts)
        try:
            # The pool forks its workers in the first submit: an interruption arriving meanwhile waits for the
            # block's end (its Python handler would otherwise run in an at-fork callback, which swallows what
            # it raises, and the run would go on), and the workers start with it blocked until they run.
            with InterruptsWait():
                futures = [pool.submit(_case_in_worker, t) for t in remaining.values()]
            for fut in as_completed(futures):
                outcome = fut.result()
                commit(outcome)
                remaining.pop(outcome["case_id"], None)
            pool.shutdown(wait=True)
        except BaseException as exc:
            # Ctrl-C or an error: the cases committed so far stay recorded (a rerun resumes); the queued ones are
            # dropped and the running workers ended at once, not waited for (a case can take many seconds).
            _end_workers(pool)
            pool.shutdown(wait=False, cancel_futures=True)
            if not isinstance(exc, BrokenProcessPool):
                raise
            print(
                f"gflat campaign: a worker process died; restarting the pool for the {len(remaining)} cases left "
                f"(attempt {attempt + 1} of {MAX_POOL_RESTARTS})",
                file=sys.stderr,
            )
    return list(remaining)


class _WorkerEnded(BaseException):
    """Raised in a pool worker by the runner's SIGTERM (:func:`_end_workers`) during a case: unwinds the case,
    then the worker leaves (:func:`_case_in_worker`)."""


def _worker_ends(signum, frame) -> None:
    """A pool worker's SIGTERM during a case: its standard error to ``/dev/null`` (the terminal belongs to the
    runner's line), then :class:`_WorkerEnded` raised, so that the case's ``finally`` blocks run."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)
    os.close(devnull)
    raise _WorkerEnded()


def _worker_starts() -> None:
    """A pool worker's first step: its own handlers, then the interruptions blocked while the pool forked it
    delivered again.  Forked inside :class:`harness.parallel.InterruptsWait`, the worker inherits handlers that
    only record a signal (the block's end that would act on them never comes in the worker; with them a worker
    went on with its case until killed ``WORKER_END_S`` later): Ctrl-C is ignored (the runner ends its
    workers) and SIGTERM, between cases, ends the worker at once (the default action: a Python handler would
    wait for the main thread, which may be blocked reading the pool's queue while the signal went to the
    worker's queue-feeding thread); during a case :func:`_case_in_worker` unwinds it first."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, INTERRUPTS)


def _case_in_worker(task) -> dict:
    """:func:`harness.campaign.execute.run_sample` in a pool worker.  Ended meanwhile (SIGTERM), the case's
    ``finally`` blocks run (:func:`_worker_ends`, the handler while the case runs: the main thread runs Python
    code then, whichever thread the signal reached) and the worker leaves at once (``os._exit``), rather than
    return to the pool's loop, which would take the interruption for the case's error and wait for the next."""
    signal.signal(signal.SIGTERM, _worker_ends)
    try:
        return run_sample(task)
    except _WorkerEnded:
        os._exit(128 + signal.SIGTERM)
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _end_workers(pool) -> None:
    """End the pool's worker processes and wait until they have ended (killed if one does not within
    ``WORKER_END_S``), so that none outlives the runner.  A worker the pool was forking when the runner was
    interrupted is not in the pool's table yet: the runner's own children are ended too."""
    procs = {*(getattr(pool, "_processes", None) or {}).values(), *multiprocessing.active_children()}
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.terminate()
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.join(WORKER_END_S)
            if proc.is_alive():
                proc.kill()
                proc.join()


@contextlib.contextmanager
def _dask_logs():
    """Dask's loggers carry their own INFO level: at most gflat's level (-v/-q) meanwhile."""
    dlog = logging.getLogger("distributed")
    saved = dlog.level
    dlog.setLevel(max(logging.WARNING, logging.getLogger().level))
    try:
        yield
    finally:
        dlog.setLevel(saved)


def _dask(tasks, where, commit, client=None, timeout: float = DASK_TIMEOUT_S, scratch: Path | None = None):
    """Run tasks on a Dask cluster: ``client`` (connected and closed by the caller), else one started here (a
    local cluster's scratch files in ``scratch``, removed at the end)."""
    dask_completed = _distributed().as_completed
    own, cluster = client is None, None
    with _dask_logs():
        try:
            if own:
                client, cluster = _connect(where, timeout, scratch)
            futures = {client.submit(run_sample, t, key=f"gflat-{t.case_id}", pure=False): t for t in tasks}
            for fut in dask_completed(list(futures)):
                try:
                    outcome = fut.result()
                except Exception as exc:  # KilledWorker: the scheduler gave up on this case
                    t = futures[fut]
                    outcome = {
                        "case_id": t.case_id,
                        "status": "failed",
                        "metrics": None,
                        "draw": None,
                        "error": f"{type(exc).__name__}: {describe(exc)}",
                        "timings": {},
                        "files": {},
                    }
                commit(outcome)
        finally:
            if own and client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
            if own and scratch is not None:
                shutil.rmtree(scratch, ignore_errors=True)


def run_campaign(
    campaign: Campaign | str | Path,
    out: str | Path,
    *,
    samples: int | None = None,
    workers: int | None = None,
    dask: str | None = None,
    retry_failed: bool = False,
    quiet: bool = False,
    only=None,
    dask_timeout: float = DASK_TIMEOUT_S,
    progress=None,
) -> dict:
    """Run (or resume) a campaign into a folder.

    Everything is checked before the folder is created or touched: the
    campaign (:func:`harness.campaign.spec.campaign_from_dict`), the settings,
    the case ids of ``only``, and the Dask scheduler at an address (connected first).

    Parameters
    ----------
    campaign : Campaign, str or Path
        A campaign, a bundled campaign name or a campaign file.
    out : str or Path
        The campaign folder (created; an existing one of the same campaign is resumed).
    samples : int, optional
        Samples per case and dispersion set; default the campaign's.  A larger
        count on a rerun adds cases; sample k is the same whatever the count.
    workers : int, optional
        Local worker processes (default the number of CPUs; 1 runs in this process).
    dask : str, optional
        ``local:N`` or a Dask scheduler address ``[SCHEME://]HOST:PORT`` (then
        ``workers`` is not used; :func:`parse_dask`).
    retry_failed : bool
        Run the failed cases again (by default only the pending ones run).
    quiet : bool
        No note of the cases to run (nor of the untrusted ones).
    only : iterable of str, optional
        Run only these case ids (pending or failed; see :func:`rerun_case` for a done one).
    dask_timeout : float
        Seconds to wait for the Dask scheduler at an address [s].
    progress : harness.progress.Progress, optional
        Shows the cases ended, counted (a line per case when not on a terminal); default none.

    Returns
    -------
    dict
        ``cases``, ``done``, ``failed``, ``pending`` (counts after the run),
        ``computed`` (cases run now), ``skipped`` (already done or failed),
        ``elapsed_s``, ``folder``.

    Raises
    ------
    InputError
        Unknown campaign, bad settings, an unknown case id in ``only``, a Dask
        scheduler that cannot be reached, or a folder holding another campaign.
    """
    camp = campaign if isinstance(campaign, Campaign) else load_campaign(campaign)
    where = parse_dask(dask)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise InputError(f"--workers must be a positive integer, got {workers!r}")
    if (
        isinstance(dask_timeout, bool)
        or not isinstance(dask_timeout, (int, float))
        or not dask_timeout > 0
        or dask_timeout == float("inf")
    ):
        raise InputError(f"--dask-timeout must be a positive number of seconds, got {dask_timeout!r}")
    if dask_timeout > MAX_DASK_TIMEOUT_S:
        raise InputError(f"--dask-timeout {dask_timeout:g} s is above the bound of {MAX_DASK_TIMEOUT_S:g} s")
    tasks = camp.tasks(samples)
    if only is not None:
        unknown = sorted(set(only) - {t.case_id for t in tasks})
        if unknown:
            raise InputError(f"no case {unknown[0]!r} in campaign {camp.name!r} with these samples")
    client = None
    if where is not None:
        _distributed()
    if where is not None and where[0] == "address":
        with _dask_logs():
            client, _ = _connect(where, dask_timeout)  # an unreachable scheduler: nothing written
    try:
        return _run(camp, tasks, out, where, client, workers, retry_failed, quiet, only, progress)
    finally:
        if client is not None:
            with _dask_logs():
                client.close()


def _campaign_folder(out) -> Path:
    """The campaign folder checked (one line, nothing written) and made: not a file, not a gflat run's folder nor
    inside one (runs are never changed once written), not a non-empty folder without a campaign index (a folder
    of the user's is never adopted), its parent takes files."""
    given = expand_home(out)
    path = Path(os.path.abspath(given))
    if path.exists() and not path.is_dir():
        raise InputError(f"campaign folder {given}: a file of that name exists (not a folder)")
    for folder in (path, *path.parents):
        if read_manifest(folder) is not None:
            where = "is" if folder == path else f"lies inside {folder},"
            raise InputError(
                f"campaign folder {path} {where} the folder of a gflat run (runs are never changed once written): "
                f"give another --out"
            )
    if path.is_dir() and not os.path.lexists(path / DB_NAME):
        held = _entries(path)
        if held:  # a folder of the user's (or /, or a package's): never adopted
            shown = ", ".join(held[:3]) + (f" and {len(held) - 3} more" if len(held) > 3 else "")
            raise InputError(
                f"campaign folder {path} is not a campaign folder (no {DB_NAME}) and is not empty: it holds "
                f"{shown}; give a new or empty folder as --out"
            )
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"campaign folder {path}: cannot create it: {describe(exc)}") from None
    return path


def _entries(folder: Path) -> list[str]:
    """The names in ``folder`` (folders with a ``/``), sorted; a folder that cannot be listed: its cause."""
    try:
        with os.scandir(folder) as it:
            return sorted(e.name + ("/" if e.is_dir(follow_symlinks=False) else "") for e in it)
    except OSError as exc:
        raise InputError(f"campaign folder {folder}: cannot list it: {describe(exc)}") from None


def untrusted(store, quiet: bool = False, *, reset: bool = False) -> dict:
    """The stored cases that fail :meth:`~harness.campaign.store.CampaignStore.check` (done cases whose files are
    missing, truncated or changed, malformed rows), each named in one line on stderr.

    Parameters
    ----------
    store : CampaignStore
    quiet : bool
        Print nothing.
    reset : bool
        Mark each pending again, its files removed (:meth:`~harness.campaign.store.CampaignStore.reset`), so that
        this run computes it again.

    Returns
    -------
    dict
        Case id -> cause.

    Raises
    ------
    InputError
        A stored case id is not a plain name (the store was changed: nothing is removed).
    """
    rows = store.rows()
    for r in rows:
        try:
            safe_name(r["case_id"], "case id")
        except InputError as exc:
            raise InputError(f"{store.root / DB_NAME}: {exc}: use a new folder") from None
    bad = {r["case_id"]: p for r in rows if (p := store.check(r)) is not None}
    for cid, problem in bad.items():
        if reset:
            store.reset(cid)
        if not quiet:
            print(f"campaign: case {cid}: {problem}" + (": computed again" if reset else ""), file=sys.stderr)
    return bad


def _run(camp, tasks, out, where, client, workers, retry_failed, quiet, only, progress) -> dict:
    with locked(_campaign_folder(out)) as path:  # a second run (or a report) refused meanwhile
        store = CampaignStore(path)
        try:
            return _run_in(camp, tasks, out, where, client, workers, retry_failed, quiet, only, store, progress)
        finally:
            store.close()


def _run_in(camp, tasks, out, where, client, workers, retry_failed, quiet, only, store, progress) -> dict:
    meta = store.meta()
    ident = {"name": camp.name, "seed": camp.seed}
    if camp.tracking is not None:  # --tracking: the design is part of what the folder holds
        ident["tracking"] = camp.tracking
    if meta.get("campaign") and meta["campaign"] != ident:
        held = meta["campaign"]

        def design(d):
            return f", --tracking {d['tracking']}" if "tracking" in d else ""

        raise InputError(
            f"{out} holds campaign {held['name']!r} (seed {held['seed']}{design(held)}), "
            f"not {camp.name!r} (seed {camp.seed}{design(ident)}): use another folder"
        )
    store.set_meta(campaign=ident, definition=camp.raw, source=camp.source)
    store.add_cases(tasks)
    store.clean_stale()
    untrusted(store, reset=True)  # a case done whose files are missing or changed is computed again
    status = store.statuses()
    wanted = {t.case_id for t in tasks}
    if only is not None:
        only = set(only)
        tasks = [t for t in tasks if t.case_id in only]
        wanted = only
    todo = [
        t for t in tasks if status[t.case_id] == "pending" or ((retry_failed or only) and status[t.case_id] == "failed")
    ]
    skipped = len(wanted) - len(todo)
    if not quiet:
        print(
            f"campaign {camp.name}: {len(wanted)} cases, {skipped} already recorded, {len(todo)} to run"
            + (" - nothing to compute" if not todo else ""),
            file=sys.stderr,
        )
    versions = provenance()
    versions.pop("date_utc", None)
    bar = progress.begin(f"campaign {camp.name}: cases", total=len(todo)) if progress is not None and todo else None
    tally = {"done": 0, "failed": 0}
    t0 = time.perf_counter()

    def commit(outcome):
        store.commit(outcome, versions)
        tally[outcome["status"]] += 1
        if bar is not None:
            progress.advance(
                bar, f"{outcome['case_id']} {outcome['status']} ({tally['done']} done, {tally['failed']} failed)"
            )

    try:
        if not todo:
            pass
        elif where is not None:
            _dask(todo, where, commit, client, scratch=store.root / DASK_SCRATCH)
        elif (workers or os.cpu_count() or 1) == 1:
            for t in todo:
                commit(run_sample(t))
        else:
            _local_pool(todo, workers or os.cpu_count() or 1, commit)
    except BaseException:
        if bar is not None:  # an error or an interruption: no "cases done" line
            progress.cancel(bar)
        raise
    if bar is not None:
        progress.end(bar)
    counts = store.counts()
    return {
        **counts,
        "computed": tally["done"] + tally["failed"],
        "skipped": skipped,
        "elapsed_s": time.perf_counter() - t0,
        "folder": str(out),
    }


def rerun_case(out: str | Path, case_id: str, campaign: Campaign | str | Path | None = None) -> dict:
    """Compute one stored case again, alone, without touching the store.

    Parameters
    ----------
    out : str or Path
        The campaign folder.
    case_id : str
        A case of the folder.
    campaign : Campaign, str or Path, optional
        The campaign; default the one recorded in the folder (its stored definition).

    Returns
    -------
    dict
        The outcome (:func:`harness.campaign.execute.run_sample`) plus
        ``same_as_stored``: True when the stored metrics are identical (None
        when the case has no stored metrics).

    Raises
    ------
    InputError
        Not a campaign folder, or an unknown case id.
    """
    from .spec import campaign_from_dict

    if not (Path(out) / "campaign.sqlite").is_file():
        raise InputError(f"{out} is not a campaign folder (no campaign.sqlite)")
    store = CampaignStore(out)
    try:
        meta = store.meta()
        rows = {r["case_id"]: r for r in store.rows()}
    finally:
        store.close()
    if case_id not in rows:
        raise InputError(f"no case {case_id!r} in {out}")
    if campaign is None:
        src = meta.get("source", "")
        base = Path(src).parent if src.endswith(".toml") and Path(src).is_absolute() else None
        camp = campaign_from_dict(meta["definition"], where=src or "campaign", base=base)
        camp = camp.with_tracking((meta.get("campaign") or {}).get("tracking"))  # the design the folder flew
    else:
        camp = campaign if isinstance(campaign, Campaign) else load_campaign(campaign)
    row = rows[case_id]
    task = next((t for t in camp.tasks(row["sample"] + 1) if t.case_id == case_id), None)
    if task is None:
        raise InputError(f"case {case_id!r} is not part of campaign {camp.name!r}")
    outcome = run_sample(task)
    stored = row["metrics"]
    outcome["same_as_stored"] = (
        None if stored is None else json.dumps(stored, sort_keys=True) == json.dumps(outcome["metrics"], sort_keys=True)
    )
    return outcome
