"""Output folders: checked before any work, every file written atomically, nothing written outside the root.

:class:`OutputDir` is the one way the command line writes files.  The folder is
checked when the object is made, so that a bad ``--out`` is one clear error
before planning or flying; a missing folder is created only when the first
file is written, so a run that fails before writing leaves nothing.  Every file is written to a temporary
name in its final folder and renamed over its final name (``os.replace``,
atomic on POSIX), so a run never leaves a half-written file under its final
name.  :meth:`OutputDir.finish` writes the completion marker
``.gflat-complete.json`` (files written, their sha256, UTC time); a folder
without it holds an interrupted set.  At the first file a run writes, the
marker is replaced by the in-progress record ``.gflat-incomplete``: the
command writing, the files of earlier runs (complete marker and any earlier
in-progress record), then one line per file this run writes.  :meth:`OutputDir.finish` removes every file
those lists name that this run did not write (never anything else, so files
the user put there stay), writes the marker and removes the record: no stale
file of an earlier run, complete or interrupted, survives next to new ones; a
warning names how many it removed.

The marker and the record name the command that wrote them; before any work,
:mod:`harness.outguard` refuses a root or the home folder, a folder holding
another command's run, and a folder another run is writing (the run locks the
folder until :meth:`OutputDir.finish` or :meth:`OutputDir.release`, or its end).
A missing folder is made at once, to be locked, and removed again when the run
ends without writing anything.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import weakref
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from gna.errors import InputError, describe

from .fileio import json_safe, remove_empty_folders, replacing
from .folderlock import FolderLock
from .marker import earlier_files, file_entry, write_marker
from .outguard import INCOMPLETE, MARKER, _cause, _few, check_destination, check_previous, make_folder, previous_run

__all__ = ["INCOMPLETE", "MARKER", "OutputDir"]

_log = logging.getLogger(__name__)

#: The pages a run's report renders after :meth:`OutputDir.finish` (:mod:`reports.html`: index and case pages,
#: listed in the marker): removed as stale without mention, the report writes them again (or none, with its case).
REPORT_PAGES = frozenset(("index.html", "case.html"))


class _Record:
    """What a set of OutputDir objects (a root and its sub-folders) share."""

    def __init__(self, root: Path, previous: list[str], command: str | None = None, marker: bool = True):
        self.root = root
        self.previous = previous
        self.command = command
        self.marker = marker
        self.written: list[Path] = []
        self.started = False
        self.release = lambda: None


class OutputDir:
    """An output folder: checked before any work, every file written atomically, nothing outside the root.

    Parameters
    ----------
    root : str or Path
        The folder (its parent must exist unless ``parents``); created, if
        missing, at once, and removed again if the run ends without writing.
    clean : bool
        Remove, in :meth:`finish`, the files earlier runs wrote (listed by the
        completion marker or an interrupted run's in-progress record) that this
        run did not write.  Without it they stay, and stay listed in the marker
        (:func:`harness.marker.earlier_files`).
    parents : bool
        Create missing parent folders too (for default output folders);
        without it a missing parent is refused.
    command : str, optional
        The command writing (``"paper"``), recorded in the marker; a folder
        holding another command's run is refused
        (:func:`harness.outguard.check_previous`).  None through the Python API.
    marker : bool
        Keep the in-progress record and write the completion marker; without
        it (a folder tracked in git, such as ``aircraft_xml/``) files are only
        written atomically, nothing is removed and :meth:`finish` only releases
        the folder.

    Raises
    ------
    InputError
        ``root`` exists and is not a folder, its parent is missing or
        read-only, the folder cannot be written, is a root or the home folder,
        holds another command's run or is being written by another run (one
        line naming the path and the cause).

    Attributes
    ----------
    root : Path
        The resolved folder.
    written : list of Path
        Paths (relative to the top folder) written so far, in order.
    """

    def __init__(
        self,
        root: str | Path,
        *,
        clean: bool = True,
        parents: bool = False,
        command: str | None = None,
        marker: bool = True,
        _record: _Record | None = None,
    ):
        path = Path(root).expanduser()
        try:
            path = path.resolve()
        except (OSError, RuntimeError) as exc:
            raise InputError(f"output folder {root}: cannot resolve the path ({describe(exc)})") from None
        self.root = path
        self.clean = clean and marker
        if _record is not None:
            self._record = _record
            return
        check_destination(path, parents)
        lock = FolderLock(path, make_folder(path))  # refused while another run writes there
        prev = previous_run(path)
        self._record = _Record(path, prev.files, command, marker)
        self._record.release = weakref.finalize(self._record, lock.release)  # also when collected, and at exit
        try:
            check_previous(path, prev, command, self.clean)
        except InputError:
            self.release()
            raise

    # ---- checks ----------------------------------------------------------------------------------
    @staticmethod
    def _mkdir(path: Path, parents: bool) -> None:
        try:
            path.mkdir(parents=parents, exist_ok=True)
        except FileExistsError:
            raise InputError(f"output folder {path}: a file is in the way of the folder") from None
        except OSError as exc:
            raise InputError(f"output folder {path}: cannot create it: {_cause(exc)}") from None

    # ---- paths -----------------------------------------------------------------------------------
    @property
    def written(self) -> list[Path]:
        """Paths (relative to the top folder) written so far, in order."""
        return list(self._record.written)

    def path(self, *parts: str) -> Path:
        """The resolved path of ``parts`` under this folder.

        Parameters
        ----------
        *parts : str
            Relative path components (``"plan"``, ``"plan_j0.csv"``, or ``"plan/plan_j0.csv"``).

        Returns
        -------
        Path
            Absolute path, symbolic links resolved.

        Raises
        ------
        InputError
            No part, an absolute part, or a path that leaves the folder
            (``..``, a symbolic link pointing outside).
        """
        if not parts or any(not isinstance(p, (str, os.PathLike)) or not str(p) for p in parts):
            raise InputError(f"output path under {self.root}: empty or invalid component in {parts!r}")
        for p in parts:
            if Path(p).is_absolute():
                raise InputError(f"output path {p!r} is absolute: outputs stay under {self.root}")
        candidate = self.root.joinpath(*parts)
        try:
            resolved = candidate.resolve()
        except (OSError, RuntimeError) as exc:
            raise InputError(f"output path {candidate}: cannot resolve it ({describe(exc)})") from None
        top = self._record.root
        if resolved == top or not (resolved.is_relative_to(self.root) and resolved.is_relative_to(top)):
            raise InputError(f"output path {'/'.join(map(str, parts))!r} leaves the output folder {self.root}")
        return resolved

    def sub(self, *parts: str) -> OutputDir:
        """A sub-folder (created) sharing this folder's record of written files and its marker.

        Parameters
        ----------
        *parts : str
            Relative path of the sub-folder.

        Returns
        -------
        OutputDir

        Raises
        ------
        InputError
            The path leaves the folder or cannot be created.
        """
        return OutputDir(self.path(*parts), clean=self.clean, _record=self._record)

    # ---- writing ---------------------------------------------------------------------------------
    def _note(self, rel: Path) -> None:
        """Before a file lands: list it in the in-progress record (started, at the first file, in place of the marker).

        The record starts with the files of earlier runs, so that a run
        interrupted now still lets the next complete run remove them, and
        grows by one line per file this run writes.
        """
        rec = self._record
        root = rec.root
        if not rec.marker:
            return
        try:
            if not rec.started:
                head = json.dumps({"command": rec.command}) + "\n"
                with replacing(root / INCOMPLETE) as tmp:
                    tmp.write_text(head + "".join(json.dumps(p) + "\n" for p in rec.previous), encoding="utf-8")
                with contextlib.suppress(FileNotFoundError):
                    (root / MARKER).unlink()  # no longer a complete set
                rec.started = True
            with open(root / INCOMPLETE, "a", encoding="utf-8") as fh:
                fh.write(json.dumps(str(rel)) + "\n")
        except OSError as exc:
            raise InputError(f"cannot write {root / INCOMPLETE}: {_cause(exc)}") from None

    @contextlib.contextmanager
    def atomic(self, *parts: str) -> Iterator[Path]:
        """A temporary path in the final folder, renamed to ``parts`` when the block ends without error.

        The temporary name keeps the final suffix (libraries that choose the
        format from it, such as matplotlib, write the right one).

        Parameters
        ----------
        *parts : str
            Relative path of the final file.

        Yields
        ------
        Path
            The temporary path to write.

        Raises
        ------
        InputError
            The path leaves the folder, or the write or rename failed
            (``OSError``: disk full, permissions), naming the file and the cause;
            the temporary file is removed and nothing is left under the final name.
        """
        final = self.path(*parts)
        rel = final.relative_to(self._record.root)
        self._mkdir(final.parent, parents=True)
        try:
            with replacing(final) as tmp:
                yield tmp
                self._note(rel)  # listed before it lands under its final name
        except OSError as exc:
            raise InputError(f"cannot write {final}: {_cause(exc)}") from None
        if rel not in self._record.written:
            self._record.written.append(rel)

    def write_bytes(self, *parts: str, data: bytes) -> Path:
        """Write ``data`` to ``parts`` atomically.

        Parameters
        ----------
        *parts : str
            Relative path of the file.
        data : bytes
            Content.

        Returns
        -------
        Path
            The file written.

        Raises
        ------
        InputError
            As :meth:`atomic`.
        """
        with self.atomic(*parts) as tmp:
            tmp.write_bytes(data)
        return self.path(*parts)

    def write_text(self, *parts: str, text: str) -> Path:
        """Write ``text`` (UTF-8, ``\\n`` line ends) to ``parts`` atomically.

        Parameters
        ----------
        *parts : str
            Relative path of the file.
        text : str
            Content.

        Returns
        -------
        Path
            The file written.

        Raises
        ------
        InputError
            As :meth:`atomic`.
        """
        return self.write_bytes(*parts, data=text.encode("utf-8"))

    def write_json(self, *parts: str, obj) -> Path:
        """Write ``obj`` as JSON (indent 2, keys in their order) to ``parts`` atomically.

        NumPy numbers, arrays and paths are converted; NaN and infinities are
        refused (JSON has none): pass the object through :func:`json_safe` to
        write them as ``null``.

        Parameters
        ----------
        *parts : str
            Relative path of the file.
        obj : object
            JSON-serialisable structure.

        Returns
        -------
        Path
            The file written.

        Raises
        ------
        InputError
            A NaN, an infinity or an object JSON cannot represent (naming the
            file), or as :meth:`atomic`.
        """

        def default(o):
            if isinstance(o, (np.generic, np.ndarray, os.PathLike, set, tuple)):
                return json_safe(o) if not isinstance(o, np.floating) else float(o)
            raise TypeError(f"{type(o).__name__} is not JSON serialisable")

        try:
            text = json.dumps(obj, indent=2, sort_keys=False, allow_nan=False, default=default)
        except (ValueError, TypeError) as exc:
            raise InputError(f"cannot write {self.root.joinpath(*parts)} as JSON: {describe(exc)}") from None
        return self.write_text(*parts, text=text + "\n")

    # ---- completion ------------------------------------------------------------------------------
    def finish(self, *, release: bool = True) -> Path:
        """Remove earlier runs' stale files (with ``clean``), write the completion marker, drop the in-progress record.

        Stale files are those the completion marker or an interrupted run's
        in-progress record lists and this run did not write; files never
        listed (the user's own) are kept; a warning (``logging``) names how
        many were removed and the first few.

        Parameters
        ----------
        release : bool
            Release the folder's lock too; without it the run keeps the folder
            (files written after the run, such as its report) until :meth:`release`.

        Returns
        -------
        Path
            The marker ``<root>/.gflat-complete.json``: ``files`` (path relative
            to the top folder, sha256, bytes), ``command``, ``date_utc`` (without
            ``marker``: the folder, nothing written).

        Raises
        ------
        InputError
            The marker cannot be written.
        """
        rec = self._record
        root = rec.root
        if not rec.marker:
            if release:
                self.release()
            return root
        # the earlier run's files still there, not written again: stale with ``clean``, else kept listed
        earlier = earlier_files(root, rec.previous, rec.written)
        removed = []
        for rel in earlier if self.clean else ():
            stale = root / rel
            if not stale.is_symlink():  # a link is not followed to remove what it points to
                with contextlib.suppress(OSError):
                    stale.unlink()
                    removed.append(rel)
                    remove_empty_folders(stale.resolve().parent, root)
        removed = [rel for rel in removed if Path(rel).name not in REPORT_PAGES]
        if removed:
            _log.warning(
                "%s: removed %d file(s) of the folder's earlier run that this run did not write again (%s)",
                root,
                len(removed),
                _few(removed),
            )
        kept = [] if self.clean else earlier
        files = [file_entry(root, rel) for rel in (*kept, *rec.written) if (root / rel).is_file()]
        self._mkdir(root, parents=True)
        final = write_marker(root, rec.command, files)
        rec.previous = [f["path"] for f in files]
        rec.started = False
        if release:
            self.release()
        return final

    def release(self) -> None:
        """Release the folder to other runs (also done when the object is collected, and at exit); again: nothing."""
        getattr(self._record, "release", lambda: None)()

    def __repr__(self) -> str:
        return f"OutputDir({str(self.root)!r}, {len(self._record.written)} file(s) written)"
