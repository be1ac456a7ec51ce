"""What an output folder must not be, before a run writes there: a root or the home folder, another command's
run, a folder inside another run's folder, a folder another run is writing.

Four checks of :class:`harness.outdir.OutputDir`, made before anything is
computed or written, each refused with one line (:class:`gna.errors.InputError`,
exit status 2 at the command line):

* a file-system root (``/``) or the user's home folder itself: a run removes
  the files its earlier runs wrote there, and such a folder is nobody's run;
* a folder holding the files of a run (complete: ``.gflat-complete.json``;
  interrupted: ``.gflat-incomplete``) of another command: a run removes the
  files of the folder's earlier run it does not write again, so ``gflat plan``
  into a ``gflat paper`` folder would delete most of the paper's results.  The
  marker and the in-progress record name the command that wrote them; a
  record naming none (written by an earlier gflat, or through the Python API)
  is refused to a command that would remove its files;
* a folder inside another run's folder (a parent folder holds a completion
  marker or an in-progress record, or is being written by a run): the new
  files would land among that run's, whose index and marker would show or
  vouch for them (:func:`check_not_inside_run`).  A run's own sub-folders
  (the case folders ``gflat paper`` writes) are written through its own
  :class:`harness.outdir.OutputDir` and are not checked again;
* a folder another run is writing: the run holds an exclusive ``flock`` on
  the folder itself (no lock file) from the moment the folder is checked to
  the end of the run; the operating system drops it when the process ends,
  however it ends (error, Ctrl-C, a kill).
"""

from __future__ import annotations

import errno
import json
import os
import stat
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from gna.errors import InputError, describe

from .folderlock import is_held

#: Name of the completion marker written by :meth:`harness.outdir.OutputDir.finish`.
MARKER = ".gflat-complete.json"

#: Name of the in-progress record (one JSON string per line: paths relative to the top folder; a first
#: line ``{"command": ...}`` names the command writing).
INCOMPLETE = ".gflat-incomplete"

_ADVICE = "give another folder with --out, or remove this one first"


def _cause(exc: OSError) -> str:
    """The OS error's meaning: "No such file or directory" creating a name in a folder that exists (procfs)
    means the file system creates nothing there."""
    name = exc.filename if isinstance(exc.filename, (str, Path)) else None
    if exc.errno == errno.ENOENT and name is not None and not os.path.islink(name):
        folder = Path(os.path.abspath(name)).parent
        if folder.is_dir():
            return f"{folder} exists, but its file system creates no new files or folders there"
    return describe(exc)


def _write_probe(folder: Path) -> None:
    """Make and remove a small file in ``folder`` (OSError where it takes no files)."""
    fd, name = tempfile.mkstemp(prefix=".gflat-probe-", dir=folder)
    os.close(fd)
    os.unlink(name)


def _probe(path: Path, target: Path | None = None) -> None:
    """Write and remove a small file in ``path`` (``target``'s nearest existing folder, when it does not exist
    yet): catches read-only folders and file systems (/proc, /sys), whoever runs."""
    try:
        _write_probe(path)
    except OSError as exc:
        where = (
            f"{path}: cannot write there"
            if target is None or target == path
            else f"{target}: cannot create it, its nearest existing folder {path} takes no files"
        )
        raise InputError(f"output folder {where}: {_cause(exc)}") from None


def _few(names: list[str], n: int = 3) -> str:
    return ", ".join(names[:n]) + (", ..." if len(names) > n else "")


def check_destination(path: Path, parents: bool = False) -> None:
    """Refuse a root, the home folder, a file, a missing parent (unless ``parents``), a folder that takes no files.

    Parameters
    ----------
    path : Path
        The resolved folder.
    parents : bool
        Missing parent folders will be made.

    Raises
    ------
    InputError
        ``path`` is a root (``/``, a drive) or the home folder, lies inside another run's folder
        (:func:`check_not_inside_run`), is a file, has
        no parent folder, or it (or its nearest existing folder) cannot be written.
    """
    check_not_root_or_home(path)
    check_not_inside_run(path)
    if path.exists() and not path.is_dir():
        raise InputError(f"output folder {path}: a file of that name exists (not a folder)")
    if path.exists():
        _probe(path)
        return
    parent = path.parent
    if not parent.is_dir() and not parents:
        what = "is a file" if parent.exists() else "does not exist"
        raise InputError(f"output folder {path}: its parent folder {parent} {what}")
    while not parent.exists():  # nearest existing ancestor (with ``parents``)
        parent = parent.parent
    if not parent.is_dir():
        raise InputError(f"output folder {path}: {parent} is a file, not a folder")
    _probe(parent, path)


