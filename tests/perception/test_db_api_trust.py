"""Issue 12 from Python: ObjectDatabase.open/create check the file as the CLI does, the IVF
cache is checked for what it says (not only its sizes), and the API refuses bad values."""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from skimage import data

from scenespeak.errors import CalibrationError, DatabaseError, ImageError
from scenespeak.perception.calibration import load_rig, rig_from_short
from scenespeak.perception.features import detect, load_image, to_gray
from scenespeak.perception.recognition import IVFIndex, ObjectDatabase, outline_from_mask


@pytest.fixture(scope="module")
def small_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("trustdb") / "objects.db"
    with ObjectDatabase.create(path) as db:
        db.add_object("astronaut", [to_gray(data.astronaut())[30:330, 100:400]])
        db.add_object("coffee", [to_gray(data.coffee())[50:350, 150:450]])
    return path


def _copy(src: Path, dest: Path) -> Path:
    dest.write_bytes(src.read_bytes())
    return dest


def _cache(path: Path) -> tuple[bytes, bytes]:
    with sqlite3.connect(path) as conn:
        row = conn.execute("SELECT centroids, cells FROM index_cache WHERE kind='ivf'").fetchone()
    conn.close()
    return bytes(row[0]), bytes(row[1])


def _poison(path: Path, how: str) -> None:
    centroids, cells = _cache(path)
    c = np.frombuffer(centroids, np.float32).copy()
    k = np.frombuffer(cells, np.uint16).copy()
    nlist = c.size // 128
    if how == "cells":  # every descriptor filed under the wrong cell: sizes all valid
        k = ((k.astype(np.int64) + 1) % nlist).astype(np.uint16)
    elif how == "centroids":  # other (finite, in-range) centroids, the same cells
        c = np.random.default_rng(0).uniform(0, 255, c.size).astype(np.float32)
    else:  # centroids no k-means of uint8 vectors can give
        c[:128] = 1e30
    with sqlite3.connect(path) as conn:
        conn.execute(
            "UPDATE index_cache SET centroids = ?, cells = ? WHERE kind='ivf'",
            (c.tobytes(), k.tobytes()),
        )
    conn.close()


def _label(path: Path, *, readonly: bool) -> tuple[set[str], IVFIndex]:
    query = detect(to_gray(data.astronaut())[30:330, 100:400])
    with ObjectDatabase.open(path, readonly=readonly, index="ivf") as db:
        found = {d.label for d in db.label(query).detections}
        index = db.index
    assert isinstance(index, IVFIndex)
    return found, index


@pytest.mark.parametrize("how", ["cells", "centroids", "out-of-range"])
def test_poisoned_ivf_cache_with_valid_sizes_is_detected_and_rebuilt(
    small_db: Path, tmp_path: Path, how: str
) -> None:
    path = _copy(small_db, tmp_path / "objects.db")
    found, first = _label(path, readonly=False)  # trains and caches the quantiser
    assert found == {"astronaut"} and not first.cache_rejected
    good = _cache(path)
    _, again = _label(path, readonly=True)
    assert not again.cache_rejected  # a good cache is trusted (and not retrained)
    _poison(path, how)
    found, index = _label(path, readonly=True)
    assert index.cache_rejected and found == {"astronaut"}
    np.testing.assert_array_equal(index.cells(), first.cells())  # the same seed: retrained
    found, index = _label(path, readonly=False)
    assert index.cache_rejected and found == {"astronaut"}
    assert _cache(path) == good  # and written back when the file is writable


