"""Stage 4: the object database — labelled SIFT descriptors in a SQLite file, and labelling.

The paper matches the scene's keypoints "to a database of known objects ... If a keypoint is
not matched, it is held as part of an unknown object". Here that database is one SQLite file:

* ``meta``: ``application`` = ``scenespeak-object-database``, ``schema_version`` = ``1`` and a
  ``generation`` counter bumped by every write. A file without them is "not a scenespeak object
  database".
* ``objects``: one row per label (``id``, ``label`` unique, ``added`` as ISO-8601 UTC).
* ``views``: one row per training image: its source name, width and height, the number of
  keypoints, the descriptors as one ``uint8`` ``(N, 128)`` BLOB, the keypoints as one
  ``float32`` ``(N, 4)`` BLOB (x, y, size, angle) and the object's outline in that image as a
  ``float32`` ``(M, 2)`` BLOB (the largest contour of the mask, or the image border).

Every write is one transaction (features are extracted *before* it opens), so an exception or
Ctrl-C in the middle of :meth:`ObjectDatabase.add_object` leaves the file as it was.

On the first :meth:`ObjectDatabase.label` the descriptors are loaded into a nearest-neighbour
index (:func:`build_index`): exact brute force for small databases, an inverted-file index
in NumPy/BLAS (k-means coarse quantiser over ``uint8`` lists, cached in the file) for large
ones (searched by FAISS instead when ``faiss-cpu`` is installed: same cells, same answers).
Descriptors stay ``uint8`` in memory: 500,000 of them take 64 MB.

Labelling (:meth:`ObjectDatabase.label`) is Lowe's recipe: a ratio test whose second
neighbour is the nearest descriptor *of a different object* (several views of one object hold
near-copies of the same descriptor; comparing against those would reject exactly the good
matches), then per training view a RANSAC homography (a similarity where there are few matches)
between the training keypoints and the scene's, with each inlier's SIFT scale and orientation
checked against the model; an object is accepted only with ``min_inliers`` inliers, so a few
stray matches never make an object (a small, far one, whose outline covers at most
``small_area`` pixels, with ``min_inliers_small`` inliers at distinct positions). A query's
matches into every view of its object are checked, not only its single nearest neighbour's, so
matches split between near-identical views are pooled. Query keypoints keep the label ``-1``
unless they are inliers of an accepted detection.

>>> import numpy as np
>>> from skimage import data
>>> from scenespeak.perception.database import ObjectDatabase
>>> from scenespeak.perception.features import detect
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "objects.db"
>>> with ObjectDatabase.open(path, create=True) as db:
...     info = db.add_object("astronaut", [data.astronaut()[40:300, 120:380]])
...     result = db.label(detect(data.astronaut()))
>>> info.label, [d.label for d in result.detections]
('astronaut', ['astronaut'])
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import math
import sqlite3
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import UTC, datetime
from os import PathLike
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, Protocol, Self

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import DatabaseError, ImageError
from scenespeak.perception.features import Features, detect, load_image, to_gray

__all__ = [
    "APPLICATION",
    "SCHEMA_VERSION",
    "DescriptorIndex",
    "Detection",
    "ExactIndex",
    "IVFIndex",
    "Labelling",
    "ObjectDatabase",
    "ObjectInfo",
    "TrainingView",
    "build_index",
    "outline_from_mask",
]

APPLICATION = "scenespeak-object-database"
SCHEMA_VERSION = 1
#: SQLite ``PRAGMA application_id`` of our files ("SCSK").
APPLICATION_ID = 0x5343534B
_SQLITE_MAGIC = b"SQLite format 3\x00"
_DIM = 128

ImageLike = str | PathLike[str] | NDArray[np.generic]
MaskLike = str | PathLike[str] | NDArray[np.generic] | None
Progress = Callable[[str, int, int], None]

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
CREATE TABLE index_cache (
    kind TEXT PRIMARY KEY,
    generation INTEGER NOT NULL,
    ntotal INTEGER NOT NULL,
    centroids BLOB NOT NULL,
    cells BLOB NOT NULL
);
"""


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ObjectInfo:
    """One object of the database, as listed by :meth:`ObjectDatabase.list_objects`.

    Attributes
    ----------
    id : int
        Row id in the ``objects`` table.
    label : str
        The object's name.
    views : int
        Number of training images.
    descriptors : int
        Number of stored SIFT descriptors over all views.
    added : str
        When it was added (ISO-8601, UTC).
    """

    id: int
    label: str
    views: int
    descriptors: int
    added: str


@dataclass(frozen=True)
class TrainingView:
    """One training image of an object (without its descriptors).

    Attributes
    ----------
    id : int
        Row id in the ``views`` table (``Detection.view_id`` refers to it).
    label : str
        The object's label.
    source : str
        The image's file name as given, or ``"<array i>"``.
    width, height : int
        Size of the training image in pixels.
    outline : (M, 2) float32
        The object's outline in the training image, pixels (column, row); the image border
        (pixel edges at -0.5 and size - 0.5) when no mask was given.
    has_mask : bool
        Whether the outline came from a mask.
    keypoints : int
        Number of stored keypoints.
    """

    id: int
    label: str
    source: str
    width: int
    height: int
    outline: NDArray[np.float32]
    has_mask: bool
    keypoints: int


@dataclass(frozen=True)
class Detection:
    """An object recognised in the scene image.

    Attributes
    ----------
    label : str
        The object's label.
    view_id : int
        The training view that matched best (see :meth:`ObjectDatabase.views`).
    homography : (3, 3) float64
        Maps training-view pixels to scene pixels (homogeneous, ``H @ [x, y, 1]``). For a
        similarity model its last row is ``[0, 0, 1]``.
    inliers : (K,) intp
        Indices of the query keypoints that agree with the model (sorted).
    outline_in_scene : (M, 2) float64
        The training outline carried into the scene image by ``homography``.
    score : float
        Number of inliers (the evidence for the object; larger is better).
    model : {"homography", "similarity"}
        Which geometric model was fitted.
    matches : int
        Ratio-test matches to this view before the geometric check.
    """

    label: str
    view_id: int
    homography: NDArray[np.float64]
    inliers: NDArray[np.intp]
    outline_in_scene: NDArray[np.float64]
    score: float
    model: str
    matches: int


@dataclass(frozen=True)
class Labelling:
    """Labels of the query keypoints of one image.

    Attributes
    ----------
    labels : (N,) int32
        For each query keypoint the index of its detection in ``detections``, or ``-1``
        (unknown: not matched, or not an inlier of an accepted object).
    detections : tuple of Detection
        Recognised objects, best score first; at most one per label.
    matched : (N,) int32
        Before the geometric check: the database object id each keypoint passed the ratio test
        to, or ``-1``. For figures and diagnostics.
    """

    labels: NDArray[np.int32]
    detections: tuple[Detection, ...]
    matched: NDArray[np.int32] = field(repr=False)

    def names(self) -> list[str | None]:
        """The label of each query keypoint, ``None`` where unknown."""
        return [None if i < 0 else self.detections[i].label for i in self.labels.tolist()]

    def detection(self, label: str) -> Detection | None:
        """The detection of ``label``, if the object was recognised."""
        for det in self.detections:
            if det.label == label:
                return det
        return None


# --------------------------------------------------------------------------------------------
# Nearest-neighbour indexes over uint8 descriptors
# --------------------------------------------------------------------------------------------


