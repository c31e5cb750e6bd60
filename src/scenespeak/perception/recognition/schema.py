"""The SQLite file: its schema, the marks that make it ours, and the checks on opening."""

from __future__ import annotations

import sqlite3
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import DatabaseError
from scenespeak.perception.recognition.index import _DIM

if TYPE_CHECKING:
    from scenespeak.perception.recognition.ivf import FaissIndex, IVFIndex

__all__ = ["APPLICATION", "APPLICATION_ID", "READABLE_VERSIONS", "SCHEMA_VERSION", "migrate"]


APPLICATION = "scenespeak-object-database"
SCHEMA_VERSION = 3
#: Versions this scenespeak reads: 1 (no colour signatures) and 2 (no grey signatures) are
#: upgraded in place when opened for writing (:func:`migrate`), and read as they are when
#: opened read-only.
READABLE_VERSIONS = ("1", "2", "3")
#: SQLite ``PRAGMA application_id`` of our files ("SCSK").
APPLICATION_ID = 0x5343534B
_SQLITE_MAGIC = b"SQLite format 3\x00"

_SCHEMA = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE objects (
    id INTEGER PRIMARY KEY,
    label TEXT NOT NULL UNIQUE,
    added TEXT NOT NULL
);
CREATE TABLE views (
    id INTEGER PRIMARY KEY,
    object_id INTEGER NOT NULL REFERENCES objects(id) ON DELETE CASCADE,
    source TEXT NOT NULL,
    width INTEGER NOT NULL,
    height INTEGER NOT NULL,
    has_mask INTEGER NOT NULL,
    n INTEGER NOT NULL,
    descriptors BLOB NOT NULL,
    keypoints BLOB NOT NULL,
    outline BLOB NOT NULL
);
CREATE INDEX views_object ON views(object_id);
CREATE TABLE view_colours (
    view_id INTEGER PRIMARY KEY REFERENCES views(id) ON DELETE CASCADE,
    signature BLOB NOT NULL,
    aspect REAL NOT NULL,
    grey BLOB,
    grey_aspect REAL
);
CREATE TABLE index_cache (
    kind TEXT PRIMARY KEY,
    generation INTEGER NOT NULL,
    ntotal INTEGER NOT NULL,
    centroids BLOB NOT NULL,
    cells BLOB NOT NULL
);
"""


def _duplicate(label: str) -> str:
    return f"already has an object labelled {label!r}; use --replace to replace it"


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _check_schema(path: Path, conn: sqlite3.Connection) -> None:
    not_ours = "is not a scenespeak object database"
    try:
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    except sqlite3.DatabaseError as exc:
        raise DatabaseError(path, f"{not_ours} (corrupt or not SQLite: {exc})") from None
    if "meta" not in tables:
        raise DatabaseError(path, f"{not_ours} (an SQLite file without our 'meta' table)")
    try:
        meta = dict(conn.execute("SELECT key, value FROM meta").fetchall())
    except sqlite3.DatabaseError as exc:
        raise DatabaseError(path, f"{not_ours} (unreadable 'meta' table: {exc})") from None
    if meta.get("application") != APPLICATION:
        raise DatabaseError(path, f"{not_ours} (its 'meta' table names another application)")
    version = meta.get("schema_version")
    if version not in READABLE_VERSIONS:
        raise DatabaseError(
            path,
            f"{not_ours} of this version (schema version {version}, this scenespeak reads "
            f"{', '.join(READABLE_VERSIONS[:-1])} and {READABLE_VERSIONS[-1]}); rebuild it with "
            "`scenespeak db add`",
        )
    missing = {"objects", "views"} - tables
    if missing:
        raise DatabaseError(path, f"{not_ours} (missing tables: {', '.join(sorted(missing))})")
    try:
        check = conn.execute("PRAGMA quick_check").fetchone()
    except sqlite3.DatabaseError as exc:
        raise DatabaseError(path, f"{not_ours} (corrupt: {exc})") from None
    if check is None or check[0] != "ok":
        raise DatabaseError(path, f"{not_ours} (corrupt: {check[0] if check else 'no answer'})")


#: Schema version 2's addition: each training view's colour signature and chromatic-box aspect
#: (:mod:`~scenespeak.perception.recognition.colour`); views learnt before have no row.
#: Version 3 adds the columns ``grey`` and ``grey_aspect``: its grey signature and object-box
#: aspect (:mod:`~scenespeak.perception.recognition.grey`; NULL for views learnt before).
_COLOUR_TABLE = _SCHEMA[_SCHEMA.index("CREATE TABLE view_colours") :].split(";")[0]
_GREY_COLUMNS = (
    "ALTER TABLE view_colours ADD COLUMN grey BLOB",
    "ALTER TABLE view_colours ADD COLUMN grey_aspect REAL",
)


def migrate(conn: sqlite3.Connection) -> None:
    """Upgrade a version-1 or -2 file to this version in one transaction (a no-op when current).

    Version 2 adds the ``view_colours`` table, version 3 its grey columns; the views learnt
    before keep no colour or grey signature (they are still found by their descriptors;
    ``db add --replace`` adds them).
    """
    row = conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
    if row is None or row[0] == str(SCHEMA_VERSION):
        return
    conn.execute("BEGIN IMMEDIATE")
    try:
        if row[0] == "1":
            conn.execute(_COLOUR_TABLE)
        else:
            for stmt in _GREY_COLUMNS:
                conn.execute(stmt)
        conn.execute(
            "UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(SCHEMA_VERSION),)
        )
        conn.execute("COMMIT")
    except BaseException:
        conn.execute("ROLLBACK")
        raise


# -- the index cache ------------------------------------------------------------------


def cached_quantiser(
    conn: sqlite3.Connection, gen: int, total: int
) -> tuple[NDArray[np.float32] | None, NDArray[np.integer] | None]:
    """The cached quantiser (centroids, cell of each descriptor) if it is of this generation
    and size and intact, else (None, None)."""
    try:
        rows = conn.execute(
            "SELECT generation, ntotal, centroids, cells FROM index_cache WHERE kind = 'ivf'"
        ).fetchall()
    except sqlite3.Error:  # a damaged cache only costs the time to train again
        return None, None
    if not rows or int(rows[0][0]) != gen or int(rows[0][1]) != total:
        return None, None
    if len(rows[0][2]) == 0 or len(rows[0][2]) % (4 * _DIM):
        return None, None
    centroids = np.frombuffer(rows[0][2], np.float32).reshape(-1, _DIM)
    dtype = np.uint16 if centroids.shape[0] <= 65535 else np.int32
    if len(rows[0][3]) != total * np.dtype(dtype).itemsize:
        return None, None
    cells = np.frombuffer(rows[0][3], dtype)
    if cells.size and int(cells.max()) >= centroids.shape[0]:
        return None, None
    return centroids, cast("NDArray[np.integer]", cells)


def save_quantiser(conn: sqlite3.Connection, gen: int, index: IVFIndex | FaissIndex) -> None:
    """Cache the trained quantiser; a failure here only costs time on the next load."""
    try:
        conn.execute("BEGIN IMMEDIATE")
        try:
            conn.execute(
                "INSERT OR REPLACE INTO index_cache(kind, generation, ntotal, centroids, "
                "cells) VALUES ('ivf', ?, ?, ?, ?)",
                (gen, index.ntotal, index.centroids.tobytes(), index.cells().tobytes()),
            )
            conn.execute("COMMIT")
        except BaseException:
            conn.execute("ROLLBACK")
            raise
    except sqlite3.Error:
        pass


def _check_magic(p: Path) -> None:
    """Refuse a file that cannot be read or does not begin as an SQLite file does."""
    try:
        with p.open("rb") as fh:
            head = fh.read(len(_SQLITE_MAGIC))
    except OSError as exc:
        raise DatabaseError(p, f"cannot be read: {exc.strerror or exc}") from None
    if head != _SQLITE_MAGIC:
        raise DatabaseError(p, "is not a scenespeak object database (not an SQLite file)")
