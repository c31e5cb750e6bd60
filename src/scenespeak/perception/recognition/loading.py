"""Loading an object database into memory: its views' keypoints and the descriptor index.

:meth:`ObjectDatabase.load <scenespeak.perception.recognition.store.ObjectDatabase.load>` calls
:func:`read_views` (keypoints, objects, views and outlines) and :func:`index_of` (the index of the
database's kind over every descriptor, streamed one view at a time by
:func:`descriptor_chunks`; an inverted file's cached quantiser reused).
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import DatabaseError
from scenespeak.perception.recognition.colour import BINS, ColourModel
from scenespeak.perception.recognition.grey import GREY_BINS
from scenespeak.perception.recognition.index import (
    _DIM,
    DescriptorIndex,
    _auto_kind,
    _have_faiss,
    build_index,
)
from scenespeak.perception.recognition.ivf import FaissIndex, IVFIndex
from scenespeak.perception.recognition.schema import cached_quantiser, save_quantiser

if TYPE_CHECKING:
    from scenespeak.perception.recognition.store import ObjectDatabase

__all__ = [
    "descriptor_chunks",
    "index_of",
    "raised_sources",
    "read_colour_models",
    "read_views",
    "synthetic_of",
]


_SELECT_VIEWS = " FROM views v JOIN objects o ON o.id = v.object_id ORDER BY v.id"


def read_views(
    db: ObjectDatabase, total: int
) -> tuple[
    NDArray[np.float32],
    NDArray[np.int32],
    NDArray[np.int32],
    list[int],
    dict[int, str],
    dict[int, NDArray[np.float32]],
]:
    """Every view's keypoints (x, y, size, angle), object and view of each descriptor,
    the views' sizes, the objects' labels and the views' outlines."""
    kp = np.empty((total, 4), np.float32)
    object_of = np.empty(total, np.int32)
    view_of = np.empty(total, np.int32)
    sizes: list[int] = []
    labels: dict[int, str] = {}
    outlines: dict[int, NDArray[np.float32]] = {}
    s = 0
    try:
        cursor = db.conn.execute(
            "SELECT v.id, v.object_id, o.label, v.n, v.keypoints, v.outline" + _SELECT_VIEWS
        )
        for vid, oid, lab, n, k_blob, o_blob in cursor:
            n = int(n)
            try:
                kp[s : s + n] = np.frombuffer(k_blob, np.float32).reshape(n, 4)
                outline = np.frombuffer(o_blob, np.float32).reshape(-1, 2).copy()
            except ValueError:
                raise DatabaseError(
                    db.path, f"view {vid} of {lab!r} is corrupt (wrong BLOB sizes)"
                ) from None
            outlines[int(vid)] = outline
            object_of[s : s + n] = oid
            view_of[s : s + n] = vid
            labels[int(oid)] = str(lab)
            sizes.append(n)
            s += n
    except sqlite3.DatabaseError as exc:
        raise DatabaseError(db.path, f"cannot be read (corrupt?): {exc}") from None
    if s != total:
        raise DatabaseError(db.path, "is corrupt (views without an object)")
    return kp, object_of, view_of, sizes, labels, outlines


def raised_sources(db: ObjectDatabase) -> dict[int, int]:
    """Each synthesised view's row id → the learnt view's it comes from (the ``raised_views``
    table, :func:`~scenespeak.perception.recognition.views.record_raised`; {} without it)."""
    from scenespeak.perception.recognition.views import has_raised_table

    if not has_raised_table(db.conn):
        return {}
    rows = db._query(
        "SELECT r.view_id, r.source_view FROM raised_views r JOIN views v ON v.id = r.view_id"
    )
    return {int(a): int(b) for a, b in rows}


def synthetic_of(
    db: ObjectDatabase, view_of: NDArray[np.int32]
) -> tuple[NDArray[np.bool_] | None, NDArray[np.int32]]:
    """Per descriptor (its view ``view_of``): whether its view was synthesised at ``db add``
    (:func:`~scenespeak.perception.recognition.views.raised_views`, as the ``raised_views``
    table records; None when no view was), and the view it is checked with: a synthesised
    view's descriptors lie at their places in the learnt view they come from and count as that
    view's."""
    to = raised_sources(db)
    if not to:
        return None, view_of
    synthetic = np.isin(view_of, list(to))
    pooled = view_of.copy()
    for vid, src_vid in to.items():
        pooled[view_of == vid] = src_vid
    return synthetic, pooled


