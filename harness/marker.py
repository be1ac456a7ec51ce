"""The completion marker of a run's folder: written when the run ends, amended by files added after the run.

Every command writes its marker through :func:`write_marker` (via
:meth:`harness.outdir.OutputDir.finish`, and the campaign runner).  A run
that removes nothing of the folder's earlier run keeps that run's files
(still there) listed in its marker, whatever command -- or none, an earlier
gflat -- wrote them (:func:`earlier_files`): nothing a marker listed becomes
an unlisted file by a later run.  ``gflat report DIR`` adds files to a
finished (or interrupted) run's folder on behalf of that run: it holds the
run's folder as every run does (:func:`amending`), and its files join the
run's list (:func:`record_in_marker`), so that the run's command, run again
there, replaces or removes them as its own.
"""

from __future__ import annotations

import contextlib
import datetime
import hashlib
import json
import os
from collections.abc import Iterable, Iterator
from pathlib import Path

from gna.errors import InputError

from .fileio import replacing
from .folderlock import FolderLock
from .outguard import INCOMPLETE, MARKER, _cause, _probe, check_not_root_or_home


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def file_entry(root: Path, rel: str | Path) -> dict:
    """A marker's entry of a file: path relative to the run's top folder, sha256, size.

    Parameters
    ----------
    root : Path
        The run's top folder.
    rel : str or Path
        The file, relative to ``root``.

    Returns
    -------
    dict
        ``{"path", "sha256", "bytes"}``.
    """
    p = root / rel
    return {"path": str(rel), "sha256": _sha256(p), "bytes": p.stat().st_size}


def earlier_files(root: Path, previous: Iterable[str], written: Iterable[str | Path] = ()) -> list[str]:
    """The files of the folder's earlier run still there and not written again: those a run that removes nothing
    keeps listed in its marker, and those a run that cleans removes as stale (:meth:`harness.outdir.OutputDir.finish`).

    Parameters
    ----------
    root : Path
        The run's top folder.
    previous : iterable of str
        The earlier run's files (:attr:`harness.outguard.PreviousRun.files`).
    written : iterable of str or Path
        The files this run wrote (listed by it anyway).

    Returns
    -------
    list of str
        Those of ``previous`` still present as files inside ``root``, not written again, in order.
    """
    now = {str(p) for p in written}
    kept = []
    for rel in previous:
        if rel in now or rel in (MARKER, INCOMPLETE):
            continue
        try:
            p = (root / rel).resolve()
        except (OSError, RuntimeError):
            continue
        if p != root and p.is_relative_to(root) and p.is_file():
            kept.append(rel)
    return kept


def write_marker(root: Path, command: str | None, files: list[dict]) -> Path:
    """Write the completion marker of a run (atomically), then remove its in-progress record.

    Parameters
    ----------
    root : Path
        The run's top folder.
    command : str or None
        The command that wrote the run (``"paper"``); None through the Python API.
    files : list of dict
        The run's files (:func:`file_entry`; an entry may carry the path alone, a file that keeps changing).

    Returns
    -------
    Path
        ``<root>/.gflat-complete.json``: ``tool``, ``complete``, ``command``, ``date_utc``, ``files``.

    Raises
    ------
    InputError
        The marker cannot be written.
    """
    marker = {
        "tool": "gflat",
        "complete": True,
        "command": command,
        "date_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "files": files,
    }
    final = root / MARKER
    try:
        with replacing(final) as tmp:  # mode from the umask, like every output
            tmp.write_text(json.dumps(marker, indent=2) + "\n", encoding="utf-8")
        with contextlib.suppress(FileNotFoundError):
            (root / INCOMPLETE).unlink()  # after the marker: an interruption between keeps both lists
    except OSError as exc:
        raise InputError(f"cannot write {final}: {_cause(exc)}") from None
    return final


def run_folder(folder: Path) -> Path:
    """The top folder of the run ``folder`` belongs to: the nearest of ``folder`` and its parents holding a
    completion marker or an in-progress record (``folder`` itself when none does).

    Parameters
    ----------
    folder : Path
        A resolved folder (a run's folder, or a case folder inside one).

    Returns
    -------
    Path
    """
    return next((d for d in (folder, *folder.parents) if is_run(d)), folder)


def is_run(folder: Path) -> bool:
    """Whether ``folder`` holds a run's completion marker or in-progress record.

    Parameters
    ----------
    folder : Path
        A folder.

    Returns
    -------
    bool
    """
    return (folder / MARKER).is_file() or (folder / INCOMPLETE).is_file()


