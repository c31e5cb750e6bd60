"""Nearest-neighbour indexes over ``uint8`` SIFT descriptors: the protocol, exact search, and
:func:`build_index` choosing exact / IVF / FAISS."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from typing import Literal, Protocol

import numpy as np
from numpy.typing import NDArray

__all__ = ["DescriptorIndex", "ExactIndex", "IndexKind", "build_index"]


_DIM = 128

IndexKind = Literal["auto", "exact", "ivf", "faiss"]


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


def _have_faiss() -> bool:
    try:
        import faiss  # noqa: F401
    except ImportError:
        return False
    return True


def _auto_kind(n: int, exact_below: int = 4096) -> IndexKind:
    if n < exact_below:
        return "exact"
    return "faiss" if _have_faiss() else "ivf"


def _default_nlist(n: int) -> int:
    return int(2 ** round(math.log2(max(1.0, 2.0 * math.sqrt(n)))))


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
    # The inverted files build on this module's helpers: imported here, not at the top.
    from scenespeak.perception.recognition.ivf import FaissIndex, IVFIndex

    if kind == "ivf":
        return IVFIndex(
            data, nlist=nlist, nprobe=nprobe, seed=seed, centroids=centroids, cells=cells
        )
    if kind == "faiss":
        return FaissIndex(
            data, nlist=nlist, nprobe=nprobe, seed=seed, centroids=centroids, cells=cells
        )
    raise ValueError(f"unknown index kind {kind!r}; use auto, exact, ivf or faiss")
