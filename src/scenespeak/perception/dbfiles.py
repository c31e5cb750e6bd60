"""The object database file as untrusted input and as a shared, killable resource.

* :func:`create_atomically` — a new database is built in a temporary file beside the target and
  then linked into place (``os.link`` fails if the name exists), so a ``db add`` killed while it
  creates the file leaves no file, never a 0-byte or half-made one; two processes creating the
  same file at once both end up using the one that won.
* :func:`connect` — opens with a bounded wait for other writers (:attr:`~scenespeak.limits.
  Limits.db_wait_s`), recovers a hot journal left by a killed writer before a read-only open,
  and tells "locked by another process" apart from "not a database".
* :func:`begin_write` — ``BEGIN IMMEDIATE`` that first tries briefly, then says it is waiting
  (a callback) and waits up to the limit.
* :func:`whole` / :func:`blob_rows` / :func:`printable_label` — every value read from a row is
  checked before it is used or allocated for, and a bad one is reported as
  ``database is damaged: view 3 of 'mug': …`` naming the row.
"""

from __future__ import annotations

import contextlib
import math
import os
import secrets
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any

from scenespeak import limits as _limits
from scenespeak.errors import DatabaseError
from scenespeak.safeio import clean_text

__all__ = [
    "begin_write",
    "blob_rows",
    "connect",
    "create_atomically",
    "damaged",
    "printable_label",
    "whole",
]

Waiting = Callable[[str], None]


def _publish(tmp: Path, path: Path) -> bool:
    """Flush the finished file ``tmp`` to disk and link it in as ``path`` unless one exists.

    Returns False when another process created ``path`` first (a link never replaces a file,
    so readers never see a half-written database).
    """
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    try:
        os.link(tmp, path)
        return True
    except FileExistsError:
        return False


def damaged(path: Path, where: str, problem: str) -> DatabaseError:
    """``<path>: database is damaged: <where>: <problem>`` (one line, escapes shown)."""
    return DatabaseError(path, f"database is damaged: {clean_text(where)}: {clean_text(problem)}")


