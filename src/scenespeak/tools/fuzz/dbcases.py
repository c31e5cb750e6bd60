"""Corpus family: object databases (damaged files and rows) and the ``db`` commands."""

from __future__ import annotations

import functools
import os
import sqlite3
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from scenespeak.tools.fuzz.corpus import (
    Base,
    Case,
    Checker,
    Expect,
    Writer,
    db_labels,
    keeps_labels,
    make_fifo,
)

_ROW_DAMAGE: dict[str, str] = {
    "n-nan": "UPDATE views SET n = 'NaN' WHERE id = 1",
    "n-real-nan": "UPDATE views SET n = CAST('nan' AS REAL) WHERE id = 1",
    "n-negative": "UPDATE views SET n = -4 WHERE id = 1",
    "n-text": "UPDATE views SET n = 'many' WHERE id = 1",
    "n-1e12": "UPDATE views SET n = 1000000000000 WHERE id = 1",
    "n-null-ish": "UPDATE views SET n = '' WHERE id = 1",
    "width-negative": "UPDATE views SET width = -1 WHERE id = 1",
    "width-huge": "UPDATE views SET width = 9000000000 WHERE id = 1",
    "descriptors-truncated": "UPDATE views SET descriptors = substr(descriptors, 1, 1000) "
    "WHERE id = 1",
    "descriptors-empty": "UPDATE views SET descriptors = x'' WHERE id = 1",
    "descriptors-text": "UPDATE views SET descriptors = 'hello' WHERE id = 1",
    "keypoints-odd": "UPDATE views SET keypoints = substr(keypoints, 1, 7) WHERE id = 1",
    "keypoints-nan": "UPDATE views SET keypoints = zeroblob(length(keypoints)) WHERE id = 1",
    "outline-odd": "UPDATE views SET outline = x'000102' WHERE id = 1",
    "outline-million": "UPDATE views SET outline = zeroblob(8000000) WHERE id = 1",
    "outline-empty": "UPDATE views SET outline = x'' WHERE id = 1",
    "label-empty": "UPDATE objects SET label = '' WHERE id = 1",
    "label-escape": "UPDATE objects SET label = char(27) || '[2J' || char(27) || '[31mred' "
    "WHERE id = 1",
    "label-newline": "UPDATE objects SET label = 'two' || char(10) || 'lines' WHERE id = 1",
    "label-bad-utf8": "UPDATE objects SET label = CAST(x'ff fe 41' AS TEXT) WHERE id = 1",
    "label-number": "UPDATE objects SET label = 42 WHERE id = 1",
    "added-garbage": "UPDATE objects SET added = 'yesterday' WHERE id = 1",
    "object-without-views": "DELETE FROM views WHERE object_id = 1",
    "orphan-view": "UPDATE views SET object_id = 999 WHERE id = 1",
    "meta-generation-text": "UPDATE meta SET value = 'abc' WHERE key = 'generation'",
    "meta-version-999": "UPDATE meta SET value = '999' WHERE key = 'schema_version'",
    "meta-app-other": "UPDATE meta SET value = 'something-else' WHERE key = 'application'",
    "meta-missing": "DROP TABLE meta",
    "views-missing": "DROP TABLE views",
    "views-column-missing": "ALTER TABLE views DROP COLUMN outline",
    "objects-missing": "DROP TABLE objects",
    "index-cache-poisoned": "INSERT OR REPLACE INTO index_cache VALUES ('ivf', "
    "(SELECT CAST(value AS INTEGER) FROM meta WHERE key = 'generation'), "
    "(SELECT sum(n) FROM views), randomblob(1024), randomblob(64))",
    "index-cache-garbage-kind": "INSERT OR REPLACE INTO index_cache "
    "VALUES ('exact', 0, -5, x'', x'')",
}


def _damage(base: Base, dest: Path, sql: str) -> Callable[[], None]:
    def run() -> None:
        base.copy_db(dest)
        conn = sqlite3.connect(dest)
        conn.executescript(sql.replace("x'ff fe 41'", "x'fffe41'") + ";")
        conn.commit()
        conn.close()

    return run


