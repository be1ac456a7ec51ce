"""The ``gflat`` command-line tool.

Each sub-command lives in a module of :mod:`harness.commands` exposing
``register(subparsers)``; the module adds its parser and sets ``func`` to a
callable ``func(args) -> int``; a new command is its module plus one line of
:data:`COMMANDS`.  A command's module is imported only when that command runs (or
shows its ``--help``): ``gflat --help`` lists the commands from the static table
:data:`COMMANDS`, and ``gflat --version`` loads none of them (nor numpy).

Errors gflat raises on purpose (:class:`gna.errors.GflatError`) are printed as
one line naming the cause, with exit status 2; anything else is a bug and keeps
its traceback.  With ``--json`` (every command has it,
:mod:`harness.commands._json`) stdout carries exactly one JSON object: the
command's result, or on an error ``{"command", "error", "exit_status"}``; the
text the command prints goes to stderr.

Exit status (:data:`EXIT_CODES`): 0 success; 1 the work ran but its verdict is
negative (a validation FAIL, an infeasible plan, a trim that does not
converge, stale files under ``--check``); 2 a usage or input error (bad option, bad file, bad value), no
result; 130 interrupted (Ctrl-C), 143 terminated (SIGTERM) and 129 hung up (SIGHUP), both handled like
Ctrl-C (a run's staging folder removed; an ignored SIGHUP, under ``nohup``, stays ignored); the first of
these signals counts, a second one waits for its cleanup.  An option error (argparse's) is one line too, ``gflat <cmd>: error: <message> (see gflat <cmd>
--help)``, exit status 2.  ``-v``/``-q`` set the level of the ``logging``
messages (and of Python warnings, routed through ``logging``), on stderr.

The long commands (:data:`PROGRESS_COMMANDS`) show their stages on stderr (:mod:`harness.progress`): the
:class:`~harness.progress.Progress` is made and its first line shown as soon as the words are read, before the
command's modules load, and handed to the command as ``args.progress``; ``-q`` silences it.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import os
import re
import signal
import sys
import time
from collections.abc import Sequence

from gna.errors import GflatError, describe

from .progress import Progress

#: Exit statuses of ``gflat``, documented in ``gflat --help`` and the README.
EXIT_CODES: dict[int, str] = {
    0: "success",
    1: "the work ran but its verdict is negative: validation FAIL, infeasible plan, trim not converged, "
    "stale files (--check)",
    2: "usage or input error (bad option, file or value): one line names the cause, nothing is computed",
    130: "interrupted (Ctrl-C)",
    129: "hung up (SIGHUP), handled as Ctrl-C",
    143: "terminated (SIGTERM), handled as Ctrl-C: nothing left half-written",
}

#: The signals raised as :class:`Terminated` while a command runs (SIGHUP where the platform has it).
TERMINATING = tuple(s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s is not None)

#: Numbers such as -1, -0.5, -1e-3, -.5E+2 are option values, not option names.
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


class GflatParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` reading ``--gamma -1e-3`` as a negative number, its errors in one line.

    argparse's own test for negative numbers (``-1``, ``-0.5``) misses the exponent form; no gflat
    option name looks like a number, so every such word is a value.  An option error prints
    ``gflat <cmd>: error: <message> (see gflat <cmd> --help)`` (no usage block) and exits with status 2;
    ``--help`` is argparse's own.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE_NUMBER
        self.error_prog: str | None = None  # the command the words name, for errors found at the top level

    def error(self, message: str):
        """Print the one-line error and exit with status 2 (argparse's hook).

        Parameters
        ----------
        message : str
            argparse's message.
        """
        prog = self.error_prog or self.prog
        self.exit(2, f"{prog}: error: {' '.join(str(message).split())} (see {prog} --help)\n")


def _named_prog(parser: argparse.ArgumentParser, words: Sequence[str]) -> str:
    """The ``prog`` of the deepest (sub-)command ``words`` name (``gflat campaign run``), else the parser's."""
    for word in words:
        if word == "--":
            continue
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if subs and not word.startswith("-") and word in subs[0].choices:
            parser = subs[0].choices[word]
    return parser.prog


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("gflat")
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a source tree without install
        return "unknown"


class _VersionAction(argparse.Action):
    """``--version``: print ``gflat <version>`` and exit 0, reading the version only when asked."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"gflat {_version()}")
        parser.exit()


def _add_verbosity(parser: argparse.ArgumentParser, default) -> None:
    group = parser.add_argument_group("messages")
    group.add_argument(
        "-v", "--verbose", action="count", default=default, help="more messages on stderr (-v: progress, -vv: debug)"
    )
    group.add_argument(
        "-q",
        "--quiet",
        action="count",
        default=default,
        help="fewer messages on stderr (-q: errors only, warnings hidden)",
    )


def _subparsers(parser: argparse.ArgumentParser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for p in dict.fromkeys(action.choices.values()):
                yield p
                yield from _subparsers(p)


#: Command name -> (its module, its one-line help), in the order ``gflat --help`` lists them.  The help
#: lines are the ones each module's ``register`` gives (a test keeps the two in step), so that the list
#: needs no command module.
COMMANDS: dict[str, tuple[str, str]] = {
    "aircraft": ("harness.commands.aircraft", "list the aircraft and their provenance"),
    "trim": ("harness.commands.trim", "steady flight (trim) of an aircraft"),
    "plan": ("harness.commands.plan", "plan a manoeuvre (flatness + generalized flatness)"),
    "compare": ("harness.commands.compare", "fly a plan on several engines, open or closed loop, and compare them"),
    "paper": ("harness.commands.paper", "plan the paper's three manoeuvres and fly them on both engines"),
    "report": ("harness.commands.report", "render a run's HTML and PDF reports again from its saved results"),
    "export-jsbsim": ("harness.commands.export_jsbsim", "write the JSBSim aircraft files (aircraft_xml/<id>/<id>.xml)"),
    "export-jsbsim-script": (
        "harness.commands.export_script",
        "write a plan as a JSBSim script (aircraft, initialization, control tables, CSV output)",
    ),
    "fit": ("harness.commands.fit", "fit GNA aerodynamic parameters to a source model"),
    "campaign": ("harness.commands.campaign", "validation campaigns: many cases over dispersed aircraft"),
}


def command_word(argv: Sequence[str]) -> str | None:
    """The sub-command ``argv`` names: its first word that is not an option (the top-level options take no value).

    Parameters
    ----------
    argv : sequence of str
        The command-line words after ``gflat``.

    Returns
    -------
    str or None
        That word (an unknown command too), or None when there is none (``gflat --version``).
    """
    words = list(argv)
    for i, word in enumerate(words):
        if word == "--":
            return words[i + 1] if i + 1 < len(words) else None
        if not word.startswith("-"):
            return word
    return None


#: The long commands, whose stages are shown as they run (:mod:`harness.progress`): command -> the sub-commands
#: that are (None: the command itself).
PROGRESS_COMMANDS: dict[str, tuple[str, ...] | None] = {
    "paper": None,
    "compare": None,
    "report": None,
    "fit": ("jsbsim",),
    "campaign": ("run",),
}


def progress_command(argv: Sequence[str]) -> str | None:
    """The long command ``argv`` names (``"paper"``, ``"fit jsbsim"``), read before any command module loads.

    Parameters
    ----------
    argv : sequence of str
        The command-line words after ``gflat``.

    Returns
    -------
    str or None
        None for another command, ``--help``, or ``-q``/``--quiet`` (no progress).
    """
    words = list(argv)
    if any(w in ("-h", "--help") or re.fullmatch(r"-q+", w) or w == "--quiet" for w in words):
        return None
    name = command_word(words)
    if name not in PROGRESS_COMMANDS:
        return None
    subs = PROGRESS_COMMANDS[name]
    if subs is None:
        return name
    sub = command_word(words[words.index(name) + 1 :])
    return f"{name} {sub}" if sub in subs else None


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``gflat`` parser, with the sub-command that ``argv`` names loaded.

    Every command of :data:`COMMANDS` is listed; only the loaded ones have their options (and their
    modules imported).

    Parameters
    ----------
    argv : sequence of str, optional
        The command-line words: only the command they name is loaded (none for ``--version``,
        ``--help`` or an unknown command).  Default: every command.

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = GflatParser(
        prog="gflat",
        description="Flatness-based motion planning of aircraft (GNA aerodynamics) and its validation "
        "across dynamics engines.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="every command takes --json (one JSON object on stdout, its text on stderr) and --help (its options "
        "and examples)\n\nexit status:\n" + "\n".join(f"  {k:<4} {v}" for k, v in EXIT_CODES.items()),
    )
    parser.add_argument("--version", action=_VersionAction, help="show program's version number and exit")
    _add_verbosity(parser, 0)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    wanted = set(COMMANDS) if argv is None else {command_word(argv)}
    for name, (module, help_line) in COMMANDS.items():
        if name in wanted:
            importlib.import_module(module).register(sub)
        else:
            sub.add_parser(name, help=help_line)  # listed only: never chosen, since argv names another
    for p in _subparsers(parser):  # -v/-q also after the sub-command (counted there)
        _add_verbosity(p, argparse.SUPPRESS)
    if argv is not None:  # "unrecognized arguments" is found by the top parser: named after the command
        parser.error_prog = _named_prog(parser, argv)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM (or SIGHUP) received by ``gflat``: raised like Ctrl-C, so that every cleanup of an interruption
    runs (a run's staging folder removed, worker processes ended); exit status 128 + the signal's number.

    Parameters
    ----------
    signum : int
        The signal received.
    """

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def _signals_raise():
    """Within the block Ctrl-C raises ``KeyboardInterrupt`` and the :data:`TERMINATING` signals raise
    :class:`Terminated`, once: a second interruption (Ctrl-C pressed twice, SIGTERM sent to the whole process
    group) waits for the first one's cleanup instead of cutting it short.  A signal ignored when the block
    starts (SIGHUP under ``nohup``) stays ignored; a forked child that inherited the handlers gets the
    previous ones back (it dies of SIGTERM, or raises ``KeyboardInterrupt`` on Ctrl-C, as before).  The
    previous handlers are put back after the block."""
    pid = os.getpid()
    first: list[int] = []
    old: dict = {}

    def handler(signum, frame):
        if os.getpid() != pid:  # a worker forked from this process: the handler it had before
            signal.signal(signum, old.get(signum, signal.SIG_DFL))
            os.kill(os.getpid(), signum)
            return
        if first:  # the first interruption's cleanup runs on
            return
        first.append(signum)
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        raise Terminated(signum)

    try:
        for sig in (signal.SIGINT, *TERMINATING):
            if signal.getsignal(sig) not in (signal.SIG_IGN, None):
                old[sig] = signal.signal(sig, handler)
    except ValueError:  # not the main thread (gflat run in-process from a thread): left as they are
        pass
    try:
        yield
    finally:
        for sig, previous in old.items():
            signal.signal(sig, previous)


class _StderrHandler(logging.StreamHandler):
    """A handler writing to whatever ``sys.stderr`` is when a record is emitted.

    ``gflat`` run in-process (tests, notebooks) may see ``sys.stderr`` replaced and the old stream closed; a
    handler bound to the stream of the first call would then fail on every later message.
    """

    def __init__(self):
        super().__init__(sys.stderr)

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):  # logging.StreamHandler.__init__ assigns it; the property always reads sys.stderr
        pass