_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a named pipe (fifo)"),
    (stat.S_ISSOCK, "a socket"),
)


def check_output_file(path: Path) -> None:
    """Refuse, before any work, a file that could not (or must not) be written: anything there but a regular file
    (a device, a pipe, a socket, a folder, a link to one), a folder of a gflat run, a folder missing, a file, or
    taking no files.

    The file is written later through :func:`harness.fileio.replacing` (a temporary file beside it, renamed
    over it, which would replace ``/dev/null`` by a file): a probe file made and removed in its folder now
    catches what would refuse it then.  A run's folder (or one inside it) holds that run's files only: the
    run's command, run again, would remove a file it did not write, or ``gflat report`` read it as the run's.

    Parameters
    ----------
    path : Path
        The file to write (as given: the message names it so).

    Raises
    ------
    InputError
        ``cannot write <path>: <cause>`` (one line).
    """
    try:
        mode = os.stat(path).st_mode  # through a link: what the name stands for
    except FileNotFoundError:  # missing (or a dangling link, replaced)
        mode = None
    except OSError as exc:
        raise InputError(f"cannot write {path}: {_cause(exc)}") from None
    if mode is not None and not stat.S_ISREG(mode):
        kind = next((k for test, k in _KINDS if test(mode)), "a special file")
        link = "a symbolic link to " if path.is_symlink() else ""
        raise InputError(
            f"cannot write {path}: it is {link}{kind}, not a regular file (it would be replaced "
            f"by one): give the path of a new or regular file"
        )
    try:
        found = enclosing_run(path.resolve())
    except (OSError, RuntimeError):  # a loop of links: the probe write names it
        found = None
    if found is not None:
        raise InputError(
            f"cannot write {path}: {found[0]} is the folder of {found[1]}, which holds that run's "
            f"files only: give a path outside it"
        )
    try:
        _write_probe(path.parent)
    except OSError as exc:
        raise InputError(f"cannot write {path}: {_cause(exc)}") from None


def make_folder(path: Path) -> list[Path]:
    """Make ``path`` and its missing parents.

    Parameters
    ----------
    path : Path
        The folder.

    Returns
    -------
    list of Path
        The folders made, deepest first (another run may have made some meanwhile: not listed).

    Raises
    ------
    InputError
        A folder cannot be made.
    """
    made = []
    for folder in reversed([p for p in (path, *path.parents) if not p.exists()]):
        try:
            folder.mkdir()
        except FileExistsError:
            continue
        except OSError as exc:
            raise InputError(f"output folder {path}: cannot create it: {_cause(exc)}") from None
        made.append(folder)
    return made[::-1]


def check_not_root_or_home(path: Path, run: bool = True) -> None:
    """Refuse a file-system root or the user's home folder itself (its sub-folders are fine).

    Parameters
    ----------
    path : Path
        The resolved folder.
    run : bool
        The folder is a new run's output folder (the message suggests another ``--out``); else a run's folder
        to read (``gflat report DIR``).

    Raises
    ------
    InputError
        One line naming the folder and what to give instead.
    """
    if path == Path(path.anchor):
        what = "a file-system root"
    else:
        try:
            home = Path.home().resolve()
        except (OSError, RuntimeError, KeyError):  # no home folder known
            return
        if path != home:
            return
        what = "your home folder itself"
    if run:
        eg = "--out ./out" if what.startswith("a file") else "--out ~/gflat-out"
        raise InputError(
            f"output folder {path}: {what} is not an output folder (a run removes its earlier files "
            f"there); give a folder of its own, e.g. {eg}"
        )
    raise InputError(
        f"{path}: {what} is no run's output folder (a run is never written there); give the run's "
        f"folder, the --out of gflat paper or gflat compare"
    )


