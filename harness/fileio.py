"""File primitives shared by the output folder and the report writers: JSON-safe copies, atomic replacement.

:func:`replacing` writes a file under a temporary name beside its final name
and renames it over the final name (``os.replace``, atomic on POSIX), so a
reader never sees a half-written file; :func:`json_safe` turns NumPy values,
paths and dataclasses into the types :func:`json.dumps` takes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import secrets
from collections.abc import Iterator
from pathlib import Path

import numpy as np

__all__ = ["json_safe", "replacing"]


def json_safe(obj, nonfinite: str = "null"):
    """A copy of ``obj`` that :func:`json.dumps` takes with ``allow_nan=False``.

    NumPy scalars and arrays become Python numbers and lists, paths strings,
    tuples and sets lists, dataclasses dicts, other objects their ``str``.

    Parameters
    ----------
    obj : object
        Nested dicts, lists, numbers, strings, paths, NumPy values, dataclasses.
    nonfinite : {"null", "text"}
        How a NaN or infinite float is written (JSON has none): ``None``, or
        the strings ``"nan"``, ``"inf"``, ``"-inf"`` (which keep NaN and
        infinity apart, as a report shows them).

    Returns
    -------
    object
        The same structure with JSON types only.
    """
    if isinstance(obj, dict):
        return {str(k): json_safe(v, nonfinite) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set)):
        return [json_safe(v, nonfinite) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist(), nonfinite)
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else (str(v) if nonfinite == "text" else None)
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return json_safe(dataclasses.asdict(obj), nonfinite)
    if obj is None or isinstance(obj, str):
        return obj
    return str(obj)


@contextlib.contextmanager
def replacing(final: str | Path) -> Iterator[Path]:
    """A temporary file beside ``final``, renamed over it when the block ends without error.

    The temporary name is hidden, unique (created exclusively) and keeps the
    final suffix; it gets the permissions the user's umask gives new files.
    On any error it is removed and ``final`` is untouched: a reader never sees
    a half-written file under the final name.

    Parameters
    ----------
    final : str or Path
        The file to (re)place; its folder must exist.

    Yields
    ------
    Path
        The temporary path to write.

    Raises
    ------
    OSError
        Creating, writing or renaming failed (disk full, permissions).
    """
    final = Path(final)
    for _ in range(100):
        tmp = final.with_name(f".{final.stem}.{secrets.token_hex(6)}.tmp{final.suffix}")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            break
        except FileExistsError:
            continue
    else:
        raise FileExistsError(f"no free temporary name next to {final}")
    try:
        yield tmp
        os.replace(tmp, final)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def remove_empty_folders(folder: str | Path, root: str | Path) -> None:
    """Remove ``folder`` and then its parents, up to (not including) ``root``, while they are empty.

    Only empty folders go (``rmdir``): a folder holding anything -- the user's files included -- ends the walk.

    Parameters
    ----------
    folder : str or Path
        The deepest folder (a file's folder after the file was removed).
    root : str or Path
        The top folder, never removed; nothing outside it is touched.
    """
    folder, root = Path(folder), Path(root)
    while folder != root and folder.is_relative_to(root):
        try:
            folder.rmdir()
        except OSError:
            return
        folder = folder.parent