def setup_logging(verbose: int, quiet: int) -> int:
    """Send ``logging`` messages (and Python warnings) to stderr at the level ``-v``/``-q`` choose.

    Parameters
    ----------
    verbose : int
        Number of ``-v`` (1: INFO, 2: DEBUG).
    quiet : int
        Number of ``-q`` (1: ERROR only, warnings hidden).

    Returns
    -------
    int
        The ``logging`` level set.
    """
    level = min(max(logging.WARNING - 10 * verbose + 10 * quiet, logging.DEBUG), logging.CRITICAL)
    logger = logging.getLogger()
    for h in list(logger.handlers):
        if getattr(h, "gflat", False):
            logger.removeHandler(h)
    handler = _StderrHandler()
    handler.gflat = True
    handler.setFormatter(logging.Formatter("gflat: %(levelname)s: %(message)s"))
    logger.addHandler(handler)
    logger.setLevel(level)
    # gflat's own progress lines (a long plan's iterates) are INFO and shown by default; other libraries'
    # INFO (Dask, matplotlib) only with -v
    ours = logging.INFO if (verbose, quiet) == (0, 0) else level
    for name in ("gna", "planners", "harness", "reports"):
        logging.getLogger(name).setLevel(ours)
    logging.captureWarnings(True)
    return level