def enclosing_run(path: Path) -> tuple[Path, str] | None:
    """The nearest parent folder of ``path`` that is another run's: it holds a completion marker or an
    in-progress record, or a gflat run is writing it.

    Parameters
    ----------
    path : Path
        A resolved folder (existing or not); only its parents are looked at.

    Returns
    -------
    (Path, str) or None
        The parent folder and what makes it a run's (``"a complete run of 'gflat paper'"``,
        ``"an interrupted run"``, ``"a running gflat"``), or None.
    """
    for folder in path.parents:
        if not folder.is_dir():
            continue
        complete, interrupted = (folder / MARKER).is_file(), (folder / INCOMPLETE).is_file()
        if complete or interrupted:
            prev = previous_run(folder)
            what = "a complete run" if complete and not interrupted else "an interrupted (or running) run"
            return folder, what + (f" of 'gflat {prev.command}'" if prev.command else "")
        if is_held(folder):
            return folder, "a gflat run writing it now"
    return None


def check_not_inside_run(path: Path) -> None:
    """Refuse an output folder inside another run's folder (:func:`enclosing_run`).

    A run writing into another run's case folders would have its files shown
    by that run's index and vouched for by its marker (or removed by its next
    run); a run's own sub-folders are written through its own
    :class:`harness.outdir.OutputDir` and never come here.

    Parameters
    ----------
    path : Path
        The resolved output folder.

    Raises
    ------
    InputError
        One line naming the folder, the run's folder and what to do.
    """
    found = enclosing_run(path)
    if found is not None:
        folder, what = found
        raise InputError(
            f"output folder {path} lies inside {folder}, the folder of {what}: a new run there "
            f"would mix its files with that run's; give a folder outside it with --out"
        )


@dataclass
class PreviousRun:
    """The files of the runs written into a folder before (completion marker, then in-progress record).

    Attributes
    ----------
    files : list of str
        Paths relative to the folder, in order, each once.
    command : str or None
        The command that wrote them (``"paper"``), None when the marker and record name none.
    complete : bool
        A completion marker was read (else the files, if any, are an interrupted run's).
    """

    files: list[str] = field(default_factory=list)
    command: str | None = None
    complete: bool = False


def previous_run(root: Path) -> PreviousRun:
    """Read the completion marker and any in-progress record of ``root``.

    Parameters
    ----------
    root : Path
        The folder.

    Returns
    -------
    PreviousRun
        Empty when the folder holds neither (or they cannot be read).
    """
    prev = PreviousRun()
    try:
        data = json.loads((root / MARKER).read_text(encoding="utf-8"))
        prev.files += [str(f["path"]) for f in data.get("files", []) if isinstance(f, dict) and "path" in f]
        prev.command = data.get("command") if isinstance(data.get("command"), str) else None
        prev.complete = True
    except (OSError, ValueError, TypeError, AttributeError):
        pass
    try:
        lines = (root / INCOMPLETE).read_text(encoding="utf-8").splitlines()
    except (OSError, ValueError):
        lines = []
    for line in lines:
        try:
            item = json.loads(line)
        except ValueError:  # a line cut short by an interruption
            continue
        if isinstance(item, str):
            prev.files.append(item)
        elif isinstance(item, dict) and isinstance(item.get("command"), str) and not prev.complete:
            prev.command = item["command"]
    prev.files = list(dict.fromkeys(prev.files))
    return prev


def check_previous(root: Path, prev: PreviousRun, command: str | None, clean: bool) -> None:
    """Refuse a folder holding the files of another command's run (or of a run naming no command, when they would
    be removed).

    Parameters
    ----------
    root : Path
        The folder.
    prev : PreviousRun
        Its earlier run (:func:`previous_run`).
    command : str or None
        The command about to write (``"plan"``); None through the Python API.
    clean : bool
        Whether this run removes the earlier run's files it does not write again.

    Raises
    ------
    InputError
        One line naming the folder, the command that wrote it and what to do.
    """
    present = [f for f in prev.files if f not in (MARKER, INCOMPLETE) and (root / f).is_file()]
    if not present:  # nothing of an earlier run left to lose
        return
    what = "a complete run" if prev.complete else "an interrupted run"
    me = f"'gflat {command}'" if command else "this run"
    if prev.command is not None and prev.command != command:
        does = "would remove those it does not write again" if clean else "would mix its files with them"
        raise InputError(
            f"output folder {root} holds {what} of 'gflat {prev.command}' ({len(present)} files); "
            f"{me} {does}: {_ADVICE}"
        )
    if prev.command is None and command is not None and clean:
        raise InputError(
            f"output folder {root} holds {what} whose marker names no command (an earlier gflat, "
            f"or the Python API): {me} would remove those of its {len(present)} files it does not "
            f"write again ({_few(present)}): {_ADVICE}"
        )
