"""The inverted-file index (k-means coarse quantiser over ``uint8`` lists) in NumPy/BLAS, and
the same cells searched by FAISS when ``faiss-cpu`` is installed."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields
from typing import Any, Self, cast

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.blas import omp_threads, single_threaded_blas
from scenespeak.perception.recognition.index import (
    _DIM,
    _batches,
    _runs,
    _sqnorms,
    _topk_rows,
)
from scenespeak.perception.recognition.quantiser import _quantise, quantiser_fits

__all__ = ["FaissIndex", "IVFIndex", "quantiser_fits"]


@dataclass(frozen=True)
class _QuantiserOptions:
    """The coarse quantiser's keywords of an index's constructor (``nlist``, ``train_size``,
    ``iters``, ``seed``; a cached ``centroids`` + ``cells`` pair, used when it fits)."""

    nlist: int | None = None
    train_size: int = 65536
    iters: int = 10
    seed: int = 0
    centroids: NDArray[np.float32] | None = None
    cells: NDArray[np.integer] | None = None
    train: tuple[Callable[[], Iterator[NDArray[np.uint8]]], int] | None = None


_QUANTISER = tuple(f.name for f in fields(_QuantiserOptions))


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
    cache_rejected: bool

    def _build(
        self,
        chunks: Callable[[], Iterator[NDArray[np.uint8]]],
        n: int,
        *,
        nprobe: int = 4,
        **options: Any,
    ) -> None:
        # the quantiser's keywords (see _QuantiserOptions); the rest are the subclass's _fill's
        quantiser = _QuantiserOptions(**{k: options.pop(k) for k in _QUANTISER if k in options})
        centroids, cells = quantiser.centroids, quantiser.cells
        #: True when a cached quantiser was given but did not fit the data (then retrained).
        self.cache_rejected = False
        if centroids is not None and cells is not None:
            if not quantiser_fits(chunks, n, centroids, cells):
                centroids, cells = None, None
                self.cache_rejected = True
        self.centroids, assign = _quantise(
            chunks,
            n,
            nlist=quantiser.nlist,
            train_size=quantiser.train_size,
            iters=quantiser.iters,
            seed=quantiser.seed,
            cached=(centroids, cells),
            train=quantiser.train,
        )
        self.nprobe = nprobe
        self._fill(chunks, n, assign, **options)

    def _fill(
        self,
        chunks: Callable[[], Iterator[NDArray[np.uint8]]],
        n: int,
        assign: NDArray[np.intp],
        threads: int | None = None,
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
        return cast("NDArray[np.uint16 | np.int32]", out)

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
        # two cores). So BLAS runs single-threaded during the search (threadpoolctl, a declared
        # dependency, restores the setting afterwards).
        with single_threaded_blas():
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


#: Rows per float32 block added to a FAISS index (16 MiB; 8,192 rows cost each load 0.25 s
#: more CPU at 1,000 objects, FAISS going over every list per block).
_FILL_ROWS = 32768


def _fill_lists(
    index: Any,
    chunks: Callable[[], Iterator[NDArray[np.uint8]]],
    assign: NDArray[np.intp],
    nlist: int,
) -> None:
    """Add the descriptors to a FAISS inverted file under their cells ``assign``.

    Each list's memory is allocated once at its final size (growing it as the blocks arrive
    left part of it unused), and the descriptors go in as float32 blocks of
    :data:`_FILL_ROWS` rows (65,536 rows took 32 MiB at once). ``add_core`` puts each list's
    entries in the order of the ids, whatever the blocks: the same lists (tested). At 1,000
    objects the load's peak (tracemalloc) went from 118.7 to 60.5 MB and its RSS growth from
    152 to 98-105 MB, with :func:`quantiser_fits`'s sample no longer holding every chunk.
    """
    import faiss  # optional dependency

    lists = faiss.downcast_InvertedLists(index.invlists)
    counts = np.bincount(assign, minlength=nlist)
    for cell in np.flatnonzero(counts).tolist():
        lists.resize(cell, int(counts[cell]))  # the capacity, once; then filled from 0
        lists.resize(cell, 0)
    start = 0
    for block in _batches(chunks, _FILL_ROWS):
        x = np.ascontiguousarray(block, np.float32)
        pre = np.ascontiguousarray(assign[start : start + x.shape[0]], np.int64)
        index.add_core(x.shape[0], faiss.swig_ptr(x), None, faiss.swig_ptr(pre))
        start += x.shape[0]


class FaissIndex(_IndexBuilder):
    """FAISS ``IndexIVFScalarQuantizer`` with ``QT_8bit_direct``: exact ``uint8`` storage.

    Only available when the optional ``faiss-cpu`` package is installed. Uses the same coarse
    quantiser as :class:`IVFIndex` (so the cache in the database file serves both); the
    descriptors are stored as 128-byte codes (no residuals), searched by FAISS in C++.
    A small search runs on one OpenMP thread (:attr:`serial_below`; the same answer: each
    query is scanned on its own).
    """

    #: Searches computing fewer distances than this run on one thread: each query is compared
    #: with the ``nlist`` coarse centroids and then with the ``nprobe · N / nlist`` descriptors
    #: of its cells on average, ``nq · (nlist + nprobe · N / nlist)`` in all. A scene's 301
    #: queries against 6,820 descriptors took 20 ms wall, 8 ms CPU on FAISS's two threads,
    #: 2–6 ms wall, 2.1–2.7 ms CPU on one (2 cores, load 6); 2,318 queries against 1,000
    #: objects (571,333 descriptors, nlist 2,048, 7.3 million distances) took 187 ms on one
    #: thread and 93 ms on two (idle; counting the cells alone, 2.6 million, had put them on
    #: one).
    serial_below = 1 << 22
    #: OpenMP threads of every search (None: one below :attr:`serial_below`, else FAISS's own).
    threads: int | None = None

    def _fill(
        self,
        chunks: Callable[[], Iterator[NDArray[np.uint8]]],
        n: int,
        assign: NDArray[np.intp],
        threads: int | None = None,
    ) -> None:
        """The FAISS index of the cells (``threads``: FAISS chooses its own)."""
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
        _fill_lists(index, chunks, assign, nl)
        self._cells = assign.astype(np.uint16 if nl <= 65535 else np.int32)
        self._index = index
        self._quantizer = quantizer
        self._n = n

    def cells(self) -> NDArray[np.uint16 | np.int32]:
        """The coarse cell of every descriptor, in the order they were given (for caching)."""
        return cast("NDArray[np.uint16 | np.int32]", self._cells)

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
        threads = self.threads
        per_query = self.nlist + self.nprobe * self._n / max(self.nlist, 1)
        if threads is None and q.shape[0] * per_query < self.serial_below:
            threads = 1
        with omp_threads(threads):
            d, i = self._index.search(q, k)
        d = np.where(i < 0, np.inf, d).astype(np.float32)
        return d, i.astype(np.int64)
