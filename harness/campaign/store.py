"""The campaign folder: an SQLite index of every case, and each case's files under ``cases/<case_id>/``.

Layout of ``DIR``::

    campaign.sqlite       # WAL journal; tables ``campaign`` (key, value) and ``cases``
    cases/<case_id>/      # the case's trajectories (<engine>.parquet), complete or absent
    report/               # gflat campaign report

A case is committed in three steps: its files are written to a temporary
folder ``cases/.tmp-<case_id>-<pid>`` (each file flushed to disk), the folder
is renamed to ``cases/<case_id>``, then one transaction marks the case done
with its metrics.  A crash before the transaction leaves the case pending (the
folder, if any, is replaced when the case is run again); the database never
says ``done`` for a case whose files are incomplete.  One process writes: the
runner.  The store's transactions are the campaign's record (it stays
resumable in place); :func:`locked`, an ``flock`` on the index file, keeps a
second ``campaign run`` or ``campaign report`` out while one works.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import shutil
import sqlite3
import time
from collections.abc import Iterator
from pathlib import Path

from gna.errors import InputError, describe

from ..recorded import confined, file_problem, safe_name

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows: the store is not locked
    fcntl = None

__all__ = ["CampaignStore", "STATUSES", "DB_NAME", "locked"]

#: Statuses of a case in the store.
STATUSES: tuple[str, ...] = ("pending", "done", "failed")
#: File name of the index.
DB_NAME = "campaign.sqlite"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS campaign (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS cases (
    case_id TEXT PRIMARY KEY,
    ordinal INTEGER NOT NULL,
    label TEXT NOT NULL,
    dispersion TEXT NOT NULL,
    sample INTEGER NOT NULL,
    seed INTEGER NOT NULL,
    params TEXT NOT NULL,
    status TEXT NOT NULL DEFAULT 'pending' CHECK (status IN ('pending', 'done', 'failed')),
    pass INTEGER,
    flyable INTEGER,
    tracking INTEGER,
    engines_agree INTEGER,
    cause TEXT,
    metrics TEXT,
    draw TEXT,
    error TEXT,
    timings TEXT,
    files TEXT,
    versions TEXT,
    attempts INTEGER NOT NULL DEFAULT 0,
    finished_utc TEXT
);
CREATE INDEX IF NOT EXISTS cases_status ON cases (status);
"""

#: The verdict columns of ``cases`` (1 pass, 0 fail, NULL not judged: open loop's tracking, a failed sample) and
#: the sample's cause (:data:`harness.validation.verdicts.CAUSES`); added to a store made before them.
VERDICT_COLUMNS: dict[str, str] = {
    "flyable": "INTEGER",
    "tracking": "INTEGER",
    "engines_agree": "INTEGER",
    "cause": "TEXT",
}


@contextlib.contextmanager
def locked(root: str | Path) -> Iterator[Path]:
    """Hold the campaign folder's store for a ``campaign run`` or ``campaign report``: an exclusive ``flock`` on
    the index file (made when missing), released when the block ends or the process does, however it ends.

    Open and close every :class:`CampaignStore` of the block inside it: the lock's file descriptor is closed
    last (closing a descriptor of the file drops SQLite's own POSIX locks of this process).

    Parameters
    ----------
    root : str or Path
        The campaign folder (it must exist).

    Yields
    ------
    Path
        ``root``.

    Raises
    ------
    InputError
        Another process holds the store (one line: wait for it to end), or the index cannot be opened.
    """
    root = Path(root)
    _refuse_linked_index(root)
    try:
        fd = os.open(root / DB_NAME, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        raise InputError(f"cannot open the campaign index {root / DB_NAME}: {describe(exc)}") from None
    try:
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise InputError(
                        f"campaign folder {root} is in use by another gflat campaign run or report: wait for it to end"
                    ) from None
        yield root
    finally:
        os.close(fd)


def _refuse_linked_index(root: Path) -> None:
    """A campaign's index is a file of its folder: a link (followed, it would take every write elsewhere) is refused."""
    if (root / DB_NAME).is_symlink():
        raise InputError(
            f"campaign folder {root}: its index {DB_NAME} is a symbolic link (a campaign's files stay in its "
            f"folder, and a link is never followed): copy the file there instead, or use another folder"
        )


def _os_cause(path: Path) -> str:
    """What the system says of opening ``path`` for writing (SQLite's "unable to open database file" names no
    cause), as `` (<cause>)``, or nothing."""
    try:
        os.close(os.open(path, os.O_RDWR))
    except OSError as exc:
        return f" ({describe(exc)}: the campaign folder must be writable)"
    return ""


#: Metrics of each engine's run a report reads (numbers, or None where undefined).
_RUN_METRICS = ("max_position_error_m", "saturated_s")


def _number_or_none(v) -> bool:
    return v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))


