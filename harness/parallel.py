"""Independent pieces of a command run concurrently in forked worker processes.

:class:`ForkPool` runs zero-argument callables in child processes forked from
the caller, at most ``jobs`` at a time, highest priority first: a child
inherits everything the callable refers to (plans, compiled expressions,
results), so nothing but the callable's return value is pickled (back).  A
child ignores Ctrl-C; the parent, interrupted, terminates its children when
the pool's ``with`` block ends, so the command stops with its usual one-line
message.  The parent's pipes and process handles end (their finalizers run)
only while Ctrl-C and SIGTERM wait (:class:`InterruptsWait`): Python runs a signal's handler
inside whatever function it enters next, and a ``KeyboardInterrupt`` raised
inside a finalizer is printed and lost instead of stopping the command.  An
error raised in a child is raised again in the parent, with the same type and
message where it can be rebuilt there (the child's traceback attached as its
cause).  ``jobs = 1``, or a platform without ``fork``, runs
every callable in the parent, in the same order of priorities.

A worker writes its own files directly, into the run's staging folder
(:class:`harness.rundir.RunDir`: the forked child inherits its path); the
parent alone commits the run.

Given a :class:`harness.progress.Progress`, the pool shows each callable as a
stage (its ``what``) while it runs, and the stages a worker reports itself (a
figure drawn) come back through the worker's result pipe, before its result.
"""

from __future__ import annotations

import collections
import contextlib
import gc
import heapq
import multiprocessing
import os
import pickle
import shutil
import signal
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Callable
from multiprocessing.connection import wait as wait_connections
from typing import Any

from gna.errors import GflatError, InputError, describe


def default_jobs() -> int:
    """Worker processes used by default: the CPUs this process may run on.

    Returns
    -------
    int
        At least 1.
    """
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except (AttributeError, OSError):
        return max(os.cpu_count() or 1, 1)


#: Most worker processes per CPU a command starts (``--workers``, ``--jobs``, ``--dask local:N``): more only
#: adds memory and context switches (a case is CPU-bound).
WORKERS_PER_CPU = 4


def max_workers() -> int:
    """The most worker processes a command may start: :data:`WORKERS_PER_CPU` x the CPUs of :func:`default_jobs`.

    Returns
    -------
    int
    """
    return WORKERS_PER_CPU * default_jobs()


def check_workers(n: int, what: str) -> int:
    """Refuse more worker processes than :func:`max_workers`.

    Parameters
    ----------
    n : int
        The count asked for.
    what : str
        The flag, for the message (``--workers``).

    Returns
    -------
    int
        ``n``.

    Raises
    ------
    InputError
        One line naming the flag, the value and the bound.
    """
    bound = max_workers()
    if n > bound:
        raise InputError(
            f"{what} {n}: above the bound of {bound} worker processes "
            f"({WORKERS_PER_CPU} x the {default_jobs()} CPU(s) this process may use)"
        )
    return n