def _file_kinds(w: Writer, base: Base) -> dict[str, Path]:
    rng = np.random.default_rng(7)
    out: dict[str, Path] = {
        "zero-bytes.db": w.bytes("db/zero-bytes.db", b""),
        "text.db": w.bytes("db/text.db", b"hello, not a database\n"),
        "random.db": w.bytes("db/random.db", lambda: rng.bytes(8192)),
        "sqlite-header-zeros.db": w.bytes(
            "db/sqlite-header-zeros.db", b"SQLite format 3\x00" + bytes(4080)
        ),
    }
    other = w.path("db/other-sqlite.db")

    def make_other() -> None:
        other.unlink(missing_ok=True)
        conn = sqlite3.connect(other)
        conn.execute("CREATE TABLE customers (id INTEGER, name TEXT)")
        conn.commit()
        conn.close()

    w.do(make_other)
    out["other-sqlite.db"] = other
    half = w.path("db/truncated.db")

    def make_half() -> None:
        data = base.db.read_bytes()
        half.write_bytes(data[: len(data) // 2])

    w.do(make_half)
    out["truncated.db"] = half
    flipped = w.path("db/bitflipped.db")

    def make_flipped() -> None:
        data = bytearray(base.db.read_bytes())
        for k in range(4096, len(data), 4099):
            data[k] ^= 0xFF
        flipped.write_bytes(bytes(data))

    w.do(make_flipped)
    out["bitflipped.db"] = flipped
    folder = w.path("db/folder.db")
    w.do(lambda: folder.mkdir(exist_ok=True))
    out["folder.db"] = folder
    fifo = w.path("db/fifo.db")
    w.do(functools.partial(make_fifo, fifo))
    out["fifo.db"] = fifo
    out["dev-null"] = Path("/dev/null")
    out["dev-zero"] = Path("/dev/zero")
    out["missing.db"] = w.root / "db" / "missing.db"
    out["name-300.db"] = w.root / "db" / ("d" * 300 + ".db")
    return out


def databases(w: Writer, base: Base) -> None:
    """Damaged database files and rows, through ``db list``, ``describe``, ``db add``/``remove``."""
    targets: dict[str, tuple[Path, Callable[[], None] | None]] = {
        name: (path, None) for name, path in _file_kinds(w, base).items()
    }
    for name, sql in _ROW_DAMAGE.items():
        row_db = w.path(f"db/row-{name}.db")
        w.do(_damage(base, row_db, sql))
        targets[f"row-{name}"] = (row_db, None)
    either = {
        "row-added-garbage",
        "row-index-cache-poisoned",
        "row-index-cache-garbage-kind",
        "row-label-escape",
        "row-label-number",
        "row-keypoints-nan",
        "row-width-huge",
        "row-width-negative",
        "row-orphan-view",
    }
    for name, (path, _) in targets.items():
        p: str = str(path)
        expect: Expect = "either" if name in either else "error"
        list_expect: Expect = expect
        if name.startswith("row-") and any(
            k in name for k in ("descriptors", "keypoints", "outline", "width", "orphan", "index")
        ):
            list_expect = "either"  # db list reads labels and counts, not the blobs
        w.add(
            Case(
                f"db/{name}/list",
                "database",
                ("db", "list", "--db", p),
                expect=list_expect,
                names=p,
                check=_no_raw_escapes,
            )
        )
        w.add(
            Case(
                f"db/{name}/list-json",
                "database",
                ("db", "list", "--db", p, "--json"),
                expect=list_expect,
                names=p,
            )
        )
        w.add(
            Case(
                f"db/{name}/describe",
                "database",
                (
                    "describe",
                    "--db",
                    p,
                    "--calib",
                    str(base.calib),
                    str(base.left),
                    str(base.right),
                    "-q",
                ),
                expect=expect,
                names=p,
                check=_no_raw_escapes,
            )
        )
        if name.startswith("row-") or name in ("truncated.db", "bitflipped.db"):
            copy = base.fresh_db(f"dbadd-{name}")
            src = path
            w.add(
                Case(
                    f"db/{name}/add",
                    "database",
                    (
                        "db",
                        "add",
                        "--db",
                        str(copy),
                        "--label",
                        "new",
                        str(base.train["coffee"]),
                        "-q",
                    ),
                    expect=expect,
                    names=str(copy),
                    setup=functools.partial(_copy, src, copy),
                )
            )
            w.add(
                Case(
                    f"db/{name}/remove",
                    "database",
                    ("db", "remove", "--db", str(copy), "coffee"),
                    expect=expect,
                    names=str(copy),
                    setup=functools.partial(_copy, src, copy),
                )
            )
        elif name not in ("missing.db",):
            w.add(
                Case(
                    f"db/{name}/add",
                    "database",
                    ("db", "add", "--db", p, "--label", "new", str(base.train["coffee"]), "-q"),
                    names=p,
                )
            )


def _copy(src: Path, dest: Path) -> None:
    dest.parent.mkdir(parents=True, exist_ok=True)
    for suffix in ("-wal", "-shm", "-journal", ".lock"):
        Path(str(dest) + suffix).unlink(missing_ok=True)
    dest.write_bytes(src.read_bytes())


def _no_raw_escapes(code: int, out: str, err: str) -> tuple[str, str] | None:
    for stream, text in (("stdout", out), ("stderr", err)):
        if "\x1b" in text or "\x9b" in text:
            return ("security", f"a raw terminal escape sequence on {stream}")
    return None


def _gone(path: Path, labels: tuple[str, ...]) -> Checker:
    def check(code: int, out: str, err: str) -> tuple[str, str] | None:
        have = db_labels(path) or []
        left = [x for x in labels if x in have]
        return ("silently wrong", f"still there: {left}") if left and code == 0 else None

    return check


def _with_label(base: Base, copy: Path, label: str) -> Callable[[], None]:
    def run() -> None:
        base.copy_db(copy)
        from scenespeak.perception.database import ObjectDatabase

        with ObjectDatabase.open(copy) as db:
            db.add_object(label, [base.train["coffee"]])

    return run


def _locked(base: Base, copy: Path, seconds: float) -> Callable[[], None]:
    """Copy the database and hold an exclusive lock on it from another process."""

    def run() -> None:
        base.copy_db(copy)
        ready_r, ready_w = os.pipe()
        pid = os.fork()
        if pid == 0:  # the other process
            try:
                conn = sqlite3.connect(copy, isolation_level=None)
                conn.execute("BEGIN EXCLUSIVE")
                os.write(ready_w, b"1")
                time.sleep(seconds)
                conn.execute("ROLLBACK")
            finally:
                os._exit(0)
        os.read(ready_r, 1)

    return run


def db_commands(w: Writer, base: Base) -> None:
    """Labels and arguments of ``db add`` / ``db remove``."""
    img = str(base.train["coffee"])
    labels: dict[str, tuple[str, Expect]] = {
        "empty": ("", "error"),
        "spaces": ("   ", "error"),
        "escape": ("\x1b[2J\x1b[31mred", "error"),
        "newline": ("two\nlines", "error"),
        "tab": ("a\tb", "error"),
        "surrogate": ("bad\udcff", "error"),
        "bidi": ("abc\u202edcb", "error"),
        "nul": ("a\x00b", "error"),
        "long-10000": ("x" * 10_000, "error"),
        "unicode": ("café ☕", "ok"),
        "dash-help": ("--help", "ok"),
        "dash-x": ("-x", "ok"),
        "duplicate": ("astronaut", "error"),
    }
    for name, (label, expect) in labels.items():
        copy = base.fresh_db(f"label-{name}")
        w.add(
            Case(
                f"db-label/{name}/add",
                "db commands",
                ("db", "add", "--db", str(copy), f"--label={label}", img, "-q"),
                expect=expect,
                names="label" if name != "duplicate" else "astronaut",
                setup=functools.partial(base.copy_db, copy),
                check=keeps_labels(copy, ("astronaut", "coffee")),
            )
        )
    for name, label in (("dash-help", "--help"), ("dash-x", "-x"), ("unicode", "café ☕")):
        copy = base.fresh_db(f"remove-{name}")
        w.add(
            Case(
                f"db-label/{name}/remove",
                "db commands",
                ("db", "remove", "--db", str(copy), "--", label),
                expect="ok",
                setup=_with_label(base, copy, label),
                check=_gone(copy, (label,)),
            )
        )
    copy = base.fresh_db("remove-one-missing")
    w.add(
        Case(
            "db-remove/one-missing",
            "db commands",
            ("db", "remove", "--db", str(copy), "astronaut", "no-such-label"),
            names="no-such-label",
            setup=lambda: base.copy_db(copy),
            check=keeps_labels(copy, ("astronaut", "coffee")),
        )
    )
    copy2 = base.fresh_db("remove-two")
    w.add(
        Case(
            "db-remove/two",
            "db commands",
            ("db", "remove", "--db", str(copy2), "astronaut", "coffee"),
            expect="ok",
            setup=lambda: base.copy_db(copy2),
            check=_gone(copy2, ("astronaut", "coffee")),
        )
    )
    copy3 = base.fresh_db("remove-twice")
    w.add(
        Case(
            "db-remove/same-twice",
            "db commands",
            ("db", "remove", "--db", str(copy3), "astronaut", "astronaut"),
            expect="either",
            setup=lambda: base.copy_db(copy3),
            check=keeps_labels(copy3, ("coffee",)),
        )
    )
    copy4 = base.fresh_db("remove-missing")
    w.add(
        Case(
            "db-remove/missing-db",
            "db commands",
            ("db", "remove", "--db", str(w.root / "db" / "nope.db"), "astronaut"),
            names="nope.db",
        )
    )
    w.add(
        Case(
            "db-remove/none-given",
            "db commands",
            ("db", "remove", "--db", str(copy4)),
            setup=lambda: base.copy_db(copy4),
        )
    )
    newdir = w.root / "db" / "no-such-dir" / "x.db"
    w.add(
        Case(
            "db-add/missing-dir",
            "db commands",
            ("db", "add", "--db", str(newdir), "--label", "a", img, "-q"),
            names=str(newdir),
        )
    )
    fresh = w.root / "private" / "fresh-bad-image.db"
    w.add(
        Case(
            "db-add/new-db-bad-image",
            "db commands",
            ("db", "add", "--db", str(fresh), "--label", "a", str(base.calib), "-q"),
            names=str(base.calib),
            setup=lambda: fresh.unlink(missing_ok=True),
            check=_no_file_left(fresh),
        )
    )
    locked = base.fresh_db("locked")
    w.add(
        Case(
            "db-add/locked-by-other",
            "db commands",
            ("db", "add", "--db", str(locked), "--label", "new", img, "-q"),
            expect="either",
            names=str(locked),
            says=("locked",),
            setup=_locked(base, locked, 4.0),
            check=keeps_labels(locked, ("astronaut", "coffee")),
        )
    )
    locked2 = base.fresh_db("locked-list")
    w.add(
        Case(
            "db-list/locked-by-other",
            "db commands",
            ("db", "list", "--db", str(locked2)),
            expect="either",
            names=str(locked2),
            says=("locked",),
            setup=_locked(base, locked2, 4.0),
        )
    )


def _no_file_left(path: Path) -> Checker:
    def check(code: int, out: str, err: str) -> tuple[str, str] | None:
        if code != 0 and path.exists() and db_labels(path) is None:
            return ("data loss", f"a failed first db add left an unusable {path.name}")
        return None

    return check


BUILDERS = (databases, db_commands)