def whole(value: Any, path: Path, where: str, *, limit: int | None = None, minimum: int = 0) -> int:
    """A count read from a row: a whole number in ``[minimum, limit]``, else damaged."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise damaged(path, where, f"expected a whole number, got {clean_text(repr(value))[:40]}")
    if isinstance(value, float) and (not math.isfinite(value) or value != int(value)):
        raise damaged(path, where, f"expected a whole number, got {value!r}")
    n = int(value)
    if n < minimum:
        raise damaged(path, where, f"{n} is negative" if n < 0 else f"{n} is below {minimum}")
    if limit is not None and n > limit:
        raise damaged(path, where, f"{n} is over the limit of {limit} (a damaged count?)")
    return n


def blob_rows(blob: Any, path: Path, where: str, *, itemsize: int, rows: int | None = None) -> int:
    """The number of ``itemsize``-byte rows in a BLOB (checked against ``rows`` if given)."""
    if not isinstance(blob, bytes | bytearray | memoryview):
        raise damaged(path, where, f"expected binary data, got {type(blob).__name__}")
    size = len(blob)
    if size % itemsize:
        raise damaged(path, where, f"{size} bytes is not a whole number of {itemsize}-byte rows")
    n = size // itemsize
    if rows is not None and n != rows:
        raise damaged(path, where, f"holds {n} rows, the row says {rows}")
    return n


def printable_label(value: Any, path: Path, where: str) -> str:
    """A label read from a row: non-empty printable text, else damaged."""
    if not isinstance(value, str):
        raise damaged(path, where, f"the label is not text ({type(value).__name__})")
    if not value.strip():
        raise damaged(path, where, "the label is empty")
    if clean_text(value) != value or "\t" in value:
        raise damaged(path, where, f"the label {clean_text(repr(value))} has control characters")
    if len(value) > _limits.current().max_label_chars:
        raise damaged(path, where, f"the label has {len(value)} characters")
    return value


def _tmp_name(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.creating")


def create_atomically(path: Path, build: Callable[[sqlite3.Connection], None]) -> bool:
    """Create ``path`` as a database made by ``build``, atomically.

    Returns
    -------
    bool
        True if this call created it, False if another process created it first (then the
        caller opens that one).

    Raises
    ------
    DatabaseError
        The folder is missing or not writable, or the name is too long.
    """
    if not path.parent.is_dir():
        raise DatabaseError(path, f"the folder {str(path.parent)!r} does not exist")
    tmp = _tmp_name(path)
    try:
        conn = sqlite3.connect(tmp, isolation_level=None)
        try:
            conn.execute("BEGIN IMMEDIATE")
            build(conn)
            conn.execute("COMMIT")
        finally:
            conn.close()
        return _publish(tmp, path)
    except sqlite3.Error as exc:
        raise DatabaseError(path, f"cannot create the database: {exc}") from None
    except OSError as exc:
        raise DatabaseError(path, f"cannot create the database ({exc.strerror or exc})") from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()
        for suffix in ("-journal", "-wal", "-shm"):
            with contextlib.suppress(OSError):
                Path(str(tmp) + suffix).unlink()


def _hot_journal(path: Path) -> bool:
    try:
        return Path(str(path) + "-journal").stat().st_size > 0
    except OSError:
        return False


def _locked(exc: sqlite3.Error) -> bool:
    text = str(exc).lower()
    return "locked" in text or "busy" in text


def locked_error(path: Path) -> DatabaseError:
    wait = _limits.current().db_wait_s
    return DatabaseError(
        path,
        f"is locked by another process (a db add or db remove?) for more than {wait:g} s; "
        "try again when it has finished (--limit db_wait_s=N waits longer)",
    )


def connect(path: Path, *, readonly: bool) -> sqlite3.Connection:
    """Open an existing database file, waiting at most ``db_wait_s`` for other writers.

    A hot journal (a writer killed in a transaction) is rolled back first, even for a
    read-only open (which could not do it itself).
    """
    wait = _limits.current().db_wait_s
    try:
        if readonly and _hot_journal(path) and os.access(path, os.W_OK):
            recover = sqlite3.connect(path, timeout=wait, isolation_level=None)
            try:
                recover.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()
            finally:
                recover.close()
        if readonly:
            uri = f"{path.resolve().as_uri()}?mode=ro"
            return sqlite3.connect(uri, uri=True, timeout=wait, isolation_level=None)
        return sqlite3.connect(path, timeout=wait, isolation_level=None)
    except sqlite3.Error as exc:
        if _locked(exc):
            raise locked_error(path) from None
        raise DatabaseError(path, f"cannot be opened: {exc}") from None


def begin_write(conn: sqlite3.Connection, path: Path, waiting: Waiting | None = None) -> None:
    """``BEGIN IMMEDIATE``: try for 0.2 s, then tell ``waiting`` and wait up to the limit."""
    wait = _limits.current().db_wait_s
    conn.execute("PRAGMA busy_timeout = 200")
    try:
        conn.execute("BEGIN IMMEDIATE")
        return
    except sqlite3.OperationalError as exc:
        if not _locked(exc):
            raise
    finally:
        conn.execute(f"PRAGMA busy_timeout = {int(wait * 1000)}")
    if waiting is not None:
        waiting(f"waiting for another process writing {path} (up to {wait:g} s)")
    try:
        conn.execute("BEGIN IMMEDIATE")
    except sqlite3.OperationalError as exc:
        if _locked(exc):
            raise locked_error(path) from None
        raise


# --------------------------------------------------------------------------------------------
# checks before the database is opened, and of every row


def check_file(path: Path, *, must_exist: bool = True) -> bool:
    """Refuse what is not a regular database file before SQLite touches it; True if it exists.

    A FIFO would block, a device read forever, a folder or an over-long name give SQLite's
    own confusing errors; a 0-byte file is not a database.
    """
    import stat

    try:
        st = os.stat(path)
    except FileNotFoundError:
        if must_exist:
            raise DatabaseError(
                path,
                "no such file; create it with `scenespeak db add --db FILE --label NAME IMAGE`",
            ) from None
        return False
    except OSError as exc:
        from scenespeak.safetext import _os_problem

        raise DatabaseError(path, _os_problem(exc)) from None
    if stat.S_ISDIR(st.st_mode):
        raise DatabaseError(path, "is a folder, not a scenespeak object database file")
    if not stat.S_ISREG(st.st_mode):
        raise DatabaseError(path, "is not a regular file (a FIFO or a device?): not a database")
    if st.st_size == 0:
        raise DatabaseError(
            path,
            "the file is empty (0 bytes), not a scenespeak object database (scenespeak "
            "creates databases atomically, so no other scenespeak is creating it): delete it",
        )
    return True


def _probe(path: Path) -> None:
    """Read the schema once, telling a lock apart from a file that is not ours."""
    conn = connect(path, readonly=True)
    try:
        conn.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()
    except sqlite3.OperationalError as exc:
        if _locked(exc):
            raise locked_error(path) from None
        raise DatabaseError(path, f"is not a scenespeak object database ({exc})") from None
    except sqlite3.DatabaseError as exc:
        raise DatabaseError(path, f"is not a scenespeak object database ({exc})") from None
    finally:
        conn.close()


_ROWS = """
SELECT v.id, v.object_id, o.label, v.n, v.width, v.height, typeof(v.descriptors),
       length(v.descriptors), typeof(v.keypoints), length(v.keypoints), typeof(v.outline),
       length(v.outline)
