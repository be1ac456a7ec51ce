"""Provenance of a validation run: versions, date and commit (recorded with every result)."""

from __future__ import annotations

import datetime
import platform

import numpy as np

from ..artefacts import package_version, source_commit


def provenance() -> dict:
    """Versions, date and source revision a result was computed with.

    Returns
    -------
    dict
        ``gflat``, ``jsbsim``, ``numpy``, ``python`` versions (None when a
        package is not installed), ``date_utc`` (ISO 8601, seconds) and
        ``git_commit`` of the source tree (None outside a git checkout).
    """
    return {
        "gflat": package_version("gflat"),
        "jsbsim": package_version("jsbsim"),
        "numpy": np.__version__,
        "python": platform.python_version(),
        "date_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "git_commit": source_commit(),
    }
