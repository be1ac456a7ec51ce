"""Files added to a finished run's folder after the run (a report rendered again), recorded in its marker."""

from __future__ import annotations

import json
from pathlib import Path

from gna.errors import InputError

from .fileio import replacing
from .outdir import MARKER, _cause, _sha256


def record_in_marker(root: str | Path, paths) -> bool:
    """Add files written into a complete run's folder after the run (a report rendered again) to its marker.

    The next run into the folder then removes them as stale when it does not write them again, as it does
    the run's own files.

    Parameters
    ----------
    root : str or Path
        The run's top folder (holding ``.gflat-complete.json``).
    paths : iterable of Path
        Files inside ``root``.

    Returns
    -------
    bool
        False when the folder has no readable completion marker (nothing recorded).

    Raises
    ------
    InputError
        The marker cannot be rewritten.
    """
    root = Path(root)
    try:
        marker = json.loads((root / MARKER).read_text(encoding="utf-8"))
        files = [f for f in marker["files"] if isinstance(f, dict) and "path" in f]
    except (OSError, ValueError, TypeError, KeyError):
        return False
    for p in paths:
        p = Path(p)
        rel = str(p.resolve().relative_to(root.resolve()))
        files = [f for f in files if str(f["path"]) != rel]
        files.append({"path": rel, "sha256": _sha256(p), "bytes": p.stat().st_size})
    marker["files"] = files
    try:
        with replacing(root / MARKER) as tmp:
            tmp.write_text(json.dumps(marker, indent=2) + "\n", encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot write {root / MARKER}: {_cause(exc)}") from None
    return True
