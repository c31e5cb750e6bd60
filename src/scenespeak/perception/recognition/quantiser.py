"""The inverted file's coarse quantiser: k-means on a sample of the ``uint8`` descriptors, the
cell of every descriptor, and the check that a cached quantiser fits the descriptors it claims.

(Split out of :mod:`~scenespeak.perception.recognition.ivf`, which builds the lists on it.)
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.recognition.index import (
    _DIM,
    _batches,
    _default_nlist,
    _nearest_centroid,
)

__all__ = ["quantiser_fits"]


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


def _quantise(
    chunks: Callable[[], Iterator[NDArray[np.uint8]]],
    n: int,
    *,
    nlist: int | None,
    train_size: int,
    iters: int,
    seed: int,
    cached: tuple[NDArray[np.float32] | None, NDArray[np.integer] | None],
    train: tuple[Callable[[], Iterator[NDArray[np.uint8]]], int] | None = None,
) -> tuple[NDArray[np.float32], NDArray[np.intp]]:
    """Coarse quantiser (trained on a sample unless ``cached = (centroids, cells)`` gives it)
    and each descriptor's cell. ``train``: the chunks the quantiser is trained on and their
    count, when not all (the learnt descriptors, not those of synthesised views:
    ``loading.index_of``)."""
    centroids, cells = cached
    if centroids is None:
        cells = None
        source, n_train = train if train is not None else (chunks, n)
        if nlist is None:
            nlist = _default_nlist(n_train)
        nlist = max(1, min(nlist, n_train))
        rng = np.random.default_rng(seed)
        pick = np.sort(rng.choice(n_train, size=min(n_train, train_size), replace=False))
        sample = np.empty((pick.size, _DIM), np.uint8)
        start = 0
        for block in source():
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


def quantiser_fits(
    chunks: Callable[[], Iterator[NDArray[np.uint8]]],
    n: int,
    centroids: NDArray[np.float32],
    cells: NDArray[np.integer],
    *,
    sample: int = 2048,
) -> bool:
    """Does a cached quantiser fit the descriptors it claims to index?

    A cache with the right sizes can still be wrong (stale, or planted): every centroid must be
    finite and inside the descriptors' range (a k-means mean of ``uint8`` vectors lies in
    [0, 255]), and the cached cell of a fixed sample of ``sample`` descriptors (every
    ``n / sample``-th) must be its nearest centroid, up to float32 rounding. One pass over
    the chunks, ``sample`` distance rows: a few milliseconds against seconds of training
    (the sample copied out of its chunks, which views of them kept alive: 73 MB at 1,000
    objects, as much as the index; the distances 256 rows at a time, 16 MB at once at nlist
    2,048).

    >>> rng = np.random.default_rng(0)
    >>> x = rng.integers(0, 256, (500, 128)).astype(np.uint8)
    >>> c = x[:8].astype(np.float32)
    >>> cells = _nearest_centroid(x.astype(np.float32), c)
    >>> quantiser_fits(lambda: iter([x]), 500, c, cells)
    True
    >>> quantiser_fits(lambda: iter([x]), 500, c, (cells + 1) % 8)
    False
    """
    c = np.asarray(centroids, np.float32)
    cell = np.asarray(cells)
    if c.ndim != 2 or c.shape[0] < 1 or cell.shape != (n,):
        return False
    if not np.isfinite(c).all() or c.min() < -1.0 or c.max() > 256.0:
        return False
    if cell.size and (int(cell.min()) < 0 or int(cell.max()) >= c.shape[0]):
        return False
    step = max(1, n // sample)
    rows: list[NDArray[np.uint8]] = []
    start = 0
    for block in chunks():
        first = (-start) % step
        rows.append(block[first::step].copy())  # not a view: it would keep the whole chunk
        start += block.shape[0]
    if start != n:
        return False
    x = np.concatenate(rows).astype(np.float32) if rows else np.zeros((0, _DIM), np.float32)
    picked = cell[::step][: x.shape[0]]
    cn = np.einsum("ij,ij->i", c, c)
    wrong = np.zeros(x.shape[0], bool)
    for s in range(0, x.shape[0], 256):  # 256 distance rows at a time (2 MB at nlist 2048)
        xs = x[s : s + 256]
        d = np.einsum("ij,ij->i", xs, xs)[:, None] - 2.0 * (xs @ c.T) + cn
        best = d.min(axis=1)
        mine = d[np.arange(xs.shape[0]), picked[s : s + 256]]
        wrong[s : s + 256] = mine > best + 1e-3 * np.maximum(1.0, np.abs(best))
    return bool(wrong.mean() <= 0.01) if wrong.size else True