def test_open_runs_the_cli_file_checks(small_db: Path, tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.db"
    os.mkfifo(fifo)
    with pytest.raises(DatabaseError, match="FIFO"):
        ObjectDatabase.open(fifo)  # returns at once: never blocks
    empty = tmp_path / "empty.db"
    empty.write_bytes(b"")
    with pytest.raises(DatabaseError, match="empty"):
        ObjectDatabase.open(empty)
    with pytest.raises(DatabaseError, match="expected a file name"):
        ObjectDatabase.open(None)  # type: ignore[arg-type]
    damaged = _copy(small_db, tmp_path / "damaged.db")
    with sqlite3.connect(damaged) as conn:
        conn.execute("UPDATE views SET n = -4 WHERE id = 1")
    conn.close()
    with pytest.raises(DatabaseError, match=r"database is damaged: view 1 of 'astronaut': n"):
        ObjectDatabase.open(damaged, readonly=True)


def test_create_is_atomic_and_refuses_what_exists(small_db: Path, tmp_path: Path) -> None:
    path = tmp_path / "new.db"
    with ObjectDatabase.create(path) as db:
        assert db.labels() == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.db"]  # no temporary left
    with pytest.raises(DatabaseError, match="already exists"):
        ObjectDatabase.create(path)
    with pytest.raises(DatabaseError, match="folder"):
        ObjectDatabase.create(tmp_path / "missing" / "x.db")
    with ObjectDatabase.open(tmp_path / "made.db", create=True) as db:
        assert db.labels() == []


@pytest.mark.parametrize(
    ("label", "says"),
    [("", "empty"), ("\x1b[31mred", "control"), ("\udcff", "control"), (5, "text")],
)
def test_add_object_uses_the_cli_label_rules(
    small_db: Path, tmp_path: Path, label: object, says: str
) -> None:
    path = _copy(small_db, tmp_path / "objects.db")
    with ObjectDatabase.open(path) as db, pytest.raises(DatabaseError, match=says):
        db.add_object(label, [data.chelsea()])  # type: ignore[arg-type]
    with ObjectDatabase.open(path, readonly=True) as db:
        assert db.labels() == ["astronaut", "coffee"]


@pytest.mark.parametrize(
    ("mask", "tolerance", "says"),
    [
        (np.ones((10, 10), complex), 1.0, "booleans or numbers"),
        (np.ones((2, 10, 10), bool), 1.0, "2-D"),
        (np.ones((10, 10), bool), np.nan, "finite"),
        (np.ones((10, 10), bool), -1.0, "finite"),
    ],
)
def test_outline_from_mask_refuses(mask: object, tolerance: float, says: str) -> None:
    with pytest.raises(ImageError, match=says):
        outline_from_mask(mask, tolerance=tolerance)  # type: ignore[arg-type]


def test_detect_refuses_a_complex_mask() -> None:
    with pytest.raises(ImageError, match="complex"):
        detect(np.zeros((20, 20), np.uint8), mask=np.ones((20, 20), complex))  # type: ignore[arg-type]


@pytest.mark.parametrize("value", [123, None, b"left.png", "", "a\x00.png"])
def test_readers_check_the_type_of_the_name_first(value: object) -> None:
    with pytest.raises(ImageError):
        load_image(value)  # type: ignore[arg-type]
    with pytest.raises(CalibrationError):
        load_rig(value)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("args", "kwargs", "says"),
    [
        ((120.0, 60.0, (320, 240)), {}, "units='mm'"),
        ((0.12, 60.0, ("320", "240")), {}, "whole numbers"),
        ((0.12, 60.0, (True, True)), {}, "whole numbers"),
        ((0.12, 60.0, (320, 240), [0, -1j, 0]), {}, "complex"),
        ((0.12j, 60.0, (320, 240)), {}, "number"),
        ((0.12, 60.0, (320, 240)), {"units": "furlong"}, "unknown unit"),
    ],
)
def test_rig_from_short_refuses_with_the_fix(args: tuple, kwargs: dict, says: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(CalibrationError, match=says):
        rig_from_short(*args, **kwargs)


def test_rig_from_short_in_millimetres() -> None:
    assert rig_from_short(120.0, 60.0, (320, 240), units="mm").baseline == pytest.approx(0.12)


@pytest.mark.parametrize("suffix", [".json", ".yml", ".xml"])
def test_load_rig_reads_as_untrusted_input(tmp_path: Path, suffix: str) -> None:
    fifo = tmp_path / f"calib{suffix}"
    os.mkfifo(fifo)
    with pytest.raises(CalibrationError, match="FIFO"):
        load_rig(fifo)  # at once: a FIFO never blocks
    doctype = tmp_path / "entities.xml"
    doctype.write_text('<?xml version="1.0"?><!DOCTYPE a [<!ENTITY x "y">]><opencv_storage/>')
    with pytest.raises(CalibrationError, match="DOCTYPE"):
        load_rig(doctype)