FROM views v LEFT JOIN objects o ON o.id = v.object_id ORDER BY v.id
"""


def validate(path: Path) -> None:
    """Check every row of an (existing, ours) database before it is used.

    Counts must be whole numbers within the limits, every BLOB must hold exactly what its row
    says, labels must be printable, every object needs a view and every view an object.
    Reads only lengths and small columns (no BLOB is loaded), so it is cheap.

    Raises
    ------
    DatabaseError
        ``database is damaged: <which row>: <what>`` — or "locked by another process".
    """
    from scenespeak.perception.database import ObjectDatabase

    _probe(path)
    ObjectDatabase._connect(path, readonly=True, index="auto").close()  # ours, this schema
    lim = _limits.current()
    conn = connect(path, readonly=True)
    try:
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        if not {"meta", "objects", "views"} <= tables:
            return  # not ours, or another schema: ObjectDatabase.open says which
        cols = {r[1] for r in conn.execute("PRAGMA table_info(views)")}
        needed = {"n", "width", "height", "descriptors", "keypoints", "outline", "object_id"}
        if not needed <= cols:
            missing = ", ".join(sorted(needed - cols))
            raise damaged(path, "table views", f"missing columns: {missing}")
        labels = _check_objects(conn, path, lim)
        seen: set[int] = set()
        for row in conn.execute(_ROWS):
            _check_view(path, row, lim)
            seen.add(int(row[1]))
        lonely = [str(label) for oid, label in labels if oid not in seen]
        if lonely:
            raise damaged(path, f"object {clean_text(repr(lonely[0]))}", "has no training view")
    except sqlite3.OperationalError as exc:
        if _locked(exc):
            raise locked_error(path) from None
        raise damaged(path, "the file", str(exc)) from None
    except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:
        raise damaged(path, "the file", str(exc)) from None
    finally:
        conn.close()


def _check_objects(
    conn: sqlite3.Connection, path: Path, lim: _limits.Limits
) -> list[tuple[Any, Any]]:
    """The meta generation and every object's label checked; the (id, label) rows."""
    meta = dict(conn.execute("SELECT key, value FROM meta").fetchall())
    if "generation" in meta:
        try:
            int(str(meta["generation"]))
        except ValueError:
            raise damaged(
                path, "meta generation", f"{meta['generation']!r} is not a number"
            ) from None
    labels = conn.execute("SELECT id, label FROM objects").fetchall()
    if len(labels) > lim.max_db_objects:
        raise damaged(path, "table objects", f"{len(labels)} objects is over max_db_objects")
    for oid, label in labels:
        try:
            printable_label(label, path, f"object {oid}")
        except UnicodeDecodeError:
            raise damaged(path, f"object {oid}", "the label is not UTF-8 text") from None
    return labels