class DescriptorIndex(Protocol):
    """A k-nearest-neighbour index over ``uint8`` SIFT descriptors (squared L2)."""

    @property
    def ntotal(self) -> int:
        """Number of indexed descriptors."""
        ...

    @property
    def nbytes(self) -> int:
        """Memory held by the index (descriptors included), in bytes."""
        ...

    def search(
        self, query: NDArray[np.uint8], k: int
    ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """Return the ``k`` nearest squared distances and ids per query row, nearest first.

        Missing neighbours (``k`` larger than reachable) have distance ``inf`` and id ``-1``.
        """
        ...


def _topk_rows(d: NDArray[np.float32], k: int) -> NDArray[np.intp]:
    """Column indices of the ``k`` smallest values of each row, sorted ascending."""
    n = d.shape[1]
    if k < n:
        part = np.argpartition(d, k - 1, axis=1)[:, :k]
    else:
        part = np.broadcast_to(np.arange(n), d.shape).copy()
    order = np.argsort(np.take_along_axis(d, part, axis=1), axis=1, kind="stable")
    return np.take_along_axis(part, order, axis=1)


def _runs(values: list[int]) -> tuple[list[int], list[int]]:
    """Starts and ends of the runs of equal consecutive values."""
    starts = [i for i in range(len(values)) if i == 0 or values[i] != values[i - 1]]
    return starts, [*starts[1:], len(values)] if values else []


def _sqnorms(data: NDArray[np.uint8], chunk: int = 8192) -> NDArray[np.float32]:
    out = np.empty(data.shape[0], np.float32)
    for s in range(0, data.shape[0], chunk):
        b = data[s : s + chunk].astype(np.float32)
        out[s : s + chunk] = np.einsum("ij,ij->i", b, b)
    return out


class ExactIndex:
    """Exact k-NN by brute force: float32 GEMM in blocks, descriptors kept as ``uint8``.

    Parameters
    ----------
    descriptors : (N, 128) uint8
    block : int
        Database rows converted to float32 at a time (bounds the temporary memory).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> data = rng.integers(0, 255, (100, 128), dtype=np.uint8)
    >>> d, i = ExactIndex(data).search(data[:3], 2)
    >>> i[:, 0].tolist(), d[:, 0].tolist()
    ([0, 1, 2], [0.0, 0.0, 0.0])
    """

    def __init__(self, descriptors: NDArray[np.uint8], *, block: int = 16384) -> None:
        self._data = np.ascontiguousarray(descriptors, dtype=np.uint8)
        self._norms = _sqnorms(self._data)
        self._block = block

    @property
    def ntotal(self) -> int:
        return int(self._data.shape[0])

    @property
    def nbytes(self) -> int:
        return int(self._data.nbytes + self._norms.nbytes)

    def search(
        self, query: NDArray[np.uint8], k: int
    ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        q = np.asarray(query, np.float32)
        nq = q.shape[0]
        best_d = np.full((nq, k), np.inf, np.float32)
        best_i = np.full((nq, k), -1, np.int64)
        if nq == 0 or self.ntotal == 0:
            return best_d, best_i
        qn = np.einsum("ij,ij->i", q, q)
        qchunk = 1024
        for s in range(0, self.ntotal, self._block):
            b = self._data[s : s + self._block].astype(np.float32)
            bn = self._norms[s : s + self._block]
            for qs in range(0, nq, qchunk):
                qq = q[qs : qs + qchunk]
                d = qq @ b.T
                d *= -2.0
                d += bn[None, :]
                d += qn[qs : qs + qchunk, None]
                kk = min(k, d.shape[1])
                cols = _topk_rows(d, kk)
                cd = np.take_along_axis(d, cols, axis=1)
                ci = cols.astype(np.int64) + s
                md = np.concatenate([best_d[qs : qs + qchunk], cd], axis=1)
                mi = np.concatenate([best_i[qs : qs + qchunk], ci], axis=1)
                sel = _topk_rows(md, k)
                best_d[qs : qs + qchunk] = np.take_along_axis(md, sel, axis=1)
                best_i[qs : qs + qchunk] = np.take_along_axis(mi, sel, axis=1)
        np.maximum(best_d, 0.0, out=best_d)
        return best_d, best_i


def _kmeans(
    data: NDArray[np.uint8], k: int, *, iters: int, rng: np.random.Generator
) -> NDArray[np.float32]:
    """Lloyd's k-means on a sample (float32 GEMM); empty clusters are re-seeded."""
    x = data.astype(np.float32)
    c = x[rng.choice(x.shape[0], size=k, replace=False)].copy()
    for _ in range(iters):
        assign = _nearest_centroid(x, c)
        counts = np.bincount(assign, minlength=k).astype(np.float32)
        sums = np.zeros_like(c)
        np.add.at(sums, assign, x)
        empty = counts == 0
        c[~empty] = sums[~empty] / counts[~empty, None]
        if empty.any():
            c[empty] = x[rng.choice(x.shape[0], size=int(empty.sum()), replace=False)]
    return c


def _nearest_centroid(
    x: NDArray[np.float32],
    c: NDArray[np.float32],
    chunk: int = 2048,
) -> NDArray[np.intp]:
    cn = np.einsum("ij,ij->i", c, c)
    out = np.empty(x.shape[0], np.intp)
    for s in range(0, x.shape[0], chunk):
        d = x[s : s + chunk] @ c.T
        d *= -2.0
        d += cn[None, :]
        out[s : s + chunk] = np.argmin(d, axis=1)
    return out


def _batches(
    chunks: Callable[[], Iterator[NDArray[np.uint8]]], rows: int = 16384
) -> Iterator[NDArray[np.uint8]]:
    """The chunks regrouped into blocks of about ``rows`` rows (for efficient GEMMs)."""
    pending: list[NDArray[np.uint8]] = []
    count = 0
    for block in itertools.chain(chunks(), [None]):
        if block is not None:
            pending.append(block)
            count += block.shape[0]
        if count and (count >= rows or block is None):
            yield np.concatenate(pending)
            pending, count = [], 0


def _quantise(
    chunks: Callable[[], Iterator[NDArray[np.uint8]]],
    n: int,
    *,
    nlist: int | None,
    train_size: int,
    iters: int,
    seed: int,
    centroids: NDArray[np.float32] | None,
    cells: NDArray[np.integer] | None,
) -> tuple[NDArray[np.float32], NDArray[np.intp]]:
    """Coarse quantiser (trained on a sample unless given) and each descriptor's cell."""
    if centroids is None:
        cells = None
        if nlist is None:
            nlist = _default_nlist(n)
        nlist = max(1, min(nlist, n))
        rng = np.random.default_rng(seed)
        pick = np.sort(rng.choice(n, size=min(n, train_size), replace=False))
        sample = np.empty((pick.size, _DIM), np.uint8)
        start = 0
        for block in chunks():
            a, b = np.searchsorted(pick, [start, start + block.shape[0]])
            sample[a:b] = block[pick[a:b] - start]
            start += block.shape[0]
        centroids = _kmeans(sample, nlist, iters=iters, rng=rng)
        del sample
    centroids = np.ascontiguousarray(centroids, np.float32)
    if cells is not None and len(cells) == n:
        return centroids, np.asarray(cells, np.intp)
    assign = np.empty(n, np.intp)
    start = 0
    for block in _batches(chunks):
        assign[start : start + block.shape[0]] = _nearest_centroid(
            block.astype(np.float32), centroids
        )
        start += block.shape[0]
    return centroids, assign


class _IndexBuilder:
    """Construction shared by the inverted-file indexes: from one array or from chunks.

    Subclasses implement ``_build(chunks, n, **options)``; the options are the keyword
    parameters documented on each subclass.
    """

    def __init__(self, descriptors: NDArray[np.uint8], **options: Any) -> None:
        data = np.ascontiguousarray(descriptors, dtype=np.uint8)
        self._build(lambda: iter([data]), data.shape[0], **options)

    centroids: NDArray[np.float32]
    nprobe: int

    def _build(
        self,
        chunks: Callable[[], Iterator[NDArray[np.uint8]]],
        n: int,
        *,
        nlist: int | None = None,
        nprobe: int = 4,
        train_size: int = 65536,
        iters: int = 10,
        seed: int = 0,
        centroids: NDArray[np.float32] | None = None,
        cells: NDArray[np.integer] | None = None,
        **extra: Any,
    ) -> None:
        self.centroids, assign = _quantise(
            chunks,
            n,
            nlist=nlist,
            train_size=train_size,
            iters=iters,
            seed=seed,
            centroids=centroids,
            cells=cells,
        )
        self.nprobe = nprobe
        self._fill(chunks, n, assign, **extra)

    def _fill(
        self,
        chunks: Callable[[], Iterator[NDArray[np.uint8]]],
        n: int,
        assign: NDArray[np.intp],
        **extra: Any,
    ) -> None:
        """Store the descriptors under their coarse cells ``assign`` (subclass-specific)."""
        raise NotImplementedError

    @property
    def nlist(self) -> int:
        return int(self.centroids.shape[0])

    @classmethod
    def from_chunks(
        cls,
        chunks: Callable[[], Iterator[NDArray[np.uint8]]],
        total: int,
        **options: Any,
    ) -> Self:
        """Build from descriptors read in consecutive chunks, without holding two copies.

        ``chunks()`` must yield the same ``(n_i, 128)`` blocks, in the same order, each time it
        is called; it is called up to three times (training sample, cell assignment, filling
        the lists), so that the peak memory is one ``uint8`` copy plus a training sample.
        ``options`` are those of the constructor.
        """
        index = cls.__new__(cls)
        index._build(chunks, total, **options)
        return index


class IVFIndex(_IndexBuilder):
    """Inverted-file index in NumPy: k-means coarse quantiser, ``uint8`` lists, float32 GEMM.

    The descriptors are stored once, grouped by coarse cell (``uint8``, 128 B each). A query
    visits its ``nprobe`` nearest cells; each visited cell's block is converted to float32 and
    multiplied with all queries that visit it in one GEMM.

    Parameters
    ----------
    descriptors : (N, 128) uint8
    nlist : int, optional
        Number of coarse cells (default about ``2 * sqrt(N)``, a power of two).
    nprobe : int
        Cells visited per query.
    train_size : int
        Descriptors sampled to train the quantiser.
    seed : int
        Seed of the sample and of the k-means initialisation.
    centroids : (nlist, 128) float32, optional
        A quantiser trained before (skips the training).
    cells : (N,) int, optional
        The cell of each descriptor under ``centroids`` (skips the assignment).
    threads : int, optional
        Threads scanning the cells in a search (default 1; 2 can help on an idle 2-core
        machine, and did not on the shared one it was measured on).
    """

    def _fill(
        self,
        chunks: Callable[[], Iterator[NDArray[np.uint8]]],
        n: int,
        assign: NDArray[np.intp],
        threads: int | None = None,
    ) -> None:
        self.threads = 1 if threads is None else threads
        order = np.argsort(assign, kind="stable")
        counts = np.bincount(assign, minlength=self.centroids.shape[0])
        self._offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self._ids = order.astype(np.int32)
        position = np.empty(n, np.intp)
        position[order] = np.arange(n)
        data = np.empty((n, _DIM), np.uint8)
        start = 0
        for block in chunks():
            data[position[start : start + block.shape[0]]] = block
            start += block.shape[0]
        self._data = data
        self._norms = _sqnorms(self._data)

    def cells(self) -> NDArray[np.uint16 | np.int32]:
        """The coarse cell of every descriptor, in the order they were given (for caching)."""
        counts = np.diff(self._offsets)
        cell_sorted = np.repeat(np.arange(self.nlist), counts)
        out = np.empty(self.ntotal, np.uint16 if self.nlist <= 65535 else np.int32)
        out[self._ids] = cell_sorted
        return out

    @property
    def ntotal(self) -> int:
        return int(self._data.shape[0])

    @property
    def nbytes(self) -> int:
        return int(
            self._data.nbytes
            + self._ids.nbytes
            + self._norms.nbytes
            + self._offsets.nbytes
            + self.centroids.nbytes
        )

    #: Largest table of candidate distances, in float32 entries (``(query, probe)`` pairs ×
    #: largest visited cell), filled cell by cell and read once at the end; above it each
    #: cell's nearest are read out as the cell is visited.
    table_limit = 1 << 21

    def search(
        self, query: NDArray[np.uint8], k: int
    ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        # The GEMMs here are small (a few queries × one cell): BLAS threads only add
        # synchronisation, and on a busy machine spinning BLAS threads cost seconds (measured:
        # 2.9 s instead of 0.13 s with two OpenBLAS threads and another process on one of the
        # two cores). So BLAS runs single-threaded during the search (threadpoolctl, which
        # scikit-learn brings, restores the setting afterwards).
        with _single_threaded_blas():
            return self._search(query, k)

    def _search(
        self, query: NDArray[np.uint8], k: int
    ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        q = np.ascontiguousarray(query, np.float32)
        nq = q.shape[0]
        nprobe = min(self.nprobe, self.nlist)
        if nq == 0:
            return np.full((0, k), np.inf, np.float32), np.full((0, k), -1, np.int64)
        qn = np.einsum("ij,ij->i", q, q)
        qm2 = q * np.float32(-2.0)
        cd = qm2 @ self.centroids.T
        cd += np.einsum("ij,ij->i", self.centroids, self.centroids)[None, :]
        if nprobe >= self.nlist:
            probes = np.tile(np.arange(self.nlist), (nq, 1))
        elif nprobe <= 8:
            # A few rounds of argmin (SIMD) beat argpartition over nlist columns (~6x here).
            probes = np.empty((nq, nprobe), np.intp)
            rows = np.arange(nq)
            for j in range(nprobe):
                probes[:, j] = np.argmin(cd, axis=1)
                cd[rows, probes[:, j]] = np.inf
        else:
            probes = np.argpartition(cd, nprobe - 1, axis=1)[:, :nprobe]
        out_d, out_i = self._scan_cells(qm2, probes, k)
        out_d += qn[:, None]
        np.maximum(out_d, 0.0, out=out_d)
        return out_d, out_i

    def _scan_cells(
        self, qm2: NDArray[np.float32], probes: NDArray[np.intp], k: int
    ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """Each probed cell's ``k`` nearest per query, merged into each query's ``k`` nearest.

        Returns ``-2 q·b + |b|²`` (without ``|q|²``, ``inf`` where missing) and the ids
        (``-1`` where missing), nearest first.
        """
        nq, nprobe = probes.shape
        # Candidates per (query, probe) pair, in the order the pairs are visited (grouped by
        # cell), so that each cell writes one contiguous block of rows. For the small table,
        # cells of the same size come next to each other (for _scan_table's partitions); the
        # pairs of one cell stay in query order either way.
        flat = probes.ravel()
        size_of = np.diff(self._offsets)[flat]
        width = int(size_of.max())
        table = flat.size * (width + 1) <= self.table_limit
        order = np.argsort(size_of * self.nlist + flat if table else flat, kind="stable")
        lists = flat[order]
        qidx = order // nprobe
        bounds = np.flatnonzero(np.diff(lists)) + 1
        starts = np.concatenate([[0], bounds])
        ends = np.concatenate([bounds, [lists.size]])
        cells = lists[starts]
        # (first pair, end pair, first member, end member) of each visited cell
        work = list(
            zip(
                starts.tolist(),
                ends.tolist(),
                self._offsets[cells].tolist(),
                self._offsets[cells + 1].tolist(),
                strict=True,
            )
        )
        if table:
            # The queries in visiting order, with a column of ones: against a cell's block
            # with its squared norms as a 129th column, one GEMM gives ``-2 q·b + |b|²``.
            qa = np.empty((flat.size, _DIM + 1), np.float32)
            qa[:, :_DIM] = qm2[qidx]
            qa[:, _DIM] = 1.0
            # Most cells visited (a large batch of queries): convert them all in one go.
            visited = int(np.diff(self._offsets)[cells].sum())
            whole = 2 * visited >= self.ntotal and self.ntotal * (_DIM + 1) <= self.table_limit
            pair_d, pair_i = self._scan_table(qa, lists, work, width, k, whole=whole)
        else:
            pair_d, pair_i = self._scan_each(qm2, qidx, work, k)
        back = np.empty_like(order)
        back[order] = np.arange(order.size)
        cand_d = pair_d[back].reshape(nq, nprobe * k)
        cand_i = pair_i[back].reshape(nq, nprobe * k)
        sel = _topk_rows(cand_d, k)
        return np.take_along_axis(cand_d, sel, axis=1), np.take_along_axis(cand_i, sel, axis=1)

    def _run(
        self,
        scan: Callable[[list[tuple[int, int, int, int]]], None],
        work: list[tuple[int, int, int, int]],
    ) -> None:
        """Run ``scan`` over the cells, split over :attr:`threads` threads if set."""
        # NumPy releases the GIL in the GEMM, the cast and the partition: cells are split
        # over threads (each writes its own rows of the outputs).
        threads = max(1, min(self.threads, len(work) // 16))
        if threads == 1:
            scan(work)
        else:
            with ThreadPoolExecutor(threads) as pool:
                list(pool.map(scan, [work[t::threads] for t in range(threads)]))

    def _scan_table(
        self,
        qa: NDArray[np.float32],
        lists: NDArray[np.intp],
        work: list[tuple[int, int, int, int]],
        width: int,
        k: int,
        *,
        whole: bool = False,
    ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """:meth:`_scan_each` with fewer steps per cell, for searches of small tables.

        Each cell's distances go straight from the GEMM into one table (the squared norms come
        out of the GEMM too, as a 129th column against a query column of ones); the partitions
        run once per run of cells of the same size (``work`` comes ordered by size), and the
        nearest are read out of the table for all cells at once. The numbers are the same as
        :meth:`_scan_each`'s: squared distances between ``uint8`` vectors, and every partial
        sum of them, are integers below 2**24, exact in float32 whatever the order of the
        sums. Each row is partitioned on its own, and is the same row as there, so the same
        columns come out in the same order (ties included). With ``whole``, all the descriptors are
        converted to float32 at once (a temporary copy) rather than cell by cell.
        """
        npairs = qa.shape[0]
        table = np.empty((npairs, width + 1), np.float32)
        table[:, width] = np.inf  # where missing neighbours point
        cols = np.full((npairs, k), width, np.intp)
        data, norms = self._data, self._norms
        converted = None
        if whole:
            converted = np.empty((self.ntotal, _DIM + 1), np.float32)
            converted[:, :_DIM] = data
            converted[:, _DIM] = norms

        def scan(items: list[tuple[int, int, int, int]]) -> None:
            buffer = np.empty((0 if whole else width, _DIM + 1), np.float32)  # one cell
            for a, b, lo, hi in items:
                n = hi - lo
                if n == 0:
                    continue
                if converted is not None:
                    block = converted[lo:hi]
                else:
                    block = buffer[:n]
                    block[:, :_DIM] = data[lo:hi]
                    block[:, _DIM] = norms[lo:hi]
                np.matmul(qa[a:b], block.T, out=table[a:b, :n])

        self._run(scan, work)
        # The partitions, one per run of cells of the same size (rows of equal length: each
        # row is partitioned on its own, as it would be alone).
        sizes = [hi - lo for _, _, lo, hi in work]
        for i, j in zip(*_runs(sizes), strict=True):
            a, b, n = work[i][0], work[j - 1][1], sizes[i]
            if k < n:
                cols[a:b] = np.argpartition(table[a:b, :n], k - 1, axis=1)[:, :k]
            else:
                cols[a:b, :n] = np.arange(n)
        pair_d = table.ravel()[cols + (np.arange(npairs) * (width + 1))[:, None]]
        ids = np.append(self._ids.astype(np.int64), -1)  # -1 at ntotal: missing
        where = np.where(cols == width, self.ntotal, self._offsets[lists][:, None] + cols)
        return pair_d, ids[where]

    def _scan_each(
        self,
        qm2: NDArray[np.float32],
        qidx: NDArray[np.intp],
        work: list[tuple[int, int, int, int]],
        k: int,
    ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """Each probed cell's ``k`` nearest for the queries visiting it, cell by cell.

        Used for large searches (where the GEMMs and partitions dominate, not the steps).
        """
        pair_d = np.full((qidx.size, k), np.inf, np.float32)
        pair_i = np.full((qidx.size, k), -1, np.int64)

        def scan(items: list[tuple[int, int, int, int]]) -> None:
            for a, b, lo, hi in items:
                if hi == lo:
                    continue
                d = qm2[qidx[a:b]] @ self._data[lo:hi].astype(np.float32).T
                d += self._norms[lo:hi][None, :]
                kk = min(k, hi - lo)
                if kk < hi - lo:
                    cols = np.argpartition(d, kk - 1, axis=1)[:, :kk]
                    pair_d[a:b, :kk] = d[np.arange(b - a)[:, None], cols]
                else:
                    cols = np.broadcast_to(np.arange(hi - lo), d.shape)
                    pair_d[a:b, :kk] = d
                pair_i[a:b, :kk] = self._ids[lo + cols]

        self._run(scan, work)
        return pair_d, pair_i


class FaissIndex(_IndexBuilder):
    """FAISS ``IndexIVFScalarQuantizer`` with ``QT_8bit_direct``: exact ``uint8`` storage.

    Only available when the optional ``faiss-cpu`` package is installed. Uses the same coarse
    quantiser as :class:`IVFIndex` (so the cache in the database file serves both); the
    descriptors are stored as 128-byte codes (no residuals), searched by FAISS in C++.
    """

    def _fill(
        self,
        chunks: Callable[[], Iterator[NDArray[np.uint8]]],
        n: int,
        assign: NDArray[np.intp],
    ) -> None:
        import faiss  # optional dependency

        nl = self.centroids.shape[0]
        quantizer = faiss.IndexFlatL2(_DIM)
        quantizer.add(self.centroids)
        index = faiss.IndexIVFScalarQuantizer(
            quantizer, _DIM, nl, faiss.ScalarQuantizer.QT_8bit_direct, faiss.METRIC_L2
        )
        # Encode the descriptors themselves, not residuals: QT_8bit_direct stores 0..255 as is.
        index.by_residual = False
        index.train(np.zeros((1, _DIM), np.float32))  # 8-bit direct: nothing to learn
        start = 0
        for block in _batches(chunks, 65536):
            x = np.ascontiguousarray(block, np.float32)
            pre = np.ascontiguousarray(assign[start : start + x.shape[0]], np.int64)
            index.add_core(x.shape[0], faiss.swig_ptr(x), None, faiss.swig_ptr(pre))
            start += x.shape[0]
        self._cells = assign.astype(np.uint16 if nl <= 65535 else np.int32)
        self._index = index
        self._quantizer = quantizer
        self._n = n

    def cells(self) -> NDArray[np.uint16 | np.int32]:
        """The coarse cell of every descriptor, in the order they were given (for caching)."""
        return self._cells

    @property
    def ntotal(self) -> int:
        return self._n

    @property
    def nbytes(self) -> int:
        # codes (128 B) + ids (8 B) per descriptor, the coarse centroids, the cell cache.
        return int(self._n * (_DIM + 8) + self.centroids.nbytes + self._cells.nbytes)

    def search(
        self, query: NDArray[np.uint8], k: int
    ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        q = np.ascontiguousarray(query, np.float32)
        self._index.nprobe = self.nprobe
        d, i = self._index.search(q, k)
        d = np.where(i < 0, np.inf, d).astype(np.float32)
        return d, i.astype(np.int64)


def _have_faiss() -> bool:
    try:
        import faiss  # noqa: F401
    except ImportError:
        return False
    return True


def _single_threaded_blas() -> contextlib.AbstractContextManager[object]:
    """Limit BLAS to one thread for the duration of a ``with`` block (if threadpoolctl is here).

    Finding the loaded BLAS libraries takes threadpoolctl ~2 ms per call (it walks the
    process's shared objects); the controller is kept and made again only when modules were
    imported since (a new extension module may bring its own BLAS).
    """
    controller = _blas_controller(len(sys.modules))
    if controller is None:  # pragma: no cover - scikit-learn depends on threadpoolctl
        return contextlib.nullcontext()
    return controller.limit(limits=1, user_api="blas")


@functools.lru_cache(maxsize=1)
def _blas_controller(_n_modules: int) -> Any:
    """A ``threadpoolctl.ThreadpoolController`` (cached per number of imported modules)."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - scikit-learn depends on it
        return None
    return ThreadpoolController()


def _auto_kind(n: int, exact_below: int = 4096) -> IndexKind:
    if n < exact_below:
        return "exact"
    return "faiss" if _have_faiss() else "ivf"


def _default_nlist(n: int) -> int:
    return int(2 ** round(math.log2(max(1.0, 2.0 * math.sqrt(n)))))


IndexKind = Literal["auto", "exact", "ivf", "faiss"]


def build_index(
    descriptors: NDArray[np.uint8],
    kind: IndexKind = "auto",
    *,
    exact_below: int = 4096,
    nlist: int | None = None,
    nprobe: int = 4,
    seed: int = 0,
    centroids: NDArray[np.float32] | None = None,
    cells: NDArray[np.integer] | None = None,
) -> DescriptorIndex:
    """Build a nearest-neighbour index over ``uint8`` descriptors.

    Parameters
    ----------
    descriptors : (N, 128) uint8
    kind : {"auto", "exact", "ivf", "faiss"}
        ``"auto"``: exact below ``exact_below`` descriptors, else FAISS when ``faiss-cpu`` is
        installed (2–3x faster search), else the NumPy inverted file.
    nlist, nprobe : int
        Inverted-file cells and cells visited per query.
    seed : int
        Seed of the quantiser's training.
    centroids, cells : ndarray, optional
        A trained quantiser and the cell of each descriptor (an index cache), for ``"ivf"``
        and ``"faiss"``.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> data = rng.integers(0, 255, (2000, 128), dtype=np.uint8)
    >>> index = build_index(data, "ivf", nlist=16, nprobe=16)
    >>> index.search(data[:2], 1)[1][:, 0].tolist()
    [0, 1]
    """
    data = np.ascontiguousarray(descriptors, dtype=np.uint8)
    if data.ndim != 2 or data.shape[1] != _DIM:
        raise ValueError(f"descriptors must be (N, {_DIM}) uint8, got {data.shape}")
    if kind == "auto":
        kind = _auto_kind(data.shape[0], exact_below)
    if kind == "exact":
        return ExactIndex(data)
    if kind == "ivf":
        return IVFIndex(
            data, nlist=nlist, nprobe=nprobe, seed=seed, centroids=centroids, cells=cells
        )
    if kind == "faiss":
        return FaissIndex(
            data, nlist=nlist, nprobe=nprobe, seed=seed, centroids=centroids, cells=cells
        )
    raise ValueError(f"unknown index kind {kind!r}; use auto, exact, ivf or faiss")


# --------------------------------------------------------------------------------------------
# Training views
# --------------------------------------------------------------------------------------------


def outline_from_mask(mask: NDArray[np.generic], *, tolerance: float = 1.0) -> NDArray[np.float32]:
    """Outline of the largest region of a mask, as a simplified polygon.

    Parameters
    ----------
    mask : (H, W) array
        Non-zero where the object is.
    tolerance : float
        Douglas–Peucker tolerance in pixels.

    Returns
    -------
    (M, 2) float32
        Vertices (column, row), at least 3; empty ``(0, 2)`` if the mask is empty.

    Examples
    --------
    >>> m = np.zeros((50, 60), bool); m[10:20, 5:30] = True
    >>> outline_from_mask(m).tolist()
    [[5.0, 10.0], [5.0, 19.0], [29.0, 19.0], [29.0, 10.0]]
    """
    m = (np.asarray(mask) != 0).astype(np.uint8)
    contours, _ = cv2.findContours(m, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if not contours:
        return np.zeros((0, 2), np.float32)
    biggest = max(contours, key=lambda c: (cv2.contourArea(c), len(c)))
    poly = cv2.approxPolyDP(biggest, tolerance, True).reshape(-1, 2)
    if poly.shape[0] < 3:
        poly = biggest.reshape(-1, 2)
    if poly.shape[0] < 3:  # a one-pixel-thin region: use its bounding box
        x, y, w, h = cv2.boundingRect(biggest)
        poly = np.array([[x, y], [x + w - 1, y], [x + w - 1, y + h - 1], [x, y + h - 1]])
    return poly.astype(np.float32)


def _border_outline(width: int, height: int) -> NDArray[np.float32]:
    return np.array(
        [[-0.5, -0.5], [width - 0.5, -0.5], [width - 0.5, height - 0.5], [-0.5, height - 0.5]],
        np.float32,
    )


@dataclass(frozen=True)
class _ViewData:
    source: str
    width: int
    height: int
    has_mask: bool
    features: Features
    outline: NDArray[np.float32]


def _source_name(item: object, i: int, kind: str) -> str:
    if isinstance(item, str | PathLike):
        return str(item)
    return f"<{kind} array {i}>"


def _read_image(item: ImageLike, i: int) -> NDArray[np.uint8]:
    if isinstance(item, str | PathLike):
        return load_image(item, gray=True)
    try:
        return to_gray(np.asarray(item))
    except ImageError as exc:
        raise ImageError(_source_name(item, i, "image"), exc.problem) from None


def _read_mask(item: MaskLike, i: int, shape: tuple[int, ...]) -> NDArray[np.bool_] | None:
    if item is None:
        return None
    name = _source_name(item, i, "mask")
    if isinstance(item, str | PathLike):
        arr = load_image(item, gray=True)
    else:
        arr = np.asarray(item)
        if arr.ndim == 3:
            arr = arr.any(axis=2) if arr.dtype == bool else arr.max(axis=2)
    if arr.shape[:2] != shape:
        raise ImageError(
            name,
            f"mask size {arr.shape[:2]} differs from its image's {shape}; give one mask "
            "per image, the same size",
        )
    m = np.asarray(arr) != 0
    if not m.any():
        raise ImageError(name, "the mask is empty (no object pixels)")
    return m


def _extract_view(
    image: ImageLike, mask: MaskLike, i: int, max_features: int, contrast_threshold: float
) -> _ViewData:
    gray = _read_image(image, i)
    h, w = gray.shape
    m = _read_mask(mask, i, (h, w))
    source = _source_name(image, i, "image")
    feats = detect(gray, mask=m, max_features=max_features, contrast_threshold=contrast_threshold)
    if len(feats) == 0:
        raise ImageError(
            source,
            "no SIFT keypoints found"
            + (" inside the mask" if m is not None else "")
            + "; use a sharper, more textured or larger image of the object",
        )
    outline = outline_from_mask(m) if m is not None else _border_outline(w, h)
    return _ViewData(source, w, h, m is not None, feats, outline)


# --------------------------------------------------------------------------------------------
# Geometric verification
# --------------------------------------------------------------------------------------------


def _local_jacobians(
    h: NDArray[np.float64], pts: NDArray[np.float64]
) -> tuple[tuple[NDArray[np.float64], ...], NDArray[np.float64]]:
    """Per-point 2×2 Jacobians of the homography (j00, j01, j10, j11, each (n,)) and w."""
    x, y = pts[:, 0], pts[:, 1]
    u = h[0, 0] * x + h[0, 1] * y + h[0, 2]
    v = h[1, 0] * x + h[1, 1] * y + h[1, 2]
    w = _w_of(h, pts)
    w2 = w**2
    j00 = (h[0, 0] * w - u * h[2, 0]) / w2
    j01 = (h[0, 1] * w - u * h[2, 1]) / w2
    j10 = (h[1, 0] * w - v * h[2, 0]) / w2
    j11 = (h[1, 1] * w - v * h[2, 1]) / w2
    return (j00, j01, j10, j11), w


def _w_of(h: NDArray[np.float64], pts: NDArray[np.float64]) -> NDArray[np.float64]:
    """The homogeneous coordinate ``w`` of each point mapped by ``h``."""
    return h[2, 0] * pts[:, 0] + h[2, 1] * pts[:, 1] + h[2, 2]


def _apply_h(h: NDArray[np.float64], pts: NDArray[np.float64]) -> NDArray[np.float64]:
    ph = np.hstack([pts, np.ones((len(pts), 1))]) @ h.T
    return ph[:, :2] / ph[:, 2:3]


@dataclass(frozen=True)
class _Fit:
    h: NDArray[np.float64]
    inliers: NDArray[np.bool_]
    model: str


def _consistent(
    h: NDArray[np.float64],
    t_xy: NDArray[np.float64],
    t_size: NDArray[np.float32],
    t_angle: NDArray[np.float32],
    q_xy: NDArray[np.float64],
    q_size: NDArray[np.float32],
    q_angle: NDArray[np.float32],
    threshold: float,
    max_scale_ratio: float,
    max_angle_deg: float,
) -> NDArray[np.bool_]:
    """Matches that agree with ``h`` in position, keypoint scale and orientation."""
    (j00, j01, j10, j11), w = _local_jacobians(h, t_xy)
    ok = w > 0
    proj = _apply_h(h, t_xy)
    ok &= np.linalg.norm(proj - q_xy, axis=1) <= threshold
    det = j00 * j11 - j01 * j10
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.sqrt(np.abs(det))
        ratio = (q_size / np.maximum(t_size, 1e-6)) / scale
        ok &= np.abs(np.log(ratio)) <= math.log(max_scale_ratio)
    rot = np.degrees(np.arctan2(j10 - j01, j00 + j11))
    dang = (q_angle.astype(np.float64) - t_angle - rot + 180.0) % 360.0 - 180.0
    ok &= np.abs(dang) <= max_angle_deg
    return ok & np.isfinite(ratio)


def _plausible(
    h: NDArray[np.float64], outline: NDArray[np.float32], t_xy: NDArray[np.float64]
) -> bool:
    """Reject homographies that fold, mirror, or shrink/stretch the view beyond belief."""
    if not np.all(np.isfinite(h)):
        return False
    if np.any(_w_of(h, outline.astype(np.float64)) <= 0) or np.any(_w_of(h, t_xy) <= 0):
        return False
    # The Jacobian at the centre, in Python floats: the same IEEE operations, in the same
    # order, as _local_jacobians on a one-point array (and the same numbers), without the
    # overhead of NumPy calls on one element.
    x, y = t_xy.mean(axis=0).tolist()
    (h00, h01, h02), (h10, h11, h12), (h20, h21, h22) = h.tolist()
    u = h00 * x + h01 * y + h02
    v = h10 * x + h11 * y + h12
    w = h20 * x + h21 * y + h22
    w2 = w * w
    a = np.array(
        [
            [(h00 * w - u * h20) / w2, (h01 * w - u * h21) / w2],
            [(h10 * w - v * h20) / w2, (h11 * w - v * h21) / w2],
        ]
    )
    if np.linalg.det(a) <= 0:
        return False
    sv = np.linalg.svd(a, compute_uv=False)
    if sv[1] <= 0 or sv[0] / sv[1] > 8.0:
        return False
    scale = math.sqrt(sv[0] * sv[1])
    return 1.0 / 64.0 <= scale <= 64.0


def _polygon_area(poly: NDArray[np.float64]) -> float:
    """Area of a simple polygon (shoelace), square pixels."""
    x, y = poly[:, 0], poly[:, 1]
    return float(abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2.0)


def _small_enough(
    outline_in_scene: NDArray[np.float64],
    inlier_xy: NDArray[np.float64],
    small_area: float,
    min_inliers_small: int,
) -> bool:
    """Whether a detection with fewer than ``min_inliers`` inliers may still be accepted.

    A far object covers few pixels and so carries few keypoints; a large projected outline
    with only a handful of inliers is more likely a chance agreement. Inliers are counted at
    distinct positions (SIFT gives one keypoint per dominant orientation at one place, and
    those copies are no independent evidence).
    """
    if small_area <= 0 or not np.all(np.isfinite(outline_in_scene)):
        return False
    distinct = np.unique(np.rint(inlier_xy), axis=0).shape[0]
    return distinct >= min_inliers_small and _polygon_area(outline_in_scene) <= small_area


def _fit_view(
    t_xy: NDArray[np.float64],
    t_size: NDArray[np.float32],
    t_angle: NDArray[np.float32],
    q_xy: NDArray[np.float64],
    q_size: NDArray[np.float32],
    q_angle: NDArray[np.float32],
    outline: NDArray[np.float32],
    *,
    threshold: float,
    homography_min: int,
    max_scale_ratio: float,
    max_angle_deg: float,
) -> _Fit | None:
    """Fit a homography (with enough matches) and a similarity; return the better, or None."""
    n = t_xy.shape[0]
    best: _Fit | None = None
    src = t_xy.astype(np.float32)
    dst = q_xy.astype(np.float32)

    def agree(h: NDArray[np.float64]) -> NDArray[np.bool_]:
        return _consistent(h, *train, *query, *tolerances)

    train = (t_xy, t_size, t_angle)
    query = (q_xy, q_size, q_angle)
    tolerances = (threshold, max_scale_ratio, max_angle_deg)
    if n >= homography_min:
        h, _ = cv2.findHomography(
            src, dst, cv2.RANSAC, ransacReprojThreshold=threshold, maxIters=2000, confidence=0.999
        )
        if h is not None and _plausible(h, outline, t_xy):
            inl = agree(h)
            if inl.sum() >= 4:
                # Refit on the consistent inliers (least squares), then re-check.
                h2, _ = cv2.findHomography(src[inl], dst[inl], 0)
                if h2 is not None and _plausible(h2, outline, t_xy[inl]):
                    # The refit often returns the very same matrix (then so is the verdict).
                    inl2 = inl if np.array_equal(h2, h) else agree(h2)
                    if inl2.sum() >= inl.sum():
                        h, inl = h2, inl2
                best = _Fit(h / h[2, 2], inl, "homography")
    # The similarity replaces the homography only if its inliers (a subset of the n matches)
    # exceed 1.2 times the homography's: when n itself does not, it cannot.
    if n >= 2 and (best is None or n > 1.2 * best.inliers.sum()):
        a, _ = cv2.estimateAffinePartial2D(
            src, dst, method=cv2.RANSAC, ransacReprojThreshold=threshold, maxIters=2000
        )
        if a is not None:
            h = np.vstack([a, [0.0, 0.0, 1.0]])
            if _plausible(h, outline, t_xy):
                inl = agree(h)
                # Prefer the homography unless the similarity explains clearly more matches.
                if best is None or inl.sum() > 1.2 * best.inliers.sum():
                    best = _Fit(h, inl, "similarity")
    return best


# --------------------------------------------------------------------------------------------
# The database
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Loaded:
    """Everything :meth:`ObjectDatabase.label` needs, loaded once."""

    generation: int
    index: DescriptorIndex
    object_of: NDArray[np.int32]  # per descriptor: object id
    view_of: NDArray[np.int32]  # per descriptor: view id
    xy: NDArray[np.float32]  # (N, 2)
    size: NDArray[np.float32]
    angle: NDArray[np.float32]
    labels: dict[int, str]
    outlines: dict[int, NDArray[np.float32]]


class ObjectDatabase:
    """A SQLite file of labelled SIFT descriptors learnt from training images.

    Open with :meth:`open` (or :meth:`create`); use as a context manager, which closes the
    file. Do not call the constructor directly.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from skimage import data
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "objects.db"
    >>> with ObjectDatabase.create(path) as db:
    ...     _ = db.add_object("cat", [data.chelsea()])
    ...     db.labels()
    ['cat']
    >>> with ObjectDatabase.open(path) as db:
    ...     [(o.label, o.views) for o in db.list_objects()]
    [('cat', 1)]
    """

    def __init__(
        self, path: Path, conn: sqlite3.Connection, *, readonly: bool, index_kind: IndexKind
    ) -> None:
        self.path = path
        self._conn: sqlite3.Connection | None = conn
        self.readonly = readonly
        self.index_kind: IndexKind = index_kind
        self._loaded: _Loaded | None = None

    # -- opening -------------------------------------------------------------------------

    @classmethod
    def create(cls, path: str | PathLike[str], *, index: IndexKind = "auto") -> ObjectDatabase:
        """Create a new, empty database file.

        Raises
        ------
        DatabaseError
            If the file already exists or cannot be written.
        """
        p = Path(path)
        if p.exists():
            raise DatabaseError(p, "already exists; open it instead, or choose another name")
        if not p.parent.exists():
            raise DatabaseError(p, f"the folder {str(p.parent)!r} does not exist")
        try:
            conn = sqlite3.connect(p, isolation_level=None)
            conn.execute("BEGIN IMMEDIATE")
            for stmt in _SCHEMA.strip().split(";"):
                if stmt.strip():
                    conn.execute(stmt)
            now = _now()
            conn.executemany(
                "INSERT INTO meta(key, value) VALUES (?, ?)",
                [
                    ("application", APPLICATION),
                    ("schema_version", str(SCHEMA_VERSION)),
                    ("descriptor", "sift-128-uint8 (OpenCV)"),
                    ("created", now),
                    ("generation", "0"),
                ],
            )
            conn.execute("COMMIT")
            conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
        except sqlite3.Error as exc:
            raise DatabaseError(p, f"cannot create the database: {exc}") from None
        return cls(p, conn, readonly=False, index_kind=index)

    @classmethod
    def open(
        cls,
        path: str | PathLike[str],
        *,
        create: bool = False,
        readonly: bool = False,
        index: IndexKind = "auto",
    ) -> ObjectDatabase:
        """Open a database file (or create it, if ``create`` and it does not exist).

        Parameters
        ----------
        path : str or path-like
        create : bool
            Create the file when it is missing.
        readonly : bool
            Open read-only (writes raise :class:`DatabaseError`).
        index : {"auto", "exact", "ivf", "faiss"}
            Nearest-neighbour index built on the first :meth:`label` (see :func:`build_index`).

        Raises
        ------
        DatabaseError
            Missing file, a folder, an empty file, a file that is not SQLite, an SQLite file
            that is not ours, another schema version, or a corrupt file.
        """
        p = Path(path)
        if not p.exists():
            if create and not readonly:
                return cls.create(p, index=index)
            raise DatabaseError(
                p, "no such file; create it with `scenespeak db add --db FILE --label NAME IMAGE`"
            )
        if p.is_dir():
            raise DatabaseError(p, "is a folder, not a scenespeak object database file")
        try:
            with p.open("rb") as fh:
                head = fh.read(len(_SQLITE_MAGIC))
        except OSError as exc:
            raise DatabaseError(p, f"cannot be read: {exc.strerror or exc}") from None
        if len(head) == 0:
            raise DatabaseError(
                p,
                "the file is empty (0 bytes): it is not a scenespeak object database; "
                "delete it or choose another name",
            )
        if head != _SQLITE_MAGIC:
            raise DatabaseError(p, "is not a scenespeak object database (not an SQLite file)")
        try:
            if readonly:
                conn = sqlite3.connect(
                    f"{p.resolve().as_uri()}?mode=ro", uri=True, isolation_level=None
                )
            else:
                conn = sqlite3.connect(p, isolation_level=None)
        except sqlite3.Error as exc:
            raise DatabaseError(p, f"cannot be opened: {exc}") from None
        try:
            _check_schema(p, conn)
        except BaseException:
            conn.close()
            raise
        return cls(p, conn, readonly=readonly, index_kind=index)

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        self._loaded = None

    def __enter__(self) -> ObjectDatabase:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"ObjectDatabase({str(self.path)!r})"

    @property
    def conn(self) -> sqlite3.Connection:
        if self._conn is None:
            raise DatabaseError(self.path, "the database is closed")
        return self._conn

    def _query(self, sql: str, args: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        try:
            return self.conn.execute(sql, args).fetchall()
        except sqlite3.DatabaseError as exc:
            raise DatabaseError(self.path, f"cannot be read (corrupt?): {exc}") from None

    # -- reading -------------------------------------------------------------------------

    def labels(self) -> list[str]:
        """Labels of all objects, sorted."""
        return [r[0] for r in self._query("SELECT label FROM objects ORDER BY label")]

    def __len__(self) -> int:
        return int(self._query("SELECT COUNT(*) FROM objects")[0][0])

    def __contains__(self, label: object) -> bool:
        return bool(self._query("SELECT 1 FROM objects WHERE label = ?", (label,)))

    def list_objects(self) -> list[ObjectInfo]:
        """Every object with its number of views and descriptors and when it was added."""
        rows = self._query(
            "SELECT o.id, o.label, COUNT(v.id), COALESCE(SUM(v.n), 0), o.added "
            "FROM objects o LEFT JOIN views v ON v.object_id = o.id "
            "GROUP BY o.id ORDER BY o.label"
        )
        return [ObjectInfo(int(a), str(b), int(c), int(d), str(e)) for a, b, c, d, e in rows]

    info = list_objects

    def views(self, label: str | None = None) -> list[TrainingView]:
        """Training views (image size and outline, no descriptors), of one object or all."""
        sql = (
            "SELECT v.id, o.label, v.source, v.width, v.height, v.outline, v.has_mask, v.n "
            "FROM views v JOIN objects o ON o.id = v.object_id"
        )
        args: tuple[Any, ...] = ()
        if label is not None:
            sql += " WHERE o.label = ?"
            args = (label,)
        rows = self._query(sql + " ORDER BY v.id", args)
        return [
            TrainingView(
                int(i),
                str(lab),
                str(src),
                int(w),
                int(h),
                np.frombuffer(out, np.float32).reshape(-1, 2).copy(),
                bool(hm),
                int(n),
            )
            for i, lab, src, w, h, out, hm, n in rows
        ]

    def generation(self) -> int:
        """A counter bumped by every write (for caches)."""
        return int(self._query("SELECT value FROM meta WHERE key = 'generation'")[0][0])

    # -- writing -------------------------------------------------------------------------

    def add_object(
        self,
        label: str,
        images: Sequence[ImageLike],
        masks: Sequence[MaskLike] | None = None,
        *,
        replace: bool = False,
        max_features: int = 0,
        contrast_threshold: float = 0.04,
        progress: Progress | None = None,
    ) -> ObjectInfo:
        """Learn an object from training images and store it, in one transaction.

        Parameters
        ----------
        label : str
            The object's name (non-empty; unique in the database).
        images : sequence of path or array
            Training images (files OpenCV reads, or gray/RGB/RGBA arrays).
        masks : sequence of (path, array or None), optional
            One per image: non-zero where the object is. Keypoints are taken only inside it,
            and its largest contour becomes the view's outline. Without a mask the whole image
            is the object.
        replace : bool
            Replace an object with the same label instead of failing.
        max_features : int
            Keep at most this many of the strongest keypoints per image (0: all).
        contrast_threshold : float
            SIFT's contrast threshold for the training images (see
            :func:`scenespeak.perception.features.detect`).
        progress : callable, optional
            Called as ``progress(stage, done, total)`` with stage ``"extract"`` (per image,
            before anything is written) and ``"store"`` (per view written).

        Returns
        -------
        ObjectInfo

        Raises
        ------
        DatabaseError
            Duplicate label without ``replace``, an empty label, a read-only database.
        ImageError
            An image (or mask) that cannot be read, or has no keypoints; the database is left
            as it was.
        """
        label = str(label).strip()
        if not label:
            raise DatabaseError(self.path, "an object needs a non-empty label")
        self._check_writable()
        images = list(images)
        if not images:
            raise DatabaseError(self.path, f"no training images given for {label!r}")
        mask_list: list[MaskLike] = [None] * len(images) if masks is None else list(masks)
        if len(mask_list) != len(images):
            raise DatabaseError(
                self.path,
                f"{len(mask_list)} masks for {len(images)} images of {label!r}; "
                "give one mask per image (or none)",
            )
        if not replace and label in self:
            raise DatabaseError(self.path, _duplicate(label))
        views: list[_ViewData] = []
        for i, (img, msk) in enumerate(zip(images, mask_list, strict=True)):
            views.append(_extract_view(img, msk, i, max_features, contrast_threshold))
            if progress is not None:
                progress("extract", i + 1, len(images))
        conn = self.conn
        try:
            conn.execute("BEGIN IMMEDIATE")
            try:
                old = conn.execute("SELECT id FROM objects WHERE label = ?", (label,)).fetchall()
                if old and not replace:
                    raise DatabaseError(self.path, _duplicate(label))
                for (oid,) in old:
                    conn.execute("DELETE FROM views WHERE object_id = ?", (oid,))
                    conn.execute("DELETE FROM objects WHERE id = ?", (oid,))
                now = _now()
                cur = conn.execute("INSERT INTO objects(label, added) VALUES (?, ?)", (label, now))
                oid = int(cur.lastrowid or 0)
                for i, v in enumerate(views):
                    f = v.features
                    kp = np.column_stack([f.xy, f.size, f.angle]).astype(np.float32)
                    conn.execute(
                        "INSERT INTO views(object_id, source, width, height, has_mask, n, "
                        "descriptors, keypoints, outline) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                        (
                            oid,
                            v.source,
                            v.width,
                            v.height,
                            int(v.has_mask),
                            len(f),
                            np.ascontiguousarray(f.descriptors, np.uint8).tobytes(),
                            kp.tobytes(),
                            np.ascontiguousarray(v.outline, np.float32).tobytes(),
                        ),
                    )
                    if progress is not None:
                        progress("store", i + 1, len(views))
                self._bump_generation()
                conn.execute("COMMIT")
            except BaseException:
                conn.execute("ROLLBACK")
                raise
        except sqlite3.Error as exc:
            raise DatabaseError(self.path, f"cannot write: {exc}") from None
        self._loaded = None
        return ObjectInfo(oid, label, len(views), sum(len(v.features) for v in views), now)

    def remove(self, label: str) -> None:
        """Remove an object and its views (one transaction).

        Raises
        ------
        DatabaseError
            If there is no object with that label.
        """
        self._check_writable()
        conn = self.conn
        try:
            conn.execute("BEGIN IMMEDIATE")
            try:
                rows = conn.execute("SELECT id FROM objects WHERE label = ?", (label,)).fetchall()
                if not rows:
                    known = ", ".join(self.labels()) or "none"
                    raise DatabaseError(
                        self.path, f"has no object labelled {label!r} (labels: {known})"
                    )
                for (oid,) in rows:
                    conn.execute("DELETE FROM views WHERE object_id = ?", (oid,))
                    conn.execute("DELETE FROM objects WHERE id = ?", (oid,))
                self._bump_generation()
                conn.execute("COMMIT")
            except BaseException:
                conn.execute("ROLLBACK")
                raise
        except sqlite3.Error as exc:
            raise DatabaseError(self.path, f"cannot write: {exc}") from None
        self._loaded = None

    def _check_writable(self) -> None:
        if self.readonly:
            raise DatabaseError(self.path, "was opened read-only")

    def _bump_generation(self) -> None:
        self.conn.execute(
            "UPDATE meta SET value = CAST(CAST(value AS INTEGER) + 1 AS TEXT) "
            "WHERE key = 'generation'"
        )

    # -- index and labelling -------------------------------------------------------------

    def load(self, *, nprobe: int = 4, seed: int = 0) -> None:
        """Load every descriptor and build the nearest-neighbour index (done lazily).

        The inverted file's trained quantiser and cell assignment are cached in the file's
        ``index_cache`` table (written when the database is writable), so that only the first
        load after a change trains it.

        Parameters
        ----------
        nprobe : int
            Inverted-file cells visited per query descriptor.
        seed : int
            Seed of the quantiser's training.

        Raises
        ------
        DatabaseError
            If the database has no objects, or a view is corrupt.
        """
        gen = self.generation()
        if self._loaded is not None and self._loaded.generation == gen:
            self._set_nprobe(nprobe)
            return
        self._loaded = None
        counts = self._query("SELECT COUNT(*), COALESCE(SUM(n), 0) FROM views")[0]
        if int(counts[0]) == 0:
            raise DatabaseError(
                self.path,
                "has no objects to match against; add some with "
                "`scenespeak db add --db FILE --label NAME IMAGE`",
            )
        total = int(counts[1])
        kp = np.empty((total, 4), np.float32)
        object_of = np.empty(total, np.int32)
        view_of = np.empty(total, np.int32)
        sizes: list[int] = []
        labels: dict[int, str] = {}
        outlines: dict[int, NDArray[np.float32]] = {}
        select = " FROM views v JOIN objects o ON o.id = v.object_id ORDER BY v.id"
        s = 0
        try:
            cursor = self.conn.execute(
                "SELECT v.id, v.object_id, o.label, v.n, v.keypoints, v.outline" + select
            )
            for vid, oid, lab, n, k_blob, o_blob in cursor:
                n = int(n)
                try:
                    kp[s : s + n] = np.frombuffer(k_blob, np.float32).reshape(n, 4)
                    outline = np.frombuffer(o_blob, np.float32).reshape(-1, 2).copy()
                except ValueError:
                    raise DatabaseError(
                        self.path, f"view {vid} of {lab!r} is corrupt (wrong BLOB sizes)"
                    ) from None
                outlines[int(vid)] = outline
                object_of[s : s + n] = oid
                view_of[s : s + n] = vid
                labels[int(oid)] = str(lab)
                sizes.append(n)
                s += n
        except sqlite3.DatabaseError as exc:
            raise DatabaseError(self.path, f"cannot be read (corrupt?): {exc}") from None
        if s != total:
            raise DatabaseError(self.path, "is corrupt (views without an object)")

        def chunks() -> Iterator[NDArray[np.uint8]]:
            try:
                rows = self.conn.execute("SELECT v.id, v.descriptors" + select)
                for (vid, blob), n in zip(rows, sizes, strict=True):
                    if len(blob) != n * _DIM:
                        raise DatabaseError(
                            self.path, f"view {vid} is corrupt (wrong descriptor BLOB size)"
                        )
                    yield np.frombuffer(blob, np.uint8).reshape(n, _DIM)
            except (sqlite3.DatabaseError, ValueError) as exc:
                raise DatabaseError(self.path, f"cannot be read (corrupt?): {exc}") from None

        kind = self.index_kind
        if kind == "auto":
            kind = _auto_kind(total)
        if kind == "faiss" and not _have_faiss():
            raise DatabaseError(
                self.path, "index 'faiss' needs the faiss-cpu package (pip install faiss-cpu)"
            )
        index: DescriptorIndex
        if kind in ("ivf", "faiss"):
            centroids, cells = self._cached_quantiser(gen, total)
            cls = IVFIndex if kind == "ivf" else FaissIndex
            index = cls.from_chunks(
                chunks, total, nprobe=nprobe, seed=seed, centroids=centroids, cells=cells
            )
            if centroids is None and not self.readonly:
                self._save_quantiser(gen, index)
        else:
            desc = np.empty((total, _DIM), np.uint8)
            s = 0
            for block in chunks():
                desc[s : s + block.shape[0]] = block
                s += block.shape[0]
            index = build_index(desc, kind, nprobe=nprobe, seed=seed)
            del desc
        self._loaded = _Loaded(
            gen, index, object_of, view_of, kp[:, :2], kp[:, 2], kp[:, 3], labels, outlines
        )

    def _set_nprobe(self, nprobe: int) -> None:
        if self._loaded is not None and hasattr(self._loaded.index, "nprobe"):
            self._loaded.index.nprobe = nprobe  # type: ignore[attr-defined]

    def _cached_quantiser(
        self, gen: int, total: int
    ) -> tuple[NDArray[np.float32] | None, NDArray[np.integer] | None]:
        try:
            rows = self.conn.execute(
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
        return centroids, cells

    def _save_quantiser(self, gen: int, index: IVFIndex | FaissIndex) -> None:
        """Cache the trained quantiser; a failure here only costs time on the next load."""
        conn = self.conn
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

    @property
    def index(self) -> DescriptorIndex:
        """The nearest-neighbour index (built on first use)."""
        self.load()
        assert self._loaded is not None
        return self._loaded.index

    def label(
        self,
        features: Features,
        *,
        ratio: float = 0.8,
        min_inliers: int = 8,
        ransac_threshold: float = 4.0,
        k: int = 16,
        homography_min: int = 12,
        max_scale_ratio: float = 2.0,
        max_angle_deg: float = 30.0,
        max_views: int = 3,
        nprobe: int = 4,
        min_inliers_small: int = 4,
        small_area: float = 8000.0,
    ) -> Labelling:
        """Label query keypoints (of the scene's left image) with the database's objects.

        Parameters
        ----------
        features : Features
            SIFT features of the scene image (``scenespeak.perception.features.detect``).
        ratio : float
            Lowe's ratio test: nearest distance < ``ratio`` × distance to the nearest
            descriptor of a *different* object. Among the ``k`` nearest neighbours; if all
            ``k`` are of the same object, the ``k``-th distance stands in (a lower bound, so
            the test is only stricter).
        min_inliers : int
            Geometric inliers needed to accept an object (a few stray matches never make one).
        ransac_threshold : float
            Reprojection tolerance in scene pixels.
        k : int
            Neighbours fetched per query descriptor.
        homography_min : int
            Matches needed to try a homography; a similarity is also tried from 2 matches.
        max_scale_ratio, max_angle_deg : float
            Each inlier's SIFT scale and orientation must agree with the model this closely.
        max_views : int
            Training views per object tried, most matched first. A query that passed the
            ratio test is a candidate in every view of its object where one of its ``k``
            neighbours lies and passes the ratio test too (the nearest such one per view), so
            matches split between near-identical views are pooled.
        nprobe : int
            Inverted-file cells visited per query descriptor (large databases only).
        min_inliers_small : int
            Inliers at distinct positions enough to accept a *small* detection (its outline in
            the scene covers at most ``small_area``): far objects carry few keypoints.
        small_area : float
            Largest outline area, in square pixels, for the small-detection rule (0: off).

        Returns
        -------
        Labelling

        Raises
        ------
        DatabaseError
            If the database is empty.
        """
        self.load(nprobe=nprobe)
        db = self._loaded
        assert db is not None
        need = min(min_inliers, min_inliers_small) if small_area > 0 else min_inliers
        nq = len(features)
        labels = np.full(nq, -1, np.int32)
        matched = np.full(nq, -1, np.int32)
        if nq == 0:
            return Labelling(labels, (), matched)
        kk = max(2, min(k, db.index.ntotal))
        dist, ids = db.index.search(features.descriptors, kk)
        valid = ids[:, 0] >= 0
        first_obj = np.where(valid, db.object_of[np.maximum(ids[:, 0], 0)], -1)
        obj = np.where(ids >= 0, db.object_of[np.maximum(ids, 0)], -1)
        other = (obj != first_obj[:, None]) & (ids >= 0)
        has_other = other.any(axis=1)
        j2 = np.argmax(other, axis=1)
        d2 = np.where(has_other, dist[np.arange(nq), j2], dist[:, -1])
        limit = (ratio * ratio) * d2
        passed = valid & (dist[:, 0] < limit)
        matched[passed] = first_obj[passed]
        # Candidate correspondences: for a query that passed, every fetched neighbour of the
        # same object that passes the ratio test too (its copies in the object's other views:
        # the same surface point seen from another side or distance), the nearest per view.
        # Each training view is then checked with all the queries that match into it, not only
        # those whose single nearest neighbour happened to lie in it.
        cand = passed[:, None] & (obj == first_obj[:, None]) & (ids >= 0) & (dist < limit[:, None])
        rows, cols = np.nonzero(cand)  # row-major: nearest first within each query
        t_all = ids[rows, cols]
        v_all = db.view_of[t_all].astype(np.int64)
        key = rows.astype(np.int64) * (int(db.view_of.max()) + 1) + v_all
        _, first = np.unique(key, return_index=True)
        q_idx = rows[first].astype(np.intp)
        t_idx = t_all[first]
        view = db.view_of[t_idx]

        candidates: list[tuple[float, Detection, NDArray[np.intp]]] = []
        for oid in np.unique(first_obj[q_idx]).tolist():
            sel_o = first_obj[q_idx] == oid
            vids, counts = np.unique(view[sel_o], return_counts=True)
            if counts.max() < need:
                continue
            best: tuple[int, Detection] | None = None
            order = np.argsort(-counts, kind="stable")[:max_views]
            for vid, count in zip(vids[order].tolist(), counts[order].tolist(), strict=True):
                # Views come most matched first, and a view's inliers are a subset of its
                # matches: once a view has fewer than ``need`` matches, or no more than the
                # best view's inliers (a later view must have strictly more to win), no view
                # that follows can change the result.
                if count < need or (best is not None and count <= best[0]):
                    break
                sel = sel_o & (view == vid)
                qi = q_idx[sel]
                ti = t_idx[sel]
                outline = db.outlines[vid]
                fit = _fit_view(
                    db.xy[ti].astype(np.float64),
                    db.size[ti],
                    db.angle[ti],
                    features.xy[qi],
                    features.size[qi],
                    features.angle[qi],
                    outline,
                    threshold=ransac_threshold,
                    homography_min=homography_min,
                    max_scale_ratio=max_scale_ratio,
                    max_angle_deg=max_angle_deg,
                )
                if fit is None:
                    continue
                n_in = int(fit.inliers.sum())
                if n_in < need or (best is not None and n_in <= best[0]):
                    continue
                in_scene = _apply_h(fit.h, outline.astype(np.float64))
                if n_in < min_inliers and not _small_enough(
                    in_scene, features.xy[qi[fit.inliers]], small_area, min_inliers_small
                ):
                    continue
                det = Detection(
                    label=db.labels[oid],
                    view_id=int(vid),
                    homography=fit.h,
                    inliers=np.sort(qi[fit.inliers]).astype(np.intp),
                    outline_in_scene=in_scene,
                    score=float(n_in),
                    model=fit.model,
                    matches=int(sel.sum()),
                )
                best = (n_in, det)
            if best is not None:
                candidates.append((best[1].score, best[1], best[1].inliers))
        candidates.sort(key=lambda c: -c[0])
        detections = tuple(c[1] for c in candidates)
        for i, det in enumerate(detections):
            labels[det.inliers] = i
        return Labelling(labels, detections, matched)


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
    if version != str(SCHEMA_VERSION):
        raise DatabaseError(
            path,
            f"{not_ours} of this version (schema version {version}, this scenespeak reads "
            f"{SCHEMA_VERSION}); rebuild it with `scenespeak db add`",
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