def main(argv: list[str] | None = None) -> int:
    """Run ``gflat`` with the command-line words ``argv``.

    Parameters
    ----------
    argv : list of str, optional
        Default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status (:data:`EXIT_CODES`).
    """
    words = sys.argv[1:] if argv is None else list(argv)
    name = progress_command(words)
    # the first progress line at once, before the command's modules (numpy, the planner, matplotlib) load
    progress = Progress(name or "", mode="auto" if name else "off")
    with _signals_raise(), progress:
        try:
            with progress.stage("loading the command's modules"):
                parser = build_parser(words)
        except GflatError as exc:  # a setting read at import (e.g. GFLAT_SERIES_BACKEND)
            print(f"gflat: error: {exc}", file=sys.stderr)
            return 2
        except KeyboardInterrupt as exc:  # while the command's modules load
            return _interrupted(exc)
        return _run(parser, words, progress)


def _one_line(text: str) -> str:
    """``text`` on one line: a line break inside it (a file name holding one) written as ``\\n``."""
    return text.replace("\r", "\\r").replace("\n", "\\n")


def _interrupted(exc: KeyboardInterrupt) -> int:
    """The one line and exit status of an interruption: 143 for SIGTERM, 129 for SIGHUP, 130 for Ctrl-C."""
    if isinstance(exc, Terminated):
        what = "hung up" if exc.signum == getattr(signal, "SIGHUP", None) else "terminated"
        print(f"gflat: {what} ({signal.Signals(exc.signum).name})", file=sys.stderr)
        return 128 + exc.signum
    print("gflat: interrupted", file=sys.stderr)
    return 130


