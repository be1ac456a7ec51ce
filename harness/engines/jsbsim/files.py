"""The committed aircraft files: where they live, writing them, and checking they are current.

``gflat export-jsbsim --all`` writes ``aircraft_xml/<id>/<id>.xml`` for every
bundled aircraft with :func:`harness.engines.jsbsim.export.aircraft_xml`.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from gna.aircraft import Aircraft, list_aircraft, load_aircraft
from gna.schema import check_name

from .export import FlatPlanet, aircraft_xml


def default_root() -> Path:
    """The repository's ``aircraft_xml/`` folder.

    Returns
    -------
    pathlib.Path
    """
    return Path(__file__).resolve().parents[3] / "aircraft_xml"


def xml_path(root: str | Path, aircraft_id: str) -> Path:
    """``root/<id>/<id>.xml``.

    Parameters
    ----------
    root : str or pathlib.Path
        Folder of the aircraft files.
    aircraft_id : str
        Aircraft identifier.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InputError
        If ``aircraft_id`` is not a safe identifier (a path separator, ``..``): the file stays under ``root``.
    """
    check_name(aircraft_id, "aircraft id", "JSBSim export")
    return Path(root) / aircraft_id / f"{aircraft_id}.xml"


def export_aircraft(
    aircraft: Aircraft,
    root: str | Path | None = None,
    planet: FlatPlanet | None = FlatPlanet(),  # noqa: B008
) -> Path:
    """Write ``root/<id>/<id>.xml``.

    Parameters
    ----------
    aircraft : Aircraft
        The aircraft.
    root : str or pathlib.Path, optional
        Default :func:`default_root`.
    planet : FlatPlanet or None
        As in :func:`aircraft_xml`.

    Returns
    -------
    pathlib.Path
        The written file.
    """
    path = xml_path(root if root is not None else default_root(), aircraft.id)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = aircraft_xml(aircraft, planet)
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(text)
    return path


def export_all(root: str | Path | None = None, ids: Iterable[str] | None = None) -> list[Path]:
    """Export the given aircraft.

    Parameters
    ----------
    root : str or pathlib.Path, optional
        Default :func:`default_root`.
    ids : iterable of str, optional
        Aircraft identifiers; default every bundled aircraft.

    Returns
    -------
    list of pathlib.Path
        The written files.
    """
    names = list(ids) if ids is not None else list_aircraft()
    return [export_aircraft(load_aircraft(n), root) for n in names]


def stale_files(root: str | Path | None = None, aircraft: Iterable[Aircraft] | None = None) -> list[str]:
    """Problems of the files under ``root`` (missing, or different from a fresh export); empty when current.

    Parameters
    ----------
    root : path, optional
        Default :func:`default_root`.
    aircraft : iterable of Aircraft, optional
        Default: every bundled aircraft.

    Returns
    -------
    list of str
        One line per missing or stale file.
    """
    root = Path(root) if root is not None else default_root()
    crafts = list(aircraft) if aircraft is not None else [load_aircraft(n) for n in list_aircraft()]
    out = []
    for a in crafts:
        path = xml_path(root, a.id)
        if not path.is_file():
            out.append(f"{a.id}: {path} is missing")
        elif path.read_text(encoding="utf-8") != aircraft_xml(a):
            out.append(f"{a.id}: {path} differs from a fresh export")
    return out
