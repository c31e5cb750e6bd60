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
