"""Bundled TOML files (aircraft, scenarios) looked up by name, or any file by path."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def bundled(package: str, *folder: str) -> dict[str, Path]:
    """The ``.toml`` files of a package's data folder, by name.

    Parameters
    ----------
    package : str
        Importable package holding the folder, e.g. ``"gna"``.
    *folder : str
        Path parts of the folder inside the package, e.g. ``"data", "aircraft"``.

    Returns
    -------
    dict of str to Path
        ``{stem: path}``, sorted by file name.
    """
    root = resources.files(package).joinpath(*folder)
    return {e.name[:-5]: Path(str(e)) for e in sorted(root.iterdir(), key=lambda e: e.name) if e.name.endswith(".toml")}


def resolve(name_or_path, catalogue: dict[str, Path]) -> Path | None:
    """The bundled file called ``name_or_path``, or an existing ``.toml`` file at that path, or None.

    Parameters
    ----------
    name_or_path : str or PathLike
        A name of ``catalogue`` (tried first) or a path to a ``.toml`` file.
    catalogue : dict of str to Path
        The bundled files (:func:`bundled`).

    Returns
    -------
    Path or None
        The file, or None when the name is not bundled and the path is not an existing ``.toml`` file.
    """
    key = str(name_or_path)
    if key in catalogue:
        return catalogue[key]
    path = Path(key)
    return path if path.suffix == ".toml" and path.is_file() else None