def descriptor_chunks(
    db: ObjectDatabase, sizes: list[int], skip: frozenset[int] = frozenset()
) -> Iterator[NDArray[np.uint8]]:
    """The descriptors, one view at a time (in the order of :func:`read_views`), those of the
    views ``skip`` left out."""
    try:
        rows = db.conn.execute("SELECT v.id, v.descriptors" + _SELECT_VIEWS)
        for (vid, blob), n in zip(rows, sizes, strict=True):
            if len(blob) != n * _DIM:
                raise DatabaseError(db.path, f"view {vid} is corrupt (wrong descriptor BLOB size)")
            if int(vid) not in skip:
                yield np.frombuffer(blob, np.uint8).reshape(n, _DIM)
    except (sqlite3.DatabaseError, ValueError) as exc:
        raise DatabaseError(db.path, f"cannot be read (corrupt?): {exc}") from None


def index_of(
    db: ObjectDatabase, gen: int, total: int, sizes: list[int], nprobe: int, seed: int
) -> DescriptorIndex:
    """The index of the database's ``index_kind`` over every descriptor (a cached quantiser
    reused). Its kind (``auto``) and an inverted file's cells are chosen from the *learnt*
    descriptors alone: views synthesised for one object (:func:`synthetic_of`) do not move the
    cells the other objects' descriptors fall into, nor turn an exact index into an
    approximate one."""
    ids = [int(r[0]) for r in db._query("SELECT v.id" + _SELECT_VIEWS)]
    raised = set(raised_sources(db))
    skip = frozenset(raised)
    n_learnt = total - sum(n for vid, n in zip(ids, sizes, strict=True) if vid in skip)
    kind = db.index_kind
    if kind == "auto":
        kind = _auto_kind(n_learnt)
    if kind == "faiss" and not _have_faiss():
        raise DatabaseError(
            db.path, "index 'faiss' needs the faiss-cpu package (pip install faiss-cpu)"
        )
    if kind in ("ivf", "faiss"):
        centroids, cells = cached_quantiser(db.conn, gen, total)
        cls = IVFIndex if kind == "ivf" else FaissIndex
        index = cls.from_chunks(
            lambda: descriptor_chunks(db, sizes),
            total,
            nprobe=nprobe,
            seed=seed,
            centroids=centroids,
            cells=cells,
            train=(lambda: descriptor_chunks(db, sizes, skip), n_learnt) if skip else None,
        )
        if (centroids is None or index.cache_rejected) and not db.readonly:
            save_quantiser(db.conn, gen, index)
        return index
    desc = np.empty((total, _DIM), np.uint8)
    s = 0
    for block in descriptor_chunks(db, sizes):
        desc[s : s + block.shape[0]] = block
        s += block.shape[0]
    return build_index(desc, kind, nprobe=nprobe, seed=seed)


def read_colour_models(db: ObjectDatabase) -> dict[str, ColourModel]:
    """Each object's colour (and, from schema version 3, grey) signatures by label (see
    :meth:`ObjectDatabase.colour_models`); a file without them (version 1, or 2 for the grey
    part, opened read-only) gives none. A damaged signature only costs its view's cue."""
    query = db._query
    if not query("SELECT name FROM sqlite_master WHERE name = 'view_colours'"):
        return {}
    columns = {str(r[1]) for r in query("PRAGMA table_info(view_colours)")}
    grey = "c.grey, c.grey_aspect" if "grey" in columns else "NULL, NULL"
    rows = query(
        f"SELECT o.label, c.signature, c.aspect, {grey} FROM view_colours c "
        "JOIN views v ON v.id = c.view_id JOIN objects o ON o.id = v.object_id ORDER BY v.id"
    )
    by_label: dict[str, list[tuple[NDArray[np.float32], float, Any, Any]]] = {}
    for label, blob, aspect, grey_blob, grey_aspect in rows:
        sig = np.frombuffer(blob, np.float32)
        if sig.shape != (BINS,) or not np.all(np.isfinite(sig)):
            continue
        by_label.setdefault(str(label), []).append((sig, float(aspect), grey_blob, grey_aspect))
    return {label: _model(views) for label, views in by_label.items()}


def _model(views: list[tuple[NDArray[np.float32], float, Any, Any]]) -> ColourModel:
    """One object's model; grey signatures only if every view has an intact one."""
    sigs = np.array([v[0] for v in views], np.float32)
    aspects = np.array([v[1] for v in views], np.float32)
    greys = [np.frombuffer(v[2], np.float32) if v[2] is not None else None for v in views]
    if all(g is not None and g.shape == (GREY_BINS,) and np.all(np.isfinite(g)) for g in greys):
        grey_aspects = np.array([float(v[3] or 0.0) for v in views], np.float32)
        return ColourModel(sigs, aspects, np.array(greys, np.float32), grey_aspects)
    return ColourModel(sigs, aspects)