class RemoteTraceback(Exception):
    """The traceback of an error raised in a worker process (attached as the cause of the error raised again)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def _portable(exc: BaseException) -> BaseException:
    """``exc``, or the nearest class of it rebuilt from its message, such that it survives pickling."""
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:
        pass
    for cls in type(exc).__mro__:
        if not (isinstance(cls, type) and issubclass(cls, BaseException)):
            continue
        try:
            copy = cls(str(exc))
            pickle.loads(pickle.dumps(copy))
            return copy
        except Exception:
            continue
    return RuntimeError(f"{type(exc).__name__}: {describe(exc)}")


#: The signals ``gflat`` turns into an interruption (:func:`harness.cli.main`): Ctrl-C, SIGTERM and SIGHUP.
INTERRUPTS = frozenset(s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)) if s is not None)


class InterruptsWait:
    """A ``with`` block during which Ctrl-C (SIGINT), SIGTERM and SIGHUP wait, raised where the block ends.

    ``gflat`` raises ``KeyboardInterrupt`` on Ctrl-C and :class:`harness.cli.Terminated` on SIGTERM or SIGHUP; a
    cleanup (a pool's children ended, a staging folder removed) inside the block is never cut short.

    Two locks, for two ways a signal arrives.  In the main thread the signals' Python handlers are swapped for
    one that only records them (a signal the kernel hands to another thread, e.g. one of Arrow's, still runs
    its Python handler in the main thread, at once); the recorded ones are raised again, once each, when the
    block ends, with the handlers put back.  And the signals are blocked in the calling thread
    (``signal.pthread_sigmask``), so that a child forked inside the block starts with them pending, not lost,
    until it has set its own handlers.  A handler that is ``SIG_IGN`` stays so.  ``pthread_sigmask`` runs the
    handlers of signals that arrived before it returns: the handlers are swapped before the mask is changed,
    the mask in force is read before it is changed (and restored whatever is raised meanwhile), and restored
    before the handlers, so that nothing is raised half-way and no signal stays blocked for the rest of the
    process.
    """

    def __enter__(self) -> None:
        self._saved: dict = {}
        self._pending: list[int] = []
        self._mask = None
        try:
            if threading.current_thread() is threading.main_thread():
                for sig in INTERRUPTS:
                    if signal.getsignal(sig) not in (signal.SIG_IGN, None):
                        self._saved[sig] = signal.signal(sig, self._record)
            if hasattr(signal, "pthread_sigmask"):
                self._mask = signal.pthread_sigmask(signal.SIG_BLOCK, ())  # read first: restored however this ends
                signal.pthread_sigmask(signal.SIG_BLOCK, INTERRUPTS)
        except BaseException:
            self._restore()
            raise

    def _record(self, signum, frame) -> None:
        self._pending.append(signum)

    def _restore(self) -> None:
        if self._mask is not None:  # the signals blocked meanwhile are recorded here
            signal.pthread_sigmask(signal.SIG_SETMASK, self._mask)
            self._mask = None
        for sig, handler in self._saved.items():
            signal.signal(sig, handler)
        self._saved = {}
        pending, self._pending = list(dict.fromkeys(self._pending)), []
        for sig in pending:  # the put-back handler raises it (or, SIG_DFL, its default action)
            signal.raise_signal(sig)

    def __exit__(self, *exc) -> None:
        self._restore()


class _Terminated(BaseException):
    """Raised in a worker by SIGTERM (the parent ending it): unwinds its ``finally`` blocks (temporary files)."""


def _child(conn, fn: Callable[[], Any], tmp: str | None = None, progress=None) -> None:
    """Body of a worker: run ``fn``, send ``("ok", value)`` or ``("err", exception, traceback text)``, exit.

    ``tmp``: the pool's temporary folder, made the worker's default one (``tempfile.tempdir``: this process
    only), so that whatever a worker ended at any moment leaves there goes with the pool.  ``progress``: the
    pool's :class:`harness.progress.Progress` (this process's copy), made to send the stages ``fn`` finishes
    (``("stage", name, seconds)``) through the pipe, ahead of the result.

    Ended by the parent (SIGTERM), the worker says nothing: its standard error
    goes to ``/dev/null`` at once, ``_Terminated`` unwinds ``fn``'s ``finally``
    blocks, and the process leaves by ``os._exit`` (no report of the
    multiprocessing bootstrap, whatever the moment the signal arrives).
    """
    ending = []

    def terminate(signum, frame):
        if not ending:
            ending.append(signum)
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 2)  # the user's terminal belongs to the parent's message
            os.close(devnull)
        raise _Terminated()

    code = 143
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C and ends its children
        signal.signal(signal.SIGTERM, terminate)
        if tmp is not None:
            tempfile.tempdir = tmp
        if progress is not None:
            progress.in_worker(conn.send)
        gc.freeze()  # the inherited objects are not scanned by this process's collections (nor copied by them)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, INTERRUPTS)  # blocked while the parent forked
        w0, c0 = time.perf_counter(), time.process_time()
        try:
            out = ("ok", fn())
        except _Terminated:
            raise
        except BaseException as exc:  # noqa: BLE001  (sent to the parent, raised there)
            out = ("err", _portable(exc), traceback.format_exc())
        if ending:  # a _Terminated swallowed by fn (e.g. in a __del__)
            raise _Terminated()
        out += (time.perf_counter() - w0, time.process_time() - c0)
        try:
            conn.send(out)
        except Exception as exc:  # an unpicklable result
            conn.send(
                (
                    "err",
                    RuntimeError(f"a worker's result could not be sent back: {describe(exc)}"),
                    traceback.format_exc(),
                    0.0,
                    0.0,
                )
            )
        conn.close()
        sys.stdout.flush()
        sys.stderr.flush()
        code = 0
    except BaseException:  # noqa: BLE001  (_Terminated at any moment: end quietly)
        code = 143 if ending else 1
    finally:
        os._exit(code)


class ForkPool:
    """Run zero-argument callables in forked child processes, at most ``jobs`` at a time.

    Parameters
    ----------
    jobs : int
        Most children running at once; 1 (or no ``fork`` on the platform)
        runs the callables in the calling process.
    progress : harness.progress.Progress, optional
        Shows each callable with a ``what`` as a stage while it runs, and the stages a worker reports.

    Attributes
    ----------
    jobs : int
        The number of worker processes in use (1: in process).
    log : list of dict
        Per callable finished, in the order returned: ``what``, ``wall_s`` and
        ``cpu_s`` (its process's CPU time) [s].
    """

    def __init__(self, jobs: int, progress=None):
        if jobs < 1:
            raise InputError(f"jobs must be at least 1, got {jobs}")
        forkable = "fork" in multiprocessing.get_all_start_methods() and hasattr(signal, "pthread_sigmask")
        self.jobs = jobs if forkable else 1
        self._ctx = multiprocessing.get_context("fork") if self.jobs > 1 else None
        self._queue: list = []  # heap of (-priority, sequence, key, fn, what)
        self._running: dict = {}  # parent end of the pipe -> (process, key, what)
        self._seq = 0
        self._tmp: str | None = None  # the workers' temporary folder, removed by close()
        self._progress = progress
        self._held = 0  # > 0: inside held(), nothing starts
        self._done: collections.deque = collections.deque()  # (key, what, exit code, message) collected
        self.log: list[dict] = []

    def __enter__(self) -> ForkPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @contextlib.contextmanager
    def held(self):
        """A ``with`` block whose submissions start only when it ends, highest priority first.

        Without it the first callables submitted start at once, whatever the priorities of those
        submitted next; a caller submitting several at a time (a case's flights) holds them, so that the
        longest start first.
        """
        self._held += 1
        try:
            yield self
        finally:
            self._held -= 1
            if not self._held:
                self._start()

    @property
    def pending(self) -> int:
        """Callables submitted whose result has not been returned by :meth:`next_result` yet."""
        return len(self._queue) + len(self._running) + len(self._done)

    def submit(self, key, fn: Callable[[], Any], *, priority: float = 0.0, what: str = "") -> None:
        """Queue ``fn`` (started at once if a worker is free).

        Parameters
        ----------
        key : hashable
            Returned with the result.
        fn : callable
            Zero-argument callable; its return value must be picklable.
        priority : float
            Higher starts first among the queued callables (ties: in submission order).
        what : str
            Description used in the message when a worker dies without a result.
        """
        heapq.heappush(self._queue, (-priority, self._seq, key, fn, what))
        self._seq += 1
        self._start()

    def start_ahead(self, extra: int = 1) -> None:
        """Start up to ``extra`` queued callables beyond ``jobs`` now, for a caller about to be busy a while.

        While the caller does its own work (it collects no result), a worker that finishes leaves its CPU
        idle until the caller's next :meth:`next_result` or :meth:`poll`; one more callable running meanwhile
        takes that CPU.  The pool is back at ``jobs`` as the running ones finish.

        Parameters
        ----------
        extra : int
            Callables started beyond ``jobs`` at most.
        """
        self._start(self.jobs + max(int(extra), 0))

    def _start(self, limit: int | None = None) -> None:
        if self._ctx is None or self._held:
            return
        if self._tmp is None and self._queue:
            self._tmp = tempfile.mkdtemp(prefix="gflat-pool-")
        while self._queue and len(self._running) < (self.jobs if limit is None else limit):
            sys.stdout.flush()
            sys.stderr.flush()
            with InterruptsWait():  # no Ctrl-C before the child ignores it, nor in the pipe's finalizers
                _, _, key, fn, what = heapq.heappop(self._queue)
                parent_end, child_end = self._ctx.Pipe(duplex=False)
                try:
                    proc = self._ctx.Process(
                        target=_child, args=(child_end, fn, self._tmp, self._progress), daemon=True
                    )
                    proc.start()
                except BaseException:
                    parent_end.close()
                    del parent_end
                    raise
                finally:
                    child_end.close()
                    del child_end
                self._running[parent_end] = (proc, key, what, self._begin(what))
                del parent_end, proc

    def next_result(self) -> tuple[Any, Any]:
        """The next finished callable's key and return value (the earliest started among those done when
        collected; those :meth:`poll` collected first, in its order).

        Returns
        -------
        (key, value)

        Raises
        ------
        InputError
            Nothing pending.
        Exception
            The callable's own error, raised again here.
        """
        if not self.pending:
            raise InputError("no task pending")
        if self._ctx is None:
            _, _, key, fn, what = heapq.heappop(self._queue)
            token = self._begin(what)
            w0, c0 = time.perf_counter(), time.process_time()
            try:
                value = fn()
            except BaseException:
                self._end(token, None)  # no line for a callable that raised (cancelled)
                raise
            wall = time.perf_counter() - w0
            self._end(token, wall)
            self.log.append({"what": what, "wall_s": wall, "cpu_s": time.process_time() - c0})
            return key, value
        while not self._done:  # a worker's stage reports first, then its result
            ready = wait_connections(list(self._running))
            # Ctrl-C waits while a finished child is collected and the next started, and the pipe and the Process
            # dropped here end inside the block (a Connection's __del__ and a Process's finalizer are Python
            # functions, where a KeyboardInterrupt would be printed and lost)
            with InterruptsWait():
                conn = min(ready, key=lambda c: list(self._running).index(c))
                del ready
                self._take(conn)
                del conn
        key, what, exitcode, msg = self._done.popleft()
        if msg is None:
            raise GflatError(
                f"a worker process ended without a result (exit code {exitcode})" + (f" while {what}" if what else "")
            )
        self.log.append({"what": what, "wall_s": msg[-2], "cpu_s": msg[-1]})
        if msg[0] == "err":
            exc = msg[1]
            if not isinstance(exc, GflatError):
                exc.__cause__ = RemoteTraceback(msg[2])
            try:
                raise exc
            finally:  # no cycle error -> traceback -> this frame -> error, left to the garbage collector
                del exc, msg
        return key, msg[1]

    def _take(self, conn) -> None:
        """One message of the worker at ``conn`` (ready): a stage shown, or its result kept for
        :meth:`next_result` and the next callable started.  Called with the interruptions waiting."""
        try:  # unpickled in this frame: a traceback rebuilt with the error (tblib) holds no pipe
            msg = pickle.loads(conn.recv_bytes())
        except (EOFError, OSError):
            msg = None
        if msg is not None and msg[0] == "stage":
            if self._progress is not None:
                self._progress.done(msg[1], msg[2])
            return
        proc, key, what, token = self._running.pop(conn)
        conn.close()
        proc.join()
        exitcode = proc.exitcode
        del conn, proc
        self._end(token, None if msg is None or msg[0] == "err" else msg[-2])
        self._done.append((key, what, exitcode, msg))
        self._start()

    def poll(self) -> None:
        """Collect the workers that have finished, without waiting, and start the next callables.

        A caller busy between two :meth:`next_result` calls (planning, preparing) calls it so that a
        finished worker's place is taken at once; the results wait for :meth:`next_result`, in the order
        collected.
        """
        if self._ctx is None:
            return
        while self._running:
            ready = wait_connections(list(self._running), timeout=0)
            if not ready:
                return
            with InterruptsWait():
                for conn in sorted(ready, key=lambda c: list(self._running).index(c)):
                    self._take(conn)
                del ready, conn

    def _begin(self, what: str):
        """The progress token of a callable starting (None: no progress, or nothing to call it)."""
        return self._progress.begin(what) if self._progress is not None and what else None

    def _end(self, token, seconds: float | None) -> None:
        """A callable's stage ended: finished in ``seconds`` (its worker's wall time), or cancelled (None)."""
        if token is None:
            return
        if seconds is None:
            self._progress.cancel(token)
        else:
            self._progress.end(token, seconds)

    def close(self) -> None:
        """End every running child (after an error or an interruption), drop the queue, remove the workers'
        temporary folder."""
        with InterruptsWait():  # a second Ctrl-C waits: no child left, no finalizer interrupted
            self._queue.clear()
            self._done.clear()
            for conn, (proc, _, _, token) in list(self._running.items()):
                self._end(token, None)
                if proc.is_alive():
                    proc.terminate()
                proc.join()
                conn.close()
            conn = proc = None
            self._running.clear()
            if self._tmp is not None:
                shutil.rmtree(self._tmp, ignore_errors=True)
                self._tmp = None


def run_all(fns, jobs: int, what: str = "", progress=None) -> list:
    """Run zero-argument callables in a :class:`ForkPool` of ``jobs`` workers; their results in order.

    Parameters
    ----------
    fns : sequence of callable
        Zero-argument callables with picklable results.
    jobs : int
        Most worker processes at once (1: in this process).
    what : str
        What they do, for the message of a worker that dies (``"walking a margin ladder"``) and the progress.
    progress : harness.progress.Progress, optional
        Shows each callable (with a ``what``) as a stage while it runs (:class:`ForkPool`).

    Returns
    -------
    list
        ``[fn() for fn in fns]``.
    """
    results = {}
    with ForkPool(jobs, progress=progress) as pool:
        for i, fn in enumerate(fns):
            pool.submit(i, fn, what=f"{what} ({i + 1} of {len(fns)})" if what else "")
        while pool.pending:
            i, value = pool.next_result()
            results[i] = value
    return [results[i] for i in range(len(fns))]
