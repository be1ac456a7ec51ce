"""The lock a run holds on its output folder: ``flock`` on the folder itself, no lock file.

A run takes an exclusive lock on its folder (:class:`FolderLock`) from the moment the folder is checked
to the end of the run; the operating system drops it when the process ends, however it ends (error,
Ctrl-C, a kill).  :func:`is_held` tells whether a folder is held now (another run's check that it does
not write inside a running run, :func:`harness.outguard.check_not_inside_run`).
"""

from __future__ import annotations

import errno
import os
import time
from pathlib import Path

from gna.errors import InputError

from .fileio import remove_empty_folders

try:  # POSIX; elsewhere folders are not locked
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None


def is_held(folder: Path) -> bool:
    """Whether a gflat run holds ``folder``'s lock now (probed with a shared lock, released at once).

    Parameters
    ----------
    folder : Path
        A folder (a missing or unreadable one is not held).

    Returns
    -------
    bool
    """
    if fcntl is None:  # pragma: no cover - Windows
        return False
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError as exc:
        return exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES)
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    finally:
        os.close(fd)


#: Tries of :class:`FolderLock` (10 ms apart) before a held folder is refused: another run's
#: :func:`harness.outguard.check_not_inside_run` holds a parent folder's lock (shared) for an instant.
LOCK_TRIES = 20


def _lock_now(fd: int) -> None:
    for attempt in range(LOCK_TRIES):
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except OSError as exc:
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES) or attempt == LOCK_TRIES - 1:
                raise
            time.sleep(0.01)


class FolderLock:
    """An exclusive lock on a folder for the duration of a run (``flock`` on the folder itself, no lock file).

    Released by :meth:`release` in the process that took it (the forked workers of a run share the lock
    and never release it), else by the operating system when that process ends.

    Parameters
    ----------
    path : Path
        An existing folder.
    created : list of Path, optional
        Folders the run made for it (deepest first), removed at :meth:`release` while still empty.
    advice : str, optional
        What the refusal tells the user to do (commands without ``--out`` say only to wait).

    Raises
    ------
    InputError
        Another process holds the folder's lock (one line naming the folder).
    """

    def __init__(
        self,
        path: Path,
        created: list[Path] | None = None,
        advice: str = "wait for it to end, or give another folder with --out",
    ):
        self.path = path
        self.created = list(created or ())
        self.pid = os.getpid()
        self.fd: int | None = None
        if fcntl is None:  # pragma: no cover - Windows
            return
        try:
            fd = os.open(path, os.O_RDONLY)  # not inherited by programs the run starts (O_CLOEXEC)
        except OSError:  # a folder that cannot be opened is not locked
            return
        try:
            _lock_now(fd)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise InputError(
                    f"output folder {path} is in use by another gflat run (it holds the folder until it ends): {advice}"
                ) from None
            return  # a file system without flock: not locked
        self.fd = fd

    def release(self) -> None:
        """Release the lock and remove the folders made for the run while empty (only in the process that took
        it; again: nothing)."""
        if os.getpid() != self.pid:
            return
        fd, self.fd = self.fd, None
        if fd is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_UN)  # also for the copies forked workers still hold
            finally:
                os.close(fd)
        if self.created:  # nothing written: nothing left (deepest first, a chain)
            remove_empty_folders(self.created[0], self.created[-1].parent)
        self.created = []
