"""The progress of a long command on stderr: what runs now, what has finished and when.

A :class:`Progress` is made by the command line (:func:`harness.cli.main`) as soon as it has read the
command's words, before the command's modules load, and passed explicitly to the command
(``args.progress``), which hands it to whatever reports a stage (the worker pool, the report's
renderer, the campaign runner).  Three ways of showing it (:func:`choose_mode`):

``live``
    stderr is a terminal: rich draws a live line per running stage (a spinner, its name, its elapsed
    time) under a line with the command's own elapsed time; a stage that finishes leaves one line above
    them (its name and duration).  Whatever the command prints meanwhile (stdout on the same terminal,
    the log's warnings on stderr) is printed above the live lines.
``plain``
    stderr is no terminal (a pipe, a file, CI): one timestamped line per stage finished, the first one
    (``started``) as soon as the command is read: ``[07:01:02 +3.4 s] gflat paper: planning gtm-forward-slip
    done in 1.21 s`` (the wall clock, the seconds since the start, the stage, its duration).
``off``
    ``-q``, or ``GFLAT_PROGRESS=off``: nothing.

``GFLAT_PROGRESS`` (``auto``, ``live``, ``plain``, ``off``) overrides the choice; the test suite sets
``off`` (its tests of progress set their own).  Progress lines never go to stdout: ``--json`` output
stays one JSON document.

Stages run in forked worker processes (:class:`harness.parallel.ForkPool`) reach the parent through
the pool's result pipe: the child's copy of the object, switched by :meth:`Progress.in_worker`, sends
each stage it finishes instead of drawing it, and the parent reports them as they arrive.  The live
display redirects only this process's streams (a forked child, whatever its pool, writes to the real
ones and never touches rich, whose locks it may have inherited held).
"""

from __future__ import annotations

import contextlib
import io
import itertools
import os
import sys
import time
from collections.abc import Callable

#: The environment variable overriding the mode (:func:`choose_mode`).
ENV = "GFLAT_PROGRESS"

#: The modes :data:`ENV` may name.
MODES = ("auto", "live", "plain", "off")


def choose_mode(stream=None, *, quiet: bool = False, environ=None) -> str:
    """How progress is shown on ``stream``: ``"live"``, ``"plain"`` or ``"off"``.

    Parameters
    ----------
    stream : file, optional
        Where progress goes (default ``sys.stderr``).
    quiet : bool
        ``-q`` given: ``"off"``, whatever :data:`ENV` says.
    environ : mapping, optional
        The environment (default ``os.environ``); :data:`ENV` there overrides the choice (an unknown value
        counts as ``auto``).

    Returns
    -------
    str
        ``"off"`` when quiet; else the environment's mode; else ``"live"`` when ``stream`` is a terminal
        (and ``TERM`` is not ``dumb``), ``"plain"`` otherwise.
    """
    if quiet:
        return "off"
    environ = os.environ if environ is None else environ
    asked = str(environ.get(ENV, "auto")).strip().lower()
    if asked in ("live", "plain", "off"):
        return asked
    stream = sys.stderr if stream is None else stream
    try:
        tty = bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        tty = False
    return "live" if tty and environ.get("TERM", "") != "dumb" else "plain"


def seconds_text(seconds: float) -> str:
    """A duration for a progress line: ``0.42 s``, ``12.3 s``, ``2 min 05 s``.

    Parameters
    ----------
    seconds : float

    Returns
    -------
    str
    """
    if seconds < 10:
        return f"{seconds:.2f} s"
    if seconds < 120:
        return f"{seconds:.1f} s"
    m, s = divmod(int(round(seconds)), 60)
    return f"{m} min {s:02d} s"


class _ParentStream(io.TextIOBase):
    """A stream written through rich (above the live lines) in the process that made it, straight to the real
    stream in any process forked from it."""

    def __init__(self, proxy, raw):
        super().__init__()
        self._proxy, self._raw, self._pid = proxy, raw, os.getpid()

    def _target(self):
        return self._proxy if os.getpid() == self._pid else self._raw

    def write(self, text: str) -> int:
        return self._target().write(text)

    def flush(self) -> None:
        self._target().flush()

    def fileno(self) -> int:
        return self._raw.fileno()

    def isatty(self) -> bool:
        return self._raw.isatty()

    def writable(self) -> bool:
        return True

    @property
    def encoding(self):
        return getattr(self._raw, "encoding", "utf-8")

    def __getattr__(self, name):
        return getattr(self._raw, name)


