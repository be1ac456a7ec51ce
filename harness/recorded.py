"""Files a record names, trusted only once checked: confined to their folder, and of the size and sha256 recorded.

A run's ``manifest.json`` and ``report.json`` files, and a campaign's store, name files by paths relative to
their folder.  A folder may have been received from someone else, edited or half lost since it was written, so
nothing it names is read before:

* :func:`confined`: the name is a relative path without ``..`` and, links resolved, stays inside the folder (a
  symbolic link whose target leaves it, an absolute path or a ``..`` is refused: a report never reads, nor embeds,
  a file outside its run);
* :func:`file_problem`: the file is a regular file (no link) of the recorded size and sha256;
* :func:`href`: a page links a file of the folder by a relative URL whose every character is a path's (a file
  named ``javascript:alert(1)`` is linked as ``javascript%3Aalert%281%29``, a relative path, never a scheme).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path, PurePosixPath
from urllib.parse import quote

from gna.errors import InputError, describe

__all__ = ["confined", "file_problem", "href", "record", "sha256", "safe_name"]


def sha256(path: str | Path) -> str:
    """The sha256 of a file's bytes, as hex.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str
    """
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def record(path: str | Path) -> dict:
    """What a record keeps of a file to check it later: ``{"bytes": size, "sha256": hex}``.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict
    """
    return {"bytes": os.stat(path).st_size, "sha256": sha256(path)}


def _rel_problem(name) -> str | None:
    """Why ``name`` is no relative path inside a folder (None: it is one)."""
    if not isinstance(name, str) or not name.strip():
        return "not a file name"
    if "\0" in name or "\\" in name:
        return "a name with a NUL or backslash"
    rel = PurePosixPath(name)
    if rel.is_absolute() or name.startswith("~"):
        return "an absolute path"
    if ".." in rel.parts:
        return "a path with '..'"
    if not rel.parts or rel.parts == (".",):
        return "not a file name"
    return None


def confined(root: str | Path, name, what: str = "the record names the file") -> Path:
    """The path of ``name`` in the folder ``root``, refused unless it stays there once every link is resolved.

    Parameters
    ----------
    root : str or Path
        The folder (a run's, a case's, a campaign's).
    name : str
        The relative path the record gives (POSIX separators).
    what : str
        Who names it, for the message (``"DIR/report.json names the figure"``).

    Returns
    -------
    Path
        ``root / name`` (not resolved: the name as recorded, under ``root``).

    Raises
    ------
    InputError
        ``<what> <name>: <cause> (only files inside <root> are read ...)`` (one line): not a string, an absolute path, a ``..``, a NUL, or a path
        that a symbolic link takes out of ``root``.
    """
    root = Path(root)
    problem = _rel_problem(name)
    if problem is None:
        path = root / name
        try:
            base = root.resolve()
            if not path.resolve().is_relative_to(base):
                problem = "a symbolic link leading out of the folder"
        except (OSError, RuntimeError):
            problem = "a path that cannot be resolved (a loop of links)"
    if problem is not None:
        raise InputError(
            f"{what} {name!r}: {problem} (only files inside {root} are read: the folder was changed or comes "
            f"from elsewhere)"
        )
    return path


def safe_name(name, what: str = "name") -> str:
    """``name`` when it is one plain path component (letters, digits, ``.``, ``_``, ``-``; not ``.`` or ``..``).

    Parameters
    ----------
    name : object
        A name a record gives a file or folder (a campaign's case id, an engine's name).
    what : str
        What it is, for the message.

    Returns
    -------
    str

    Raises
    ------
    InputError
        Anything else, naming the value.
    """
    ok = isinstance(name, str) and 0 < len(name) <= 255 and name not in (".", "..")
    if ok and all(c.isascii() and (c.isalnum() or c in "._-") for c in name):
        return name
    raise InputError(f"{what} {name!r}: not a plain name (letters, digits, '.', '_', '-'): the record was changed")


def file_problem(path: str | Path, size=None, digest=None) -> str | None:
    """Why the file at ``path`` is not the one recorded (None: it is).

    Parameters
    ----------
    path : str or Path
        The file (already :func:`confined`).
    size : int, optional
        Its recorded size in bytes.
    digest : str, optional
        Its recorded sha256 (hex).

    Returns
    -------
    str or None
        ``"missing"``, ``"a symbolic link"``, ``"not a regular file"``, ``"shorter than recorded (N of M bytes: truncated or rewritten)"``,
        ``"N bytes, M recorded"``, ``"changed since it was recorded (sha256 differs)"``, ``"unreadable (...)"``.
    """
    path = Path(path)
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return "missing"
    except OSError as exc:
        return f"unreadable ({describe(exc)})"
    if os.path.islink(path):
        return "a symbolic link"
    if not os.path.isfile(path):
        return "not a regular file"
    if size is not None and st.st_size != size:
        return (
            f"shorter than recorded ({st.st_size} of {size} bytes: truncated or rewritten)"
            if st.st_size < size
            else f"{st.st_size} bytes, {size} recorded"
        )
    if digest is not None:
        try:
            if sha256(path) != digest:
                return "changed since it was recorded (sha256 differs)"
        except OSError as exc:
            return f"unreadable ({describe(exc)})"
    return None


def href(target: str | Path, page_dir: str | Path) -> str:
    """The relative URL a page in ``page_dir`` links ``target`` by (every character but ``/`` percent-encoded
    unless a letter, digit or ``_.-~``: never a scheme such as ``javascript:``).

    Parameters
    ----------
    target : str or Path
        The file linked (in the same folder tree as the page).
    page_dir : str or Path
        The folder of the page.

    Returns
    -------
    str
    """
    return quote(Path(os.path.relpath(target, page_dir)).as_posix(), safe="/")