def _check_view(path: Path, row: tuple[Any, ...], lim: _limits.Limits) -> None:
    vid, oid, label, n, width, height, dt, dlen, kt, klen, ot, olen = row
    where = f"view {vid} of {clean_text(repr(label))}" if label is not None else f"view {vid}"
    if label is None:
        raise damaged(path, where, f"belongs to object {oid}, which does not exist")
    count = whole(n, path, f"{where}: n", limit=lim.max_db_descriptors)
    whole(width, path, f"{where}: width", limit=lim.max_image_side, minimum=1)
    whole(height, path, f"{where}: height", limit=lim.max_image_side, minimum=1)
    for name, typ, length, per_row in (("descriptors", dt, dlen, 128), ("keypoints", kt, klen, 16)):
        if typ != "blob":
            raise damaged(path, f"{where}: {name}", f"expected binary data, got {typ}")
        if length != count * per_row:
            raise damaged(
                path, f"{where}: {name}", f"{length} bytes, but n = {count} needs {count * per_row}"
            )
    if count == 0:
        raise damaged(path, f"{where}: n", "a view without descriptors")
    if ot != "blob" or olen % 8:
        raise damaged(path, f"{where}: outline", f"{olen} bytes is not a list of (x, y) float32")
    if olen // 8 > lim.max_db_outline:
        raise damaged(path, f"{where}: outline", f"{olen // 8} vertices is over max_db_outline")
    if olen // 8 < 3:
        raise damaged(path, f"{where}: outline", f"{olen // 8} vertices; an outline needs 3")


def remove_labels(path: Path, labels: list[str], waiting: Waiting | None = None) -> list[str]:
    """Remove several objects in ONE transaction (all or none); return the labels removed.

    Raises
    ------
    DatabaseError
        A label that is not in the database (then nothing is removed), or a lock held longer
        than ``db_wait_s``.
    """
    from scenespeak.perception.recognition.views import forget_raised

    unique = list(dict.fromkeys(labels))
    conn = connect(path, readonly=False)
    try:
        begin_write(conn, path, waiting)
        try:
            ids: list[int] = []
            for label in unique:
                rows = conn.execute("SELECT id FROM objects WHERE label = ?", (label,)).fetchall()
                if not rows:
                    known = [
                        str(r[0]) for r in conn.execute("SELECT label FROM objects ORDER BY label")
                    ]
                    shown = ", ".join(clean_text(k) for k in known[:10]) or "none"
                    raise DatabaseError(
                        path,
                        f"has no object labelled {clean_text(repr(label))} (labels: {shown}); "
                        "nothing was removed",
                    )
                ids.extend(int(r[0]) for r in rows)
            for oid in ids:
                forget_raised(conn, oid)
                conn.execute("DELETE FROM views WHERE object_id = ?", (oid,))
                conn.execute("DELETE FROM objects WHERE id = ?", (oid,))
            conn.execute(
                "UPDATE meta SET value = CAST(CAST(value AS INTEGER) + 1 AS TEXT) "
                "WHERE key = 'generation'"
            )
            conn.execute("COMMIT")
        except BaseException:
            conn.execute("ROLLBACK")
            raise
    except sqlite3.OperationalError as exc:
        if _locked(exc):
            raise locked_error(path) from None
        raise DatabaseError(path, f"cannot write: {exc}") from None
    finally:
        conn.close()
    return unique


def wait_for_writers(path: Path, waiting: Waiting | None = None) -> None:
    """Wait (saying so) until no other process holds a write lock; refuse after the limit."""
    conn = connect(path, readonly=False)
    try:
        begin_write(conn, path, waiting)
        conn.execute("ROLLBACK")
    except sqlite3.OperationalError as exc:
        if _locked(exc):
            raise locked_error(path) from None
        raise DatabaseError(path, f"cannot be opened for writing: {exc}") from None
    finally:
        conn.close()


def create_empty(path: Path) -> bool:
    """Create an empty scenespeak database at ``path`` atomically (False: it already exists).

    The schema is written by ``ObjectDatabase._new_file`` into a temporary file, which is
    then linked into place.
    """
    from scenespeak.perception.database import ObjectDatabase

    if not path.parent.is_dir():
        raise DatabaseError(path, f"the folder {str(path.parent)!r} does not exist")
    tmp = _tmp_name(path)
    try:
        ObjectDatabase._new_file(tmp)
        return _publish(tmp, path)
    except OSError as exc:
        from scenespeak.safetext import _os_problem

        raise DatabaseError(path, f"cannot create the database ({_os_problem(exc)})") from None
    finally:
        for suffix in ("", "-journal", "-wal", "-shm"):
            with contextlib.suppress(OSError):
                Path(str(tmp) + suffix).unlink()
