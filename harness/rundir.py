"""A run's output folder, written whole: it appears complete or not at all.

A command that writes a run opens a :class:`RunDir` on its ``--out`` before
any work.  The files go into a hidden staging folder beside ``--out`` (same
file system, ``.<name>.gflat-<random>.tmp``); :meth:`RunDir.commit` writes
``manifest.json`` last (every file with its sha256) and renames the staging
folder into place in one step:

* a new ``--out``: ``renameat2(RENAME_NOREPLACE)``; of two runs into the same
  new folder the first to finish wins, the other fails with one line;
* ``--replace`` of an existing run: ``renameat2(RENAME_EXCHANGE)`` swaps the
  two folders atomically (the old run, now at the staging path, is then
  removed); a folder holding anything that is not a gflat run's is never
  removed.

The run holds an ``flock`` on its staging folder for its lifetime (no lock
file).  Leaving the ``with`` block without :meth:`RunDir.commit` (an error,
Ctrl-C) removes the staging folder; a run killed outright leaves it hidden,
unlocked, and the next run into the same ``--out`` removes it.  A kill at any
moment therefore leaves either the old folder complete and unchanged or the
new one complete.  Runs are never changed once written: an output folder
inside a run's folder is refused, and ``gflat report`` renders a copy that
takes the run's place the same way.

:class:`OutputFile` is the same contract for one file the user names (``gflat fit --out FILE``): refused
when it exists unless ``--replace``, written beside it under a hidden name and renamed into place.
:func:`write_file` replaces one of the tool's own files atomically (the repository's ``aircraft_xml/``).
"""

from __future__ import annotations

import contextlib
import ctypes
import datetime
import errno
import glob
import os
import re
import secrets
import shutil
import stat
import sys
import uuid
from pathlib import Path

from gna.errors import InputError, describe, expand_home

from .artefacts import MANIFEST, enclosing_run, json_text, manifest_problem, read_manifest
from .parallel import InterruptsWait
from .recorded import sha256

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows: staging folders are not locked
    fcntl = None

__all__ = ["MANIFEST", "OutputFile", "RunDir", "check_output_file", "enclosing_run", "read_manifest", "write_file"]

RENAME_NOREPLACE, RENAME_EXCHANGE = 1, 2
#: The name of a run's staging folder (and of a file's hidden temporary copy): ``.<name>.gflat-<12 hex>.tmp``.
_STAGING = re.compile(r"\..+\.gflat-[0-9a-f]{12}\.tmp")
_AT_FDCWD = -100


def _cause(exc: OSError) -> str:
    """The OS error's meaning: "No such file or directory" creating a name in a folder that exists (procfs)
    means the file system creates nothing there."""
    name = exc.filename if isinstance(exc.filename, (str, Path)) else None
    if exc.errno == errno.ENOENT and name is not None and not os.path.islink(name):
        folder = Path(os.path.abspath(name)).parent
        if folder.is_dir():
            return f"{folder} exists, but its file system creates no new files or folders there"
        if not os.path.lexists(folder):
            return f"No such file or directory: its folder {folder} does not exist"
    return describe(exc)