def _run(parser: argparse.ArgumentParser, words: list[str], progress: Progress) -> int:
    """Parse ``words`` and run the command they name (:func:`main`'s body, SIGTERM raising meanwhile).

    With ``--json`` the command's printed text goes to stderr and its result (or, on an error or an
    interruption, ``{"command", "error", "exit_status"}``) is the one JSON object on stdout
    (:mod:`harness.commands._json`).  The command reports its stages to ``args.progress``.
    """
    if sys.stdout is None:  # started with its standard output closed (>&-): what it prints would be lost
        if sys.stderr is not None:
            print(
                "gflat: error: the standard output is closed, so nothing gflat prints could be read: "
                "run it with an open one (> FILE, or > /dev/null to discard it)",
                file=sys.stderr,
            )
        return 2
    args = parser.parse_args(words)
    args.command_line = ["gflat", *words]  # recorded in manifests
    args.progress = progress
    json_mode = bool(getattr(args, "json", False))
    args.json_stream = sys.stdout  # the command's JSON result goes here, whatever it prints meanwhile
    name = " ".join(
        [args.command] + [v for v in (getattr(args, "campaign_command", None), getattr(args, "source", None)) if v]
    )
    restore = _logging_state()
    setup_logging(args.verbose, args.quiet)
    log = logging.getLogger("gflat")
    start = time.perf_counter()

    def failed(message: str, status: int) -> int:
        print(message, file=sys.stderr)
        if json_mode and not getattr(args, "json_emitted", False):
            _json_error(args, name, message, status)
        return status

    try:
        with _stdout_to_stderr(args) if json_mode else contextlib.nullcontext():
            status = int(args.func(args) or 0)
        log.info("%s: done in %.2f s, exit status %d", args.command, time.perf_counter() - start, status)
        return status
    except GflatError as exc:
        return failed(_one_line(f"gflat {args.command}: error: {exc}"), 2)
    except OSError as exc:  # an output that cannot be written (missing or read-only folder, a file in the way)
        return failed(
            _one_line(f"gflat {args.command}: error: cannot write {exc.filename or 'the output'}: {describe(exc)}"), 2
        )
    except KeyboardInterrupt as exc:
        status = _interrupted(exc)
        if json_mode and not getattr(args, "json_emitted", False):
            _json_error(args, name, "interrupted", status)
        return status
    finally:
        restore()  # run in-process (tests, notebooks), gflat leaves logging as it found it


@contextlib.contextmanager
def _stdout_to_stderr(args):
    """Within the block whatever is printed goes to stderr, and ``args.json_stream`` is the real stdout.

    When stdout and stderr are the process's own (file descriptors 1 and 2), the redirection is made on the
    descriptors too, so that a library printing from C or C++ (JSBSim) or a child process cannot add text to
    the JSON on stdout; otherwise (gflat run in-process, streams replaced) on ``sys.stdout`` only.
    """
    try:
        descriptors = sys.stdout.fileno() == 1 and sys.stderr.fileno() == 2
    except (AttributeError, OSError, ValueError):  # a stream without a descriptor (a test's capture, a notebook)
        descriptors = False
    if not descriptors:
        with contextlib.redirect_stdout(sys.stderr):
            yield
        return
    sys.stdout.flush()
    saved = os.dup(1)
    args.json_stream = os.fdopen(saved, "w", encoding="utf-8", closefd=False)
    os.dup2(2, 1)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        sys.stdout.flush()
        args.json_stream.flush()
        os.dup2(saved, 1)
        os.close(saved)
        args.json_stream = sys.stdout  # an error's object, written after the block


def _json_error(args, name: str, message: str, status: int) -> None:
    """The ``--json`` object of a command that failed: its name, the one-line message, the exit status."""
    import json

    args.json_stream.write(json.dumps({"command": name, "error": message, "exit_status": status}) + "\n")
    args.json_stream.flush()


def _logging_state():
    """A function putting back the logging configuration :func:`setup_logging` changes."""
    root = logging.getLogger()
    names = ("gna", "planners", "harness", "reports")
    levels = root.level, {n: logging.getLogger(n).level for n in names}

    def restore():
        for h in [h for h in root.handlers if getattr(h, "gflat", False)]:
            root.removeHandler(h)
        root.setLevel(levels[0])
        for n, level in levels[1].items():
            logging.getLogger(n).setLevel(level)
        logging.captureWarnings(False)

    return restore


if __name__ == "__main__":
    sys.exit(main())
