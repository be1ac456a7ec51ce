"""Bundled TOML files (aircraft, scenarios) looked up by name, or any file by path."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def bundled(package: str, *folder: str) -> dict[str, Path]:
    """``{name: path}`` of the ``.toml`` files in a package folder, sorted by name."""
    root = resources.files(package).joinpath(*folder)
    return {e.name[:-5]: Path(str(e)) for e in sorted(root.iterdir(), key=lambda e: e.name) if e.name.endswith(".toml")}


def resolve(name_or_path, catalogue: dict[str, Path]) -> Path | None:
    """The bundled file called ``name_or_path``, or an existing ``.toml`` file at that path, or None."""
    key = str(name_or_path)
    if key in catalogue:
        return catalogue[key]
    path = Path(key)
    return path if path.suffix == ".toml" and path.is_file() else None
