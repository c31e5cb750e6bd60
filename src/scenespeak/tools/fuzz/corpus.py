"""The fuzzing corpus: bad and hostile inputs for every reader, option and public function.

:func:`build` returns the list of :class:`Case` and (with ``write=True``) writes the files the
cases read into ``root``: a small valid scene first (a stereo pair of photo cards before a
textured wall, its calibration, a database of two objects, a dataset folder), then variants of
each file, each broken in one way. Everything is generated here with fixed seeds.

A case is either a command line (run through :func:`scenespeak.cli.main` in a child process) or
a call of a public function; it says what must happen (``expect``): ``"error"`` (refused with
one line naming ``names``), ``"ok"`` (exit 0 / a return value) or ``"either"`` (no traceback,
hang or memory blow-up; a refusal, if any, one clean line). A ``check`` can look at the output
and call it silently wrong or data loss.

The families and their builders are in :mod:`~scenespeak.tools.fuzz.files` (images and masks
in :mod:`~scenespeak.tools.fuzz.images`, calibrations in
:mod:`~scenespeak.tools.fuzz.calibrations`, datasets and truth files in
:mod:`~scenespeak.tools.fuzz.datasets`), :mod:`~scenespeak.tools.fuzz.dbcases` (the
database and the ``db`` commands), :mod:`~scenespeak.tools.fuzz.options` (every CLI option)
and :mod:`~scenespeak.tools.fuzz.apicases` (the Python API).
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import sqlite3
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

__all__ = ["Case", "Checker", "Expect", "Writer", "build"]

Expect = Literal["error", "ok", "either"]
#: ``check(exit_code, stdout, stderr) -> None`` or ``(class, reason)`` for a wrong outcome.
Checker = Callable[[int, str, str], "tuple[str, str] | None"]

W, H = 320, 240
BASELINE, HFOV = 0.12, 60.0
FOCAL = (W / 2) / np.tan(np.radians(HFOV / 2))
LABELS = ("astronaut", "coffee")


@dataclass(frozen=True)
class Case:
    """One bad (or borderline) input and what must happen with it."""

    id: str
    family: str
    argv: tuple[str, ...] | None = None
    api: Callable[[], object] | None = None
    expect: Expect = "error"
    names: str | None = None
    says: tuple[str, ...] = ()
    setup: Callable[[], None] | None = None
    check: Checker | None = None
    timeout: float = 30.0


@dataclass
class Writer:
    """Writes the corpus files under ``root`` (or only names them, with ``write=False``)."""

    root: Path
    write: bool = True
    cases: list[Case] = field(default_factory=list)

    def path(self, name: str) -> Path:
        p = self.root / name
        if self.write:
            p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def bytes(self, name: str, data: bytes | Callable[[], bytes]) -> Path:
        p = self.path(name)
        if self.write:
            p.write_bytes(data() if callable(data) else data)
        return p

    def text(self, name: str, text: str | Callable[[], str]) -> Path:
        p = self.path(name)
        if self.write:
            p.write_text(
                text() if callable(text) else text, encoding="utf-8", errors="surrogatepass"
            )
        return p

    def json(self, name: str, value: object) -> Path:
        return self.text(name, lambda: json.dumps(value))

    def do(self, fn: Callable[[], object]) -> None:
        if self.write:
            fn()

    def add(self, case: Case) -> None:
        self.cases.append(case)


# --------------------------------------------------------------------------------------------
# the valid scene everything starts from


def photo(name: str, rows: int, cols: int) -> NDArray[np.uint8]:
    """scikit-image's photo ``name`` as RGB uint8 resized to ``rows`` x ``cols``."""
    import cv2
    from skimage import data

    img = getattr(data, name)()
    img = np.stack([img] * 3, -1) if img.ndim == 2 else img[..., :3]
    out = cv2.resize(np.ascontiguousarray(img), (cols, rows), interpolation=cv2.INTER_AREA)
    return np.asarray(out, np.uint8)