class Progress:
    """The stages of one command, shown on stderr as they run and finish (the module's three modes).

    Parameters
    ----------
    command : str
        The command's name in the lines (``"paper"``, ``"fit jsbsim"``).
    mode : {"auto", "live", "plain", "off"}
        ``"auto"``: :func:`choose_mode` of ``stream``.
    stream : file, optional
        Where the lines go (default ``sys.stderr`` when started).
    clock : callable
        Seconds, monotonic (the elapsed figures).

    Attributes
    ----------
    mode : str
        ``"live"``, ``"plain"``, ``"off"`` (or ``"worker"`` in a forked child, :meth:`in_worker`).
    lines : list of str
        Every line of a stage finished, in order, whatever the mode (a test's record, and the transcript).
    """

    def __init__(self, command: str, *, mode: str = "auto", stream=None, clock: Callable[[], float] = time.monotonic):
        if mode not in MODES:
            raise ValueError(f"progress mode {mode!r}: one of {', '.join(MODES)}")
        self.command = command
        self._stream = stream
        self.mode = choose_mode(stream) if mode == "auto" else mode
        self._clock = clock
        self._t0 = clock()
        self._ids = itertools.count(1)
        self._open: dict[int, tuple] = {}  # token -> (name, start, rich task id, total, count)
        self._live = None
        self._saved: tuple | None = None
        self._send: Callable | None = None
        self.lines: list[str] = []
        self.started = False

    # --- life ------------------------------------------------------------------------------------------

    @property
    def stream(self):
        """The stream the lines go to (``sys.stderr`` at the time of the call unless one was given)."""
        return sys.stderr if self._stream is None else self._stream

    @property
    def elapsed(self) -> float:
        """Seconds since the object was made [s]."""
        return self._clock() - self._t0

    def start(self) -> Progress:
        """Show the first line: ``started`` (plain), the live lines (live).

        Returns
        -------
        Progress
            Itself.
        """
        if self.started or self.mode in ("off", "worker"):
            self.started = True
            return self
        self.started = True
        if self.mode == "plain":
            self._plain("started")
        else:
            self._start_live()
        return self

    def _start_live(self) -> None:
        from rich.console import Console
        from rich.progress import Progress as RichProgress
        from rich.progress import SpinnerColumn, TextColumn, TimeElapsedColumn

        stream = self.stream
        console = Console(file=stream, highlight=False, soft_wrap=False)
        self._live = RichProgress(
            SpinnerColumn(),
            TextColumn("{task.description}", markup=False),
            TextColumn("{task.fields[count]}", markup=False),
            TimeElapsedColumn(),
            console=console,
            transient=True,
            refresh_per_second=4,
            redirect_stdout=False,  # redirected below, this process only (a forked child writes straight)
            redirect_stderr=False,
        )
        self._head = self._live.add_task(f"gflat {self.command}", count="")
        self._live.start()
        self._redirect(console)

    def _redirect(self, console) -> None:
        from rich.file_proxy import FileProxy

        def tty(f) -> bool:
            try:
                return bool(f.isatty())
            except (AttributeError, ValueError, OSError):
                return False

        self._saved = (sys.stdout, sys.stderr)
        # a terminal's output is printed above the live lines; a file or a pipe is left alone
        if tty(sys.stderr):
            sys.stderr = _ParentStream(FileProxy(console, sys.stderr), sys.stderr)
        if tty(sys.stdout):
            sys.stdout = _ParentStream(FileProxy(console, sys.stdout), sys.stdout)

    def close(self) -> None:
        """End the live lines (the lines of finished stages stay); the streams put back.  Idempotent."""
        for token in list(self._open):
            self.cancel(token)
        if self._live is not None:
            with contextlib.suppress(Exception):
                sys.stdout.flush()
                sys.stderr.flush()
            if self._saved is not None:
                sys.stdout, sys.stderr = self._saved
                self._saved = None
            self._live.stop()
            self._live = None

    def __enter__(self) -> Progress:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def in_worker(self, send: Callable[[tuple], None]) -> None:
        """Make this object (a forked child's copy) send each stage it finishes instead of showing it.

        Parameters
        ----------
        send : callable
            ``send(("stage", name, seconds))``: the pipe to the parent (:class:`harness.parallel.ForkPool`),
            whose :meth:`done` shows it.
        """
        self._live, self._saved, self._open = None, None, {}
        self.mode = "worker"
        self._send = send

    # --- stages ----------------------------------------------------------------------------------------

    def begin(self, name: str, total: int | None = None) -> int:
        """A stage starts: its live line (live mode); the first stage of an object not started starts it.

        Parameters
        ----------
        name : str
            What runs (``"planning gtm-forward-slip"``).
        total : int, optional
            A counted stage (:meth:`advance`): its count shown as ``k/total``.

        Returns
        -------
        int
            The token :meth:`end` takes.
        """
        if not self.started:
            self.start()
        token = next(self._ids)
        task = None
        if self._live is not None:
            task = self._live.add_task(name, count="" if total is None else f"0/{total}", total=total)
        self._open[token] = (name, self._clock(), task, total, 0)
        return token

    def advance(self, token: int, note: str = "", n: int = 1) -> None:
        """A counted stage moved on by ``n`` (a campaign's case ended): its count (live), a line (plain).

        Parameters
        ----------
        token : int
            From :meth:`begin` with a ``total``.
        note : str
            What ended (``"case twin-otter/3: done"``), in the plain line.
        n : int
        """
        if token not in self._open:
            return
        name, start, task, total, k = self._open[token]
        k += n
        self._open[token] = (name, start, task, total, k)
        count = f"{k}/{total}" if total is not None else str(k)
        if self._live is not None and task is not None:
            self._live.update(task, advance=n, count=count)
        elif self.mode == "plain":
            self._plain(f"{name} {count}" + (f": {note}" if note else ""))

    def end(self, token: int, seconds: float | None = None) -> None:
        """A stage finished: its line (its name and duration).

        Parameters
        ----------
        token : int
            From :meth:`begin`.
        seconds : float, optional
            Its duration [s] (default: since :meth:`begin`; a worker's own wall time when it ran elsewhere).
        """
        item = self._open.pop(token, None)
        if item is None:
            return
        name, start, task, total, k = item
        if self._live is not None and task is not None:
            self._live.remove_task(task)
        self.done(name, self._clock() - start if seconds is None else seconds)

    def cancel(self, token: int) -> None:
        """A stage that will not finish (an error, an interruption): its live line removed, no line left.

        Parameters
        ----------
        token : int
            From :meth:`begin`.
        """
        item = self._open.pop(token, None)
        if item is not None and self._live is not None and item[2] is not None:
            self._live.remove_task(item[2])

    def done(self, name: str, seconds: float) -> None:
        """A stage finished, here or in a worker process: its line.

        Parameters
        ----------
        name : str
            What ran.
        seconds : float
            Its duration [s].
        """
        if not self.started:
            self.start()
        if self.mode == "worker":
            if self._send is not None:
                self._send(("stage", name, float(seconds)))
            return
        text = f"{name} done in {seconds_text(seconds)}"
        self.lines.append(text)
        if self._live is not None:
            from rich.text import Text

            self._live.console.print(Text(f"[+{self.elapsed:6.1f} s] {text}"))
        elif self.mode == "plain":
            self._plain(text, record=False)

    @contextlib.contextmanager
    def stage(self, name: str):
        """A ``with`` block that is a stage: its live line meanwhile, its line when it ends (none on an error).

        Parameters
        ----------
        name : str
            What runs.

        Yields
        ------
        int
            Its token.
        """
        token = self.begin(name)
        try:
            yield token
        except BaseException:
            self.cancel(token)
            raise
        self.end(token)

    def _plain(self, text: str, record: bool = True) -> None:
        if record and text != "started":
            self.lines.append(text)
        stamp = time.strftime("%H:%M:%S")
        with contextlib.suppress(OSError, ValueError):
            stream = self.stream
            stream.write(f"[{stamp} +{self.elapsed:.1f} s] gflat {self.command}: {text}\n")
            stream.flush()


def stage(progress: Progress | None, name: str):
    """``progress.stage(name)``, or a block doing nothing without a progress.

    Parameters
    ----------
    progress : Progress or None
    name : str

    Returns
    -------
    context manager
    """
    return contextlib.nullcontext() if progress is None else progress.stage(name)