def _dumps(obj) -> str:
    return json.dumps(obj, sort_keys=True, allow_nan=True)


def _open_readonly(path: Path) -> sqlite3.Connection:
    """A read-only connection to a campaign index, refused in one line unless it holds the campaign's tables."""
    if not path.is_file():
        raise InputError(
            f"{path.parent} is not a campaign folder: {path} is {'a folder' if path.is_dir() else 'missing'}"
        )
    uri = path.resolve().as_uri()
    db = None
    # mode=rw: never created, and its WAL files are removed on close as a writer's; ro on a read-only medium, and
    # immutable where not even SQLite's -shm can be made there
    for query in ("?mode=rw", "?mode=ro", "?mode=ro&immutable=1"):
        try:
            db = sqlite3.connect(uri + query, uri=True, timeout=30.0, isolation_level=None)
            tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            if {"campaign", "cases"} <= tables:
                db.execute("SELECT COUNT(*) FROM cases").fetchone()  # a read-only medium fails here, not later
            break
        except sqlite3.OperationalError as exc:
            if db is not None:
                db.close()
            db, error = None, exc
        except sqlite3.DatabaseError as exc:
            raise InputError(f"cannot open the campaign index {path}: {describe(exc)}") from None
    if db is None:
        raise InputError(f"cannot open the campaign index {path}: {describe(error)}") from None
    if not {"campaign", "cases"} <= tables:
        db.close()
        kind = "an empty file" if path.stat().st_size == 0 else "an SQLite file without the campaign's tables"
        raise InputError(f"{path} is no campaign index ({kind}): not a campaign folder")
    return db