def walk_run(root: Path) -> Iterator[tuple[Path, list[str], bool]]:
    """The folders under ``root``, sorted, each with its file names and whether it is another run's top folder
    (a completion marker or an in-progress record below ``root``), not entered.

    Parameters
    ----------
    root : Path
        A folder (a run's, or one holding runs).

    Yields
    ------
    (Path, list of str, bool)
        Folder, the names of its files, whether it is another run's; symbolic links to folders are not followed.
    """
    root = Path(root)
    for here, dirs, files in os.walk(root):
        here = Path(here)
        other = here != root and (MARKER in files or INCOMPLETE in files)
        dirs[:] = [] if other else sorted(dirs)
        yield here, files, other


def runs_inside(folder: Path) -> list[Path]:
    """The run folders below ``folder`` (not ``folder`` itself), the topmost of each branch, sorted.

    Parameters
    ----------
    folder : Path
        A folder.

    Returns
    -------
    list of Path
        Folders holding a completion marker or an in-progress record; symbolic links are not followed.
    """
    return sorted(here for here, _, other in walk_run(folder) if other)


@contextlib.contextmanager
def amending(folder: str | Path) -> Iterator[Path]:
    """Hold a run's folder while files are added to it after the run (``gflat report DIR``).

    The folder must be writable; the run's top folder (:func:`run_folder`)
    and ``folder`` are locked as a run locks its folder, so that a run writing
    there meanwhile refuses to start, and this refuses while one writes.  No
    run is refused as another command's: the files added are the run's own
    (:func:`record_in_marker`).

    Parameters
    ----------
    folder : str or Path
        An existing folder: a run's, or a case folder inside one.

    Yields
    ------
    Path
        The run's top folder (resolved).

    Raises
    ------
    InputError
        ``folder`` is not a folder, is a file-system root or the home folder, takes no files, or another gflat
        run holds it (one line).
    """
    path = Path(folder).expanduser()
    if not path.is_dir():
        raise InputError(f"{folder} is not a folder")
    path = path.resolve()
    check_not_root_or_home(path, run=False)
    _probe(path)
    top = run_folder(path)
    locks = []
    try:
        for p in dict.fromkeys((top, path)):
            locks.append(FolderLock(p, advice="wait for it to end"))
        yield top
    finally:
        for lock in reversed(locks):
            lock.release()


def record_in_marker(root: str | Path, paths, removed=()) -> bool:
    """List files written into a run's folder after the run (a report rendered again) among the run's files.

    A complete run: its marker lists them (and no longer lists ``removed``);
    an interrupted run: its in-progress record does.  The next run into the
    folder then removes them as stale when it does not write them again, as it
    does the run's own files.

    Parameters
    ----------
    root : str or Path
        The run's top folder (holding ``.gflat-complete.json`` or ``.gflat-incomplete``).
    paths : iterable of Path
        Files inside ``root``.
    removed : iterable of Path
        Files inside ``root`` removed after the run (no longer listed in the marker).

    Returns
    -------
    bool
        False when the folder has neither a readable completion marker nor an in-progress record (nothing
        recorded).

    Raises
    ------
    InputError
        The marker or the record cannot be rewritten.
    """
    root = Path(root)
    top = root.resolve()
    rels = [str(Path(p).resolve().relative_to(top)) for p in paths]
    gone = {str(Path(p).resolve().relative_to(top)) for p in removed}
    try:
        marker = json.loads((root / MARKER).read_text(encoding="utf-8"))
        files = [f for f in marker["files"] if isinstance(f, dict) and "path" in f]
    except (OSError, ValueError, TypeError, KeyError):
        return _record_in_progress(root, rels)
    files = [f for f in files if str(f["path"]) not in gone and str(f["path"]) not in rels]
    files += [file_entry(top, rel) for rel in rels]
    marker["files"] = files
    try:
        with replacing(root / MARKER) as tmp:
            tmp.write_text(json.dumps(marker, indent=2) + "\n", encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot write {root / MARKER}: {_cause(exc)}") from None
    return True


def _record_in_progress(root: Path, rels: list[str]) -> bool:
    """Append files to an interrupted run's in-progress record (False: no record)."""
    if not (root / INCOMPLETE).is_file():
        return False
    text = "".join(json.dumps(rel) + "\n" for rel in rels)
    try:
        with open(root / INCOMPLETE, "a+b") as fh:
            fh.seek(0)
            before = fh.read()
            if before and not before.endswith(b"\n"):  # a line cut short by the interruption stays apart
                text = "\n" + text
            fh.write(text.encode("utf-8"))
    except OSError as exc:
        raise InputError(f"cannot write {root / INCOMPLETE}: {_cause(exc)}") from None
    return True
