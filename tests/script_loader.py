"""Loading a script of ``benchmarks/`` or ``research/`` (folders of scripts, not packages) as a module for its tests."""

from __future__ import annotations

import contextlib
import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def script_module(folder: str, name: str, as_name: str | None = None):
    """The module of ``<folder>/<name>.py``, registered under ``as_name`` while in use (dataclasses look
    their module up)."""
    spec = importlib.util.spec_from_file_location(as_name or name, ROOT / folder / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    try:
        spec.loader.exec_module(mod)
        yield mod
    finally:
        sys.modules.pop(spec.name, None)
