"""Provenance of a validation run: versions, date and commit (recorded with every result)."""

from __future__ import annotations

import datetime
import importlib.metadata
import platform
import subprocess
from pathlib import Path

import numpy as np


def provenance() -> dict:
    """Versions, date and source revision a result was computed with.

    Returns
    -------
    dict
        ``gflat``, ``jsbsim``, ``numpy``, ``python`` versions (None when a
        package is not installed), ``date_utc`` (ISO 8601, seconds) and
        ``git_commit`` of the source tree (None outside a git checkout).
    """

    def version(pkg):
        try:
            return importlib.metadata.version(pkg)
        except importlib.metadata.PackageNotFoundError:
            return None

    try:
        r = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=Path(__file__).resolve().parent, capture_output=True, text=True, timeout=5
        )
        commit = r.stdout.strip() if r.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        commit = None
    return {
        "gflat": version("gflat"),
        "jsbsim": version("jsbsim"),
        "numpy": np.__version__,
        "python": platform.python_version(),
        "date_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "git_commit": commit or None,
    }
