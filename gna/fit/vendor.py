"""Copy the public source data the fits need into ``gna/data/sources/`` (one-off tool).

The reference material lives outside the package (``shared/data/...``); the
installed package must carry what it uses, with its provenance.  This module
documents -- and can redo -- that transformation:

* GTM: the nominal (undamaged) tables of NASA's ``T2_polynomial_aerodatabase``
  as converted to JSON in ``shared/data/gtm/gtm_aero_db.json`` are written,
  values unchanged, to ``gtm/gtm_t2_aero_nominal.json.gz`` (gzip, mtime 0, so
  the bytes are reproducible); ``vehicle.json`` and ``reference_points.csv``
  are copied unchanged.
* Twin Otter: ``aircraft_dat_clean.csv`` is copied unchanged.

Usage::

    python -m gna.fit.vendor SHARED_DATA_DIR [OUT_DIR]

``SHARED_DATA_DIR`` is the folder holding ``gtm/`` and ``twin_otter/``;
``OUT_DIR`` defaults to the package's ``gna/data/sources``.  The PROVENANCE
files next to the data are written by hand, not by this tool.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import shutil
import sys
from pathlib import Path

from ..errors import InputError

#: Tables of the GTM database that the nominal (undamaged) simulation uses.
GTM_NOMINAL_TABLES: tuple[str, ...] = (
    "C6_bas",
    "dC3_sym",
    "dC3_ele",
    "dC3_lgr",
    "dC3_p",
    "dC3_q",
    "dC3_r",
    "dC6_ail",
    "dC6_rud",
    "dC6_spo",
    "dC6_w",
)


def _require(path: Path) -> Path:
    if not path.is_file():
        raise InputError(f"vendor: missing source file {path}")
    return path


def vendor_gtm(src: Path, out: Path) -> dict[str, str]:
    """Write the GTM nominal tables, vehicle data and reference points.

    Parameters
    ----------
    src : Path
        Folder holding ``gtm_aero_db.json``, ``vehicle.json`` and ``reference_points.csv``.
    out : Path
        Output folder (created): ``gtm_t2_aero_nominal.json.gz`` (the :data:`GTM_NOMINAL_TABLES` and the
        linear derivatives, gzip with mtime 0) and the two files copied unchanged.

    Returns
    -------
    dict of str to str
        Output file name -> sha256 hex digest.

    Raises
    ------
    InputError
        A missing source file, or a database lacking one of :data:`GTM_NOMINAL_TABLES`.
    """
    db = json.loads(_require(src / "gtm_aero_db.json").read_text())
    missing = [t for t in GTM_NOMINAL_TABLES if t not in db["tables"]]
    if missing:
        raise InputError(f"vendor: {src / 'gtm_aero_db.json'} lacks table(s) {', '.join(missing)}")
    nominal = {
        "title": db["title"],
        "mat_version_string": db["mat_version_string"],
        "mat_header": db["mat_header"],
        "source": db["source"],
        "conventions": db["conventions"],
        "transformation": "subset of shared/data/gtm/gtm_aero_db.json: the nominal tables "
        f"({', '.join(GTM_NOMINAL_TABLES)}) and the flap derivatives, values unchanged; "
        "damage tables omitted",
        "tables": {t: db["tables"][t] for t in GTM_NOMINAL_TABLES},
        "linear_derivatives": db["linear_derivatives"],
    }
    out.mkdir(parents=True, exist_ok=True)
    raw = json.dumps(nominal, separators=(",", ":")).encode()
    target = out / "gtm_t2_aero_nominal.json.gz"
    target.write_bytes(gzip.compress(raw, compresslevel=9, mtime=0))
    for name in ("vehicle.json", "reference_points.csv"):
        shutil.copyfile(_require(src / name), out / name)
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in (target, out / "vehicle.json", out / "reference_points.csv")
    }


def vendor_twin_otter(src: Path, out: Path) -> dict[str, str]:
    """Copy the Twin Otter clean linear model.

    Parameters
    ----------
    src : Path
        Folder holding ``aircraft_dat_clean.csv``.
    out : Path
        Output folder (created).

    Returns
    -------
    dict of str to str
        ``{"aircraft_dat_clean.csv": sha256 hex digest}``.

    Raises
    ------
    InputError
        The source file is missing.
    """
    out.mkdir(parents=True, exist_ok=True)
    target = out / "aircraft_dat_clean.csv"
    shutil.copyfile(_require(src / "aircraft_dat_clean.csv"), target)
    return {target.name: hashlib.sha256(target.read_bytes()).hexdigest()}


def main(argv: list[str] | None = None) -> int:
    """``python -m gna.fit.vendor SHARED_DATA_DIR [OUT_DIR]``: vendor both sources, print their sha256.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0, or 2 (with the usage printed) without arguments.

    Raises
    ------
    InputError
        A missing source file (from :func:`vendor_gtm`, :func:`vendor_twin_otter`).
    """
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        print(__doc__)
        return 2
    shared = Path(argv[0])
    out = Path(argv[1]) if len(argv) > 1 else Path(__file__).resolve().parents[1] / "data" / "sources"
    sums = vendor_gtm(shared / "gtm", out / "gtm")
    sums.update(vendor_twin_otter(shared / "twin_otter", out / "twin_otter"))
    for name, digest in sums.items():
        print(f"{digest}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