def _renameat2(src: Path, dst: Path, flags: int) -> bool:
    """``renameat2(src, dst, flags)`` (Linux); False where the system or file system has no such call."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint)
    if fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), flags) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL):
        return False
    raise OSError(err, os.strerror(err), str(dst))


def _rename_new(src: Path, dst: Path) -> None:
    """Rename ``src`` to ``dst``, which must not exist (FileExistsError when it does)."""
    if _renameat2(src, dst, RENAME_NOREPLACE):
        return
    if os.path.lexists(dst):  # checked os.rename elsewhere (an empty folder would be replaced)
        raise FileExistsError(errno.EEXIST, "exists", str(dst))
    os.rename(src, dst)


def _exchange(a: Path, b: Path) -> None:
    """Swap the folders ``a`` and ``b`` atomically (elsewhere: two renames)."""
    if _renameat2(a, b, RENAME_EXCHANGE):
        return
    aside = a.with_name(a.name.removesuffix(".tmp") + "-old.tmp")  # a stale staging name, should this end here
    os.rename(b, aside)
    os.rename(a, b)
    os.rename(aside, a)


def _files(root: Path) -> list[str]:
    """Every entry under ``root`` that is not a folder (links not followed), as sorted POSIX paths."""
    out = []
    for here, dirs, names in os.walk(root):
        rel = Path(here).relative_to(root)
        links = [d for d in dirs if os.path.islink(os.path.join(here, d))]
        dirs[:] = sorted(d for d in dirs if d not in links)
        out += [(rel / n).as_posix() for n in (*names, *links)]
    return sorted(out)


def _run_files(folder: Path, advice: str | None) -> dict:
    """The manifest of the run in ``folder``, refusing a folder that is no gflat run's (naming the file and what
    is wrong with it) or holds a foreign file; ``advice``, the other way out, ends each message."""
    problem = manifest_problem(folder)
    if problem is not None:
        raise InputError(
            f"{folder} is not the folder of a gflat run ({problem}): it is never removed or changed"
            + (f"; {advice}" if advice else "")
        )
    data = read_manifest(folder)
    listed = {f["path"] for f in data["files"]} | {MANIFEST}
    foreign = [f for f in _files(folder) if f not in listed]
    if foreign:
        raise InputError(
            f"{folder} holds {foreign[0]}, which is not a file of its gflat run (its {MANIFEST} does not list "
            f"it): the folder is never removed; move that file away" + (f", or {advice}" if advice else "")
        )
    return data


def _lock(fd: int) -> bool:
    """Take an exclusive ``flock`` on ``fd`` at once (True), False when another process holds one."""
    if fcntl is None:  # pragma: no cover
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except OSError as exc:
        if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
            return False
        return True  # a file system without flock: nothing to respect


class RunDir:
    """A run's output folder, staged beside ``out`` and renamed into place whole by :meth:`commit`.

    Use it as a context manager: leaving the block without :meth:`commit`
    removes the staging folder (an error, Ctrl-C).

    Parameters
    ----------
    out : str or Path
        The output folder (``--out``).
    command : str
        The command writing (``"paper"``), recorded in the manifest.
    replace : bool
        ``out`` may exist: it must be a gflat run (a readable ``manifest.json``
        of gflat listing every file in the folder), replaced once the new run
        is complete.
    parents : bool
        Make missing parent folders (default output folders); else a missing
        parent is refused.
    advice : str or None
        The other way out a refusal of an existing folder names (default ``"give another --out"``; None for
        ``gflat report``, which has no ``--out``).

    Raises
    ------
    InputError
        Checked before any work, one line naming the path and the cause:
        ``out`` exists and not ``replace``; with ``replace`` it is no gflat
        run or holds a file that is not its run's; it is a file or a link; its
        parent is missing (without ``parents``) or takes no files; it lies
        inside another run's folder.

    Attributes
    ----------
    out : Path
        The final folder (absolute, parent resolved).
    root : Path
        The staging folder the files are written into.
    """

    def __init__(
        self,
        out: str | Path,
        *,
        command: str,
        replace: bool = False,
        parents: bool = False,
        advice: str | None = "give another --out",
    ):
        given = expand_home(out)
        path = Path(os.path.abspath(given))
        if path == Path(path.anchor):
            raise InputError(f"output folder {given}: a file-system root is not an output folder; give --out DIR")
        parent = path.parent
        try:
            parent = parent.resolve()
        except (OSError, RuntimeError) as exc:
            raise InputError(f"output folder {given}: cannot resolve its parent folder ({describe(exc)})") from None
        self.out = parent / path.name
        self.command = command
        self._old_id: str | None = None
        self._done = False
        self._pid = os.getpid()
        staging = next((p for p in self.out.parents if _STAGING.fullmatch(p.name)), None)
        if staging is not None:
            raise InputError(
                f"output folder {self.out} lies inside {staging}, the staging folder of another gflat run: give a "
                f"folder outside it"
            )
        run = enclosing_run(self.out)
        if run is not None:
            raise InputError(
                f"output folder {self.out} lies inside {run}, the folder of a gflat run (runs are never changed "
                f"once written): give a folder outside it"
            )
        if os.path.islink(self.out):
            raise InputError(f"output folder {self.out} is a symbolic link: give the folder itself, or another --out")
        if self.out.exists():
            if not self.out.is_dir():
                raise InputError(f"output folder {self.out}: a file of that name exists (not a folder)")
            if not replace:
                raise InputError(
                    f"output folder {self.out} exists: give --replace to replace it once the new run is "
                    f"complete, or another --out"
                )
            self._old_id = str(_run_files(self.out, advice).get("run_id"))
        if not parent.is_dir():
            if parent.exists() or not parents:
                what = "is a file" if parent.exists() else "does not exist"
                raise InputError(f"output folder {self.out}: its parent folder {parent} {what}")
            try:
                parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise InputError(f"output folder {self.out}: cannot create {parent}: {_cause(exc)}") from None
        self._remove_stale()
        # An interruption arriving between the folder's mkdir and its record here waits for the record, and
        # then removes the folder: the caller's `with` never saw this object, so its __exit__ would not.
        try:
            with InterruptsWait():
                self.root, self._fd = self._stage()
        except BaseException:
            if getattr(self, "_fd", None) is not None:
                self.close()
            raise

    # ---- staging ---------------------------------------------------------------------------------
    def _pattern(self) -> str:
        return f".{glob.escape(self.out.name)}.gflat-*.tmp"  # a name such as "*" matches only its own

    def _remove_stale(self) -> None:
        """Remove the staging folders of earlier runs into ``out`` that no process holds (killed runs)."""
        for p in self.out.parent.glob(self._pattern()):
            try:
                fd = os.open(p, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_NOFOLLOW", 0))
            except OSError:  # gone, a file, a link: not a staging folder
                continue
            try:
                if _lock(fd):
                    shutil.rmtree(p, ignore_errors=True)
            finally:
                os.close(fd)

    def _stage(self) -> tuple[Path, int | None]:
        """Make the staging folder and lock it (a name another run removed meanwhile is made again)."""
        for _ in range(100):
            p = self.out.with_name(f".{self.out.name}.gflat-{secrets.token_hex(6)}.tmp")
            try:
                os.mkdir(p)
                fd = os.open(p, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
            except FileExistsError:
                continue
            except OSError as exc:
                raise InputError(
                    f"output folder {self.out}: cannot write in {self.out.parent}: {_cause(exc)}"
                ) from None
            if _lock(fd) and os.path.isdir(p) and os.stat(p).st_ino == os.fstat(fd).st_ino:
                return p, fd
            os.close(fd)
        raise InputError(f"output folder {self.out}: no staging folder could be made in {self.out.parent}")

    def close(self) -> None:
        """Remove the staging folder (unless committed) and release it; again: nothing.

        A second Ctrl-C or SIGTERM waits until the folder is gone (:class:`harness.parallel.InterruptsWait`).
        """
        if os.getpid() != self._pid:  # a forked worker never removes its parent's folder
            return
        with InterruptsWait():
            if not self._done:
                self._done = True
                shutil.rmtree(self.root, ignore_errors=True)
            fd, self._fd = self._fd, None
            if fd is not None:
                os.close(fd)

    def __enter__(self) -> RunDir:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ---- writing ---------------------------------------------------------------------------------
    def path(self, *parts: str) -> Path:
        """The path of ``parts`` in the staging folder (confined to the run).

        Parameters
        ----------
        *parts : str
            Relative path components (``"plan"``, ``"plan/plan-j0.parquet"``).

        Returns
        -------
        Path

        Raises
        ------
        InputError
            No part, an empty or absolute part, a ``..``, or the top-level ``manifest.json`` (written by
            :meth:`commit`).
        """
        rel = Path(*map(os.fspath, parts)) if parts and all(str(p) for p in parts) else None
        if rel is None or rel.is_absolute() or ".." in rel.parts or not rel.parts:
            raise InputError(f"output path {'/'.join(map(str, parts))!r} leaves the output folder {self.out}")
        if rel.as_posix() == MANIFEST:
            raise InputError(f"output path {MANIFEST!r} of {self.out} is written by the run's commit")
        return self.root / rel

    def sub(self, *parts: str) -> Path:
        """A sub-folder of the run, made.

        Parameters
        ----------
        *parts : str
            Its relative path.

        Returns
        -------
        Path

        Raises
        ------
        InputError
            As :meth:`path`, or the folder cannot be made.
        """
        p = self.path(*parts)
        try:
            p.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"cannot create {self.out / p.relative_to(self.root)}: {_cause(exc)}") from None
        return p

    def write_bytes(self, *parts: str, data: bytes) -> Path:
        """Write ``data`` to ``parts``.

        Parameters
        ----------
        *parts : str
            Relative path of the file.
        data : bytes
            Content.

        Returns
        -------
        Path
            The file in the staging folder.

        Raises
        ------
        InputError
            As :meth:`path`, or the write failed (disk full, ...), naming the file and the cause.
        """
        p = self.path(*parts)
        try:
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data)
        except OSError as exc:
            raise InputError(f"cannot write {self.out / p.relative_to(self.root)}: {_cause(exc)}") from None
        return p

    def write_text(self, *parts: str, text: str) -> Path:
        """Write ``text`` (UTF-8) to ``parts``; see :meth:`write_bytes`.

        Parameters
        ----------
        *parts : str
            Relative path of the file.
        text : str
            Content.

        Returns
        -------
        Path
        """
        return self.write_bytes(*parts, data=text.encode("utf-8"))

    def write_json(self, *parts: str, obj) -> Path:
        """Write ``obj`` as JSON (:func:`harness.artefacts.json_text`: NaN refused unless made null by json_safe).

        Parameters
        ----------
        *parts : str
            Relative path of the file.
        obj : object
            JSON-serialisable structure.

        Returns
        -------
        Path

        Raises
        ------
        InputError
            A NaN, an infinity or an object JSON cannot represent, or as :meth:`write_bytes`.
        """
        return self.write_text(*parts, text=json_text(obj, self.out.joinpath(*parts)))

    # ---- completion ------------------------------------------------------------------------------
    def commit(self, manifest: dict | None = None) -> Path:
        """Write ``manifest.json`` last and put the run in place of ``out`` in one rename.

        Parameters
        ----------
        manifest : dict, optional
            The caller's fields (versions, command line, inputs, settings, execution:
            :func:`harness.artefacts.run_manifest`); ``date_utc`` defaults to now.

        Returns
        -------
        Path
            ``out``, holding ``manifest.json`` with ``tool``, ``command``, ``run_id``, ``date_utc`` and
            ``files`` (``path``, ``sha256``, ``bytes``, sorted by path).

        Raises
        ------
        InputError
            The manifest cannot be written, or another run wrote ``out`` meanwhile (this run's files are
            discarded; one line).
        """
        if self._done:
            raise InputError(f"output folder {self.out}: the run is already committed or closed")
        files = [
            {"path": f, "sha256": sha256(self.root / f), "bytes": (self.root / f).stat().st_size}
            for f in _files(self.root)
            if f != MANIFEST
        ]
        record = {"tool": "gflat", "command": self.command, "run_id": uuid.uuid4().hex}
        record.update({k: v for k, v in (manifest or {}).items() if k not in ("tool", "command", "run_id", "files")})
        record.setdefault("date_utc", datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"))
        record["files"] = files
        try:
            (self.root / MANIFEST).write_text(json_text(record, self.out / MANIFEST), encoding="utf-8")
            with InterruptsWait():  # Ctrl-C or SIGTERM raised after the rename and its record, never between
                if self._old_id is not None and os.path.isdir(self.out):
                    self._swap()
                else:
                    try:
                        _rename_new(self.root, self.out)
                    except OSError:
                        if not os.path.lexists(self.out):
                            raise
                        raise InputError(
                            f"{self.out} was written by another run meanwhile: this run's files are discarded; "
                            f"give --replace to replace it, or another --out"
                        ) from None
                self._done = True
                shutil.rmtree(self.root, ignore_errors=True)  # the old run, swapped out (nothing, for a new folder)
        except OSError as exc:
            raise InputError(f"cannot write {self.out}: {_cause(exc)}") from None
        self.close()
        return self.out

    def _swap(self) -> None:
        """Exchange the staging folder with ``out``, back again when ``out`` is no longer the run found at the start."""
        _exchange(self.root, self.out)
        now = read_manifest(self.root) or {}
        if str(now.get("run_id")) != self._old_id:
            _exchange(self.root, self.out)
            raise InputError(
                f"{self.out} was replaced by another run meanwhile: this run's files are discarded; "
                f"run it again to replace that one"
            )


_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a named pipe (fifo)"),
    (stat.S_ISSOCK, "a socket"),
)


def check_output_file(path: str | Path) -> Path:
    """Refuse, before any work, a single output file that could not (or must not) be written.

    Parameters
    ----------
    path : str or Path
        The file (as given: the message names it so).

    Returns
    -------
    Path

    Raises
    ------
    InputError
        ``cannot write <path>: <cause>`` (one line): anything there but a regular file (a device, a pipe, a
        folder, a link to one), a path inside a gflat run's folder (runs are never changed once written), a
        folder missing or taking no files (a probe file made and removed there).
    """
    path = Path(path)
    try:
        mode = os.stat(path).st_mode  # through a link: what the name stands for
    except FileNotFoundError:
        mode = None
    except OSError as exc:
        raise InputError(f"cannot write {path}: {_cause(exc)}") from None
    if mode is not None and not stat.S_ISREG(mode):
        kind = next((k for test, k in _KINDS if test(mode)), "a special file")
        link = "a symbolic link to " if path.is_symlink() else ""
        raise InputError(
            f"cannot write {path}: it is {link}{kind}, not a regular file (it would be replaced by one): give "
            f"the path of a new or regular file"
        )
    try:
        resolved = path.resolve()
        run = enclosing_run(resolved)
    except (OSError, RuntimeError):
        resolved, run = None, None
    staging = next((p for p in (resolved.parents if resolved else ()) if _STAGING.fullmatch(p.name)), None)
    if staging is not None:
        raise InputError(
            f"cannot write {path}: {staging} is the staging folder of another gflat run: give a path outside it"
        )
    if run is not None:
        raise InputError(
            f"cannot write {path}: {run} is the folder of a gflat run, never changed once written: give a path "
            f"outside it"
        )
    probe = path.with_name(f".{path.name}.gflat-probe-{secrets.token_hex(6)}.tmp")
    try:  # a file made and removed beside it: what would refuse the file later refuses it now
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        os.unlink(probe)
    except OSError as exc:
        raise InputError(f"cannot write {path}: {_cause(exc)}") from None
    return path


def _stale_files(path: Path) -> None:
    """Remove the hidden temporary files of earlier writes of ``path`` that no process holds (killed writes)."""
    for p in path.parent.glob(f".{glob.escape(path.name)}.gflat-[0-9a-f]*.tmp"):  # not another's probe file
        try:
            if not stat.S_ISREG(os.lstat(p).st_mode):
                continue
            fd = os.open(p, os.O_RDONLY)
        except OSError:
            continue
        try:
            if _lock(fd):
                with contextlib.suppress(OSError):
                    os.unlink(p)
        finally:
            os.close(fd)


def _write_whole(path: Path, data: bytes, replace: bool) -> Path:
    """Write ``data`` beside ``path`` under a hidden, locked name, then rename it onto ``path`` (over an existing
    file only with ``replace``); the hidden file is removed however this ends (an error, Ctrl-C, SIGTERM)."""
    tmp = path.with_name(f".{path.name}.gflat-{secrets.token_hex(6)}.tmp")
    try:
        with open(tmp, "xb") as fh:
            _lock(fh.fileno())  # held while written: the next write of ``path`` removes it only once abandoned
            with contextlib.suppress(OSError):  # a file replaced keeps its permissions
                os.chmod(fh.fileno(), stat.S_IMODE(os.stat(path).st_mode))
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
            with InterruptsWait():
                if replace:
                    os.replace(tmp, path)
                else:
                    try:
                        _rename_new(tmp, path)
                    except FileExistsError:
                        raise InputError(
                            f"output file {path} was written by another process meanwhile: this file is discarded; "
                            f"give --replace to replace it, or another --out"
                        ) from None
    except OSError as exc:
        raise InputError(f"cannot write {path}: {_cause(exc)}") from None
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
    return path


def write_file(path: str | Path, data: bytes | str) -> Path:
    """Replace one file atomically: written beside it under a hidden name, then renamed over it.

    For the tool's own files (the repository's ``aircraft_xml/``, the bundled fitted aircraft); a file the
    user names is an :class:`OutputFile`.

    Parameters
    ----------
    path : str or Path
        The file; its folder must exist.
    data : bytes or str
        Content (str: UTF-8).

    Returns
    -------
    Path

    Raises
    ------
    InputError
        The write or rename failed (disk full, permissions), naming the file and the cause; nothing is
        left under the temporary name and ``path`` is untouched.
    """
    path = Path(path)
    return _write_whole(path, data.encode("utf-8") if isinstance(data, str) else data, replace=True)


class OutputFile:
    """One output file the user names (``gflat fit --out FILE``): checked before any work, written whole.

    The rules of a run's folder (:class:`RunDir`) for a single file: an existing file is refused unless
    ``replace``; :meth:`write` writes the new content beside it under a hidden name
    (``.<name>.gflat-<random>.tmp``) and renames it into place, so that a reader (and a killed run) sees the
    old file or the new one, never a part; without ``replace`` the rename never overwrites a file that
    appeared meanwhile.

    Parameters
    ----------
    path : str or Path
        The file (as given: the messages name it so).
    replace : bool
        An existing regular file may be replaced (once the new content is written).

    Raises
    ------
    InputError
        One line, before any work: what :func:`check_output_file` refuses; a symbolic link (give the file
        itself); an existing file without ``replace``.

    Attributes
    ----------
    path : Path
        The file.
    """

    def __init__(self, path: str | Path, *, replace: bool = False):
        self.path = check_output_file(path)
        self.replace = replace
        if self.path.is_symlink():
            raise InputError(f"output file {self.path} is a symbolic link: give the file itself, or another --out")
        if self.path.exists() and not replace:
            raise InputError(
                f"output file {self.path} exists: give --replace to replace it once the new one is written, "
                f"or another --out"
            )
        _stale_files(self.path)

    def write(self, data: bytes | str) -> Path:
        """Write the file whole (atomically).

        Parameters
        ----------
        data : bytes or str
            Content (str: UTF-8).

        Returns
        -------
        Path
            :attr:`path`.

        Raises
        ------
        InputError
            The write failed (disk full, permissions), or without ``replace`` a file of that name appeared
            meanwhile; ``path`` is then untouched and no temporary file is left.
        """
        return _write_whole(self.path, data.encode("utf-8") if isinstance(data, str) else data, self.replace)