def card_pair(seed: int = 0) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """A left/right pair: two photo cards at 1.0 and 1.3 m before a wall 4 m away."""
    import cv2

    rng = np.random.default_rng(seed)
    wall = cv2.resize(
        rng.integers(0, 255, (H // 6, (W + 100) // 6, 3)).astype(np.uint8),
        (W + 100, H),
        interpolation=cv2.INTER_LINEAR,
    )
    d_wall = round(FOCAL * BASELINE / 4.0)
    left = wall[:, 50 : 50 + W].copy()
    right = wall[:, 50 + d_wall : 50 + d_wall + W].copy()
    for name, x, z in (("coffee", 0.18, 1.3), ("astronaut", -0.15, 1.0)):
        wpx = round(FOCAL * 0.2 / z)
        u = round(W / 2 + FOCAL * x / z - wpx / 2)
        v = H // 2 - wpx // 2
        d = round(FOCAL * BASELINE / z)
        card = photo(name, wpx, wpx)
        left[v : v + wpx, u : u + wpx] = card
        right[v : v + wpx, u - d : u - d + wpx] = card
    return np.asarray(left, np.uint8), np.asarray(right, np.uint8)


def _photo_png(label: str) -> bytes:
    return png_bytes(photo(label, 200, 200))


def make_fifo(path: Path) -> None:
    """A FIFO at ``path`` (kept if there)."""
    if not path.exists():
        os.mkfifo(path)


def make_symlink(link: Path, target: Path | str) -> None:
    """A symlink ``link`` → ``target`` (kept if there)."""
    if not link.is_symlink():
        link.symlink_to(target)


def png_bytes(image: NDArray[np.generic], ext: str = ".png") -> bytes:
    """``image`` (RGB or gray) encoded by OpenCV."""
    import cv2

    arr: Any = np.asarray(image)
    if arr.ndim == 3 and arr.shape[2] == 3:
        arr = cv2.cvtColor(arr, cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(ext, arr)
    assert ok
    return buf.tobytes()


@dataclass(frozen=True)
class Base:
    """Paths of the valid scene."""

    left: Path
    right: Path
    calib: Path
    db: Path
    train: dict[str, Path]
    mask: Path
    dataset: Path
    root: Path

    def fresh_db(self, name: str) -> Path:
        """A path for a private copy of the database (copied when the case runs)."""
        return self.root / "private" / f"{name}.db"

    def copy_db(self, dest: Path) -> None:
        dest.parent.mkdir(parents=True, exist_ok=True)
        for suffix in ("-wal", "-shm", "-journal", ".lock"):
            Path(str(dest) + suffix).unlink(missing_ok=True)
        shutil.copyfile(self.db, dest)


def _make_db(db: Path, train: dict[str, Path]) -> None:
    from scenespeak.perception.database import ObjectDatabase

    db.unlink(missing_ok=True)
    with ObjectDatabase.open(db, create=True) as database:
        for label, image in train.items():
            database.add_object(label, [image])


def _make_dataset(w: Writer, base_left: bytes, base_right: bytes, calib: dict[str, object]) -> Path:
    root = w.path("dataset/ok")
    scene = "dataset/ok/scene_000"
    w.bytes(f"{scene}/left.png", base_left)
    w.bytes(f"{scene}/right.png", base_right)
    w.json(f"{scene}/calib.json", calib)
    w.json(f"{scene}/truth.json", _truth())
    w.json("dataset/ok/dataset.json", {"format": "scenespeak-scenes/1", "scenes": ["scene_000"]})
    return root


def _truth() -> dict[str, object]:
    objects = [
        {"label": "astronaut", "centroid": [-0.15, 0.0, 1.0]},
        {"label": "coffee", "centroid": [0.18, 0.0, 1.3]},
    ]
    relations = [
        {"argument": "astronaut", "referent": "coffee", "primary": "left"},
        {"argument": "coffee", "referent": "astronaut", "primary": "right"},
    ]
    return {"objects": objects, "relations": relations}


def make_base(w: Writer) -> Base:
    """Write (or name) the valid scene."""
    pair = card_pair() if w.write else None
    left_b = png_bytes(pair[0]) if pair else b""
    right_b = png_bytes(pair[1]) if pair else b""
    calib = {"baseline": BASELINE, "hfov_deg": HFOV, "image_size": [W, H]}
    left = w.bytes("base/left.png", left_b)
    right = w.bytes("base/right.png", right_b)
    cal = w.json("base/calib.json", calib)
    train = {
        label: w.bytes(f"base/{label}.png", functools.partial(_photo_png, label))
        for label in LABELS
    }
    mask = w.bytes(
        "base/mask.png", lambda: png_bytes(np.pad(np.full((160, 160), 255, np.uint8), 20))
    )
    db = w.path("base/objects.db")
    w.do(lambda: _make_db(db, train))
    dataset = _make_dataset(w, left_b, right_b, calib)
    return Base(left, right, cal, db, train, mask, dataset, w.root)


# --------------------------------------------------------------------------------------------
# helpers the families share


def db_labels(path: Path) -> list[str] | None:
    """The labels in a database file, read with plain sqlite3 (None if unreadable)."""
    try:
        conn = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=5)
        try:
            return sorted(r[0] for r in conn.execute("SELECT label FROM objects"))
        finally:
            conn.close()
    except sqlite3.Error:
        return None


def keeps_labels(path: Path, labels: tuple[str, ...]) -> Checker:
    """A check: afterwards the database at ``path`` still holds ``labels`` (else data loss)."""

    def check(code: int, out: str, err: str) -> tuple[str, str] | None:
        have = db_labels(path)
        if have is None:
            return ("data loss", f"{path.name} is no longer readable")
        missing = [x for x in labels if x not in have]
        if missing:
            return ("data loss", f"{', '.join(missing)} gone from {path.name}")
        return None

    return check


def families() -> Iterator[Callable[[Writer, Base], None]]:
    """Every family's builder, in order."""
    from scenespeak.tools.fuzz import apicases, dbcases, files, jobs, options, service, streams

    yield from files.BUILDERS
    yield from dbcases.BUILDERS
    yield from options.BUILDERS
    yield from apicases.BUILDERS
    yield from streams.BUILDERS
    yield from jobs.BUILDERS
    yield from service.BUILDERS


def build(root: str | os.PathLike[str], *, write: bool = True) -> list[Case]:
    """All cases, writing their files under ``root`` when ``write``.

    The same call with ``write=False`` returns the same cases without touching the disk (the
    runner writes in a child process, so that its own process never starts OpenCV's threads).
    """
    w = Writer(Path(root), write=write)
    if write:
        w.root.mkdir(parents=True, exist_ok=True)
    base = make_base(w)
    for builder in families():
        builder(w, base)
    ids = [c.id for c in w.cases]
    dup = {i for i in ids if ids.count(i) > 1}
    if dup:
        raise RuntimeError(f"duplicate case ids: {sorted(dup)[:5]}")
    return w.cases