class CampaignStore:
    """The SQLite index and case folders of one campaign folder.

    Parameters
    ----------
    root : str or Path
        The campaign folder (created when missing, with its parents).
    readonly : bool
        Only read the store (``campaign status``, the report's reading): nothing of gflat's is created or changed in the
        folder, a read-only medium is read, and an index without the campaign's tables (an empty or foreign
        SQLite file) is refused instead of being made a campaign's.

    Raises
    ------
    InputError
        ``root`` is a file, its index a symbolic link, or the database cannot be opened (read-only: is no
        campaign index).
    """

    def __init__(self, root: str | Path, readonly: bool = False):
        self.root = Path(root)
        if self.root.exists() and not self.root.is_dir():
            raise InputError(f"campaign folder {self.root} is a file")
        _refuse_linked_index(self.root)
        if (self.root / "cases").is_symlink():
            raise InputError(
                f"campaign folder {self.root}: its cases folder is a symbolic link (a campaign's files stay in its "
                f"folder): remove the link, or use another folder"
            )
        if readonly:
            self.db = _open_readonly(self.root / DB_NAME)
            return
        (self.root / "cases").mkdir(parents=True, exist_ok=True)
        try:
            self.db = sqlite3.connect(self.root / DB_NAME, timeout=30.0, isolation_level=None)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=FULL")
            self.db.executescript(_SCHEMA)
            have = {row[1] for row in self.db.execute("PRAGMA table_info(cases)")}
            for name, kind in VERDICT_COLUMNS.items():
                if name not in have:
                    self.db.execute(f"ALTER TABLE cases ADD COLUMN {name} {kind}")
        except sqlite3.DatabaseError as exc:
            raise InputError(
                f"cannot open the campaign index {self.root / DB_NAME}: {describe(exc)}{_os_cause(self.root / DB_NAME)}"
            ) from None

    # ------------------------------------------------------------------ campaign-level

    def meta(self) -> dict:
        """The ``campaign`` table as a dict (values JSON-decoded).

        Returns
        -------
        dict

        Raises
        ------
        InputError
            A value that is not JSON (the store was changed), naming its key.
        """
        out = {}
        for k, v in self.db.execute("SELECT key, value FROM campaign"):
            try:
                out[k] = json.loads(v)
            except (TypeError, ValueError, RecursionError):
                raise InputError(
                    f"{self.root / DB_NAME}: the campaign's {k!r} is not JSON ({str(v)[:40]!r}): the store was "
                    f"changed; use a new folder"
                ) from None
        return out

    def set_meta(self, **values) -> None:
        """Store campaign-level values (JSON-encoded).

        Parameters
        ----------
        **values
            Key -> JSON-able value.
        """
        with self.db:
            self.db.execute("BEGIN IMMEDIATE")
            self.db.executemany(
                "INSERT OR REPLACE INTO campaign (key, value) VALUES (?, ?)",
                [(k, _dumps(v)) for k, v in values.items()],
            )

    def add_cases(self, tasks) -> int:
        """Register tasks as pending cases (those already present are left untouched).

        Parameters
        ----------
        tasks : iterable of SampleTask
            In campaign order.

        Returns
        -------
        int
            Number of cases added.

        Raises
        ------
        InputError
            A case already stored with other parameters (another campaign in this folder).
        """
        known = {cid: p for cid, p in self.db.execute("SELECT case_id, params FROM cases")}
        rows, n0 = [], len(known)
        for i, t in enumerate(tasks):
            params = _dumps(t.parameters())
            if t.case_id in known:
                if known[t.case_id] != params:
                    raise InputError(
                        f"{self.root}: case {t.case_id} is stored with other parameters (another "
                        f"campaign or other settings): use a new folder"
                    )
                continue
            rows.append((t.case_id, n0 + i, t.spec.label, t.dispersion.name, t.sample, t.seed, params))
        with self.db:
            self.db.execute("BEGIN IMMEDIATE")
            self.db.executemany(
                "INSERT INTO cases (case_id, ordinal, label, dispersion, sample, seed, params) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                rows,
            )
        return len(rows)

    def statuses(self) -> dict:
        """Case id -> status.

        Returns
        -------
        dict
        """
        return dict(self.db.execute("SELECT case_id, status FROM cases ORDER BY ordinal"))

    def counts(self) -> dict:
        """Number of cases per status.

        Returns
        -------
        dict
            ``cases``, ``done``, ``failed``, ``pending``.
        """
        c = dict(self.db.execute("SELECT status, COUNT(*) FROM cases GROUP BY status"))
        out = {s: int(c.get(s, 0)) for s in STATUSES}
        return {"cases": sum(out.values()), "done": out["done"], "failed": out["failed"], "pending": out["pending"]}

    def rows(self, status: str | None = None) -> list[dict]:
        """The stored cases as dicts (JSON columns decoded), in campaign order.

        Parameters
        ----------
        status : str, optional
            Only the cases with this status.

        Returns
        -------
        list of dict
        """
        q = "SELECT * FROM cases" + (" WHERE status = ?" if status else "") + " ORDER BY ordinal"
        cur = self.db.execute(q, (status,) if status else ())
        names = [d[0] for d in cur.description]
        out = []
        for r in cur:
            row = dict(zip(names, r))
            for k in ("params", "metrics", "draw", "timings", "files", "versions"):
                try:
                    row[k] = json.loads(row[k]) if row[k] is not None else None
                except (TypeError, ValueError, RecursionError):  # a malformed row: named by check(), never trusted
                    row.setdefault("malformed", f"its {k} column is not JSON ({str(row[k])[:40]!r})")
                    row[k] = None
            out.append(row)
        return out

    # ------------------------------------------------------------------ one case

    def case_dir(self, case_id: str) -> Path:
        """Folder of a case's files.

        Parameters
        ----------
        case_id : str

        Returns
        -------
        Path
        """
        return self.root / "cases" / case_id

    def clean_stale(self) -> list[Path]:
        """Remove temporary folders and the folders of this store's cases not recorded as done (an interrupted
        commit).  A folder named after no case of the store is not the campaign's: it is left where it is.

        Returns
        -------
        list of Path
            The folders removed.
        """
        statuses = self.statuses()
        undone = {cid for cid, s in statuses.items() if s != "done"}
        removed = []
        for p in (self.root / "cases").iterdir():
            temporary = p.name.startswith(".tmp-") and p.name[5:].rpartition("-")[0] in statuses
            if temporary or (p.is_dir() and not p.is_symlink() and p.name in undone):
                shutil.rmtree(p, ignore_errors=True)
                removed.append(p)
        return removed

    def commit(self, outcome: dict, versions: dict) -> None:
        """Record a sample's outcome: its files first (temp folder, rename), then one transaction.

        Parameters
        ----------
        outcome : dict
            From :func:`harness.campaign.execute.run_sample`.
        versions : dict
            Versions the case was computed with (:func:`harness.validation.provenance`).
        """
        cid = outcome["case_id"]
        files = outcome.get("files") or {}
        names = sorted(files)
        recorded = {n: {"bytes": len(files[n]), "sha256": hashlib.sha256(files[n]).hexdigest()} for n in names}
        if outcome["status"] == "done" and files:
            tmp = self.root / "cases" / f".tmp-{cid}-{os.getpid()}"
            shutil.rmtree(tmp, ignore_errors=True)
            tmp.mkdir()
            for name in names:
                with open(tmp / name, "wb") as fh:
                    fh.write(files[name])
                    fh.flush()
                    os.fsync(fh.fileno())
            final = self.case_dir(cid)
            if final.exists():
                shutil.rmtree(final)
            os.rename(tmp, final)
            fd = os.open(final.parent, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        m = outcome.get("metrics")
        verdicts = (m or {}).get("verdicts") or {}

        def judged(name):
            ok = (verdicts.get(name) or {}).get("pass")
            return None if ok is None else int(bool(ok))

        with self.db:
            self.db.execute("BEGIN IMMEDIATE")
            self.db.execute(
                "UPDATE cases SET status = ?, pass = ?, flyable = ?, tracking = ?, engines_agree = ?, cause = ?, "
                "metrics = ?, draw = ?, error = ?, timings = ?, files = ?, "
                "versions = ?, attempts = attempts + 1, finished_utc = ? WHERE case_id = ?",
                (
                    outcome["status"],
                    None if m is None else int(bool(m["pass"])),
                    judged("flyable"),
                    judged("tracking"),
                    judged("engines_agree"),
                    (m or {}).get("cause") if m is not None else "error",
                    None if m is None else _dumps(m),
                    None if outcome.get("draw") is None else _dumps(outcome["draw"]),
                    outcome.get("error"),
                    _dumps(outcome.get("timings", {})),
                    _dumps(recorded),
                    _dumps(versions),
                    time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                    cid,
                ),
            )

    def check(self, row: dict) -> str | None:
        """Why a stored case cannot be trusted (None: it can), its recorded files checked on disk.

        Every case: its id a plain name, its parameters a table.  A case done: its metrics recorded (runs and
        differences), and each file it recorded, confined to its folder (:func:`harness.recorded.confined`), of
        the size and sha256 recorded (stores written before sizes and checksums were recorded: present).

        Parameters
        ----------
        row : dict
            A row of :meth:`rows`.

        Returns
        -------
        str or None
            The cause, e.g. ``"its file inhouse.parquet is shorter than recorded (812 of 40960 bytes: truncated or rewritten)"``,
            ``"it is recorded done without metrics"``.
        """
        try:
            cid = safe_name(row.get("case_id"), "case id")
        except InputError as exc:
            return str(exc)
        if row.get("malformed"):
            return row["malformed"]
        if not isinstance(row.get("params"), dict) or not isinstance(row["params"].get("engines"), list):
            return "its parameters are not recorded"
        if row.get("status") != "done":
            return None
        m = row.get("metrics")
        if not isinstance(m, dict) or not isinstance(m.get("runs"), dict) or not isinstance(m.get("differences"), dict):
            return "it is recorded done without metrics"
        engines = row["params"]["engines"]
        if any(not isinstance(m["runs"].get(e), dict) for e in engines):
            return "it is recorded done without the metrics of every engine"
        for e in engines:
            bad = next((k for k in _RUN_METRICS if not _number_or_none(m["runs"][e].get(k, ""))), None)
            if bad is not None or not isinstance(m["runs"][e].get("status"), str):
                return f"its metric {bad or 'status'} of engine {e} is missing or not a number"
        for e in engines[1:]:
            d = m["differences"].get(e)
            if not isinstance(d, dict) or not _number_or_none(d.get("max_position_m", "")):
                return f"its difference metric max_position_m of engine {e} is missing or not a number"
        files = row.get("files") or {}
        if isinstance(files, list):  # recorded without sizes and checksums
            files = {n: {} for n in files}
        if not isinstance(files, dict):
            return "its files column is malformed"
        for name, rec in sorted(files.items()):
            try:
                path = confined(self.root, f"cases/{cid}/{safe_name(name, 'file')}", "the store names the file")
            except InputError as exc:
                return str(exc)
            rec = rec if isinstance(rec, dict) else {}
            problem = file_problem(path, rec.get("bytes"), rec.get("sha256"))
            if problem is not None:
                return f"its file {name} is {problem}"
        return None

    def reset(self, case_id: str) -> None:
        """Mark a case pending again and remove its files (a case whose files failed :meth:`check`).

        Parameters
        ----------
        case_id : str
        """
        shutil.rmtree(self.case_dir(safe_name(case_id, "case id")), ignore_errors=True)
        with self.db:
            self.db.execute("BEGIN IMMEDIATE")
            self.db.execute(
                "UPDATE cases SET status = 'pending', pass = NULL, metrics = NULL, files = NULL WHERE case_id = ?",
                (case_id,),
            )

    def integrity(self) -> str:
        """``PRAGMA integrity_check`` of the index.

        Returns
        -------
        str
            ``"ok"`` for a sound database.
        """
        return self.db.execute("PRAGMA integrity_check").fetchone()[0]

    def close(self) -> None:
        """Close the database."""
        self.db.close()
