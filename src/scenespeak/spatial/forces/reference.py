"""The NumPy reference of the force sweep (the compiled kernel is tested against it).

For two regions and a block of directions, every (edge of A, edge of B) pair whose ranges of
lines overlap is found from one sort of the vertices per direction and cumulative counts
(:func:`_pairs`); each pair's exact integral ``∫ Φ(s_A(v) - s_B(v)) dv`` is a divided difference
of the antiderivative ``Ψ`` (:func:`_mean_phi`), binned by direction (:func:`_bin_values`). See
``docs/forces.md`` for the derivation (Matsakis & Wendling 1999, eq. 4-6, written per edge pair).

Everything here is whole-array NumPy: about 300 small array operations per pair and block,
which is why :mod:`~scenespeak.spatial.forces.kernel` exists. It stays the specification.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scenespeak.spatial.forces.regions import Region as _Region

FloatArray = NDArray[np.float64]

# Below this |h| / |m| the divided difference of Ψ is replaced by its Taylor series.
_TAYLOR_RATIO = 1e-3
# Directions are swept in blocks of about this many (direction, vertex) entries.
_BLOCK = 4096
_BLOCK_PAIRS = 32768

# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Kernel:
    """Elementary force ``φ(d) = d**-r`` (``y0 = 0``) or ``1 / max(d, y0)**2`` (hybrid)."""

    r: float
    y0: float = 0.0

    def force(self, u: FloatArray) -> FloatArray:
        if self.y0 > 0:
            return 1.0 / np.maximum(u, self.y0) ** 2
        if self.r == 0:
            return np.ones_like(u)
        return u ** (-self.r)

    def big_phi(self, u: FloatArray) -> FloatArray:
        r = self.r
        if self.y0 > 0:
            y0 = self.y0
            low = u * u / (2 * y0 * y0)
            with np.errstate(divide="ignore", invalid="ignore"):
                high = 2 * u / y0 - 1.5 - np.log(u / y0)
            return np.where(u <= y0, low, high)
        if r == 0:
            return 0.5 * u * u
        if r == 1:
            return u * np.log(u)
        if r == 2:
            return -np.log(u)
        return u ** (2 - r) / ((1 - r) * (2 - r))

    def psi(self, u: FloatArray) -> FloatArray:
        r = self.r
        if self.y0 > 0:
            y0 = self.y0
            low = u**3 / (6 * y0 * y0)
            with np.errstate(divide="ignore", invalid="ignore"):
                high = u * u / y0 - 0.5 * u - u * np.log(u / y0) - y0 / 3
            return np.where(u <= y0, low, high)
        if r == 0:
            return u * u * u / 6.0
        if r == 1:
            return 0.5 * u * u * np.log(u) - 0.25 * u * u
        if r == 2:
            return u - u * np.log(u)
        if r == 3:
            return 0.5 * np.log(u)
        return u ** (3 - r) / ((1 - r) * (2 - r) * (3 - r))


def _mean_phi(kernel: _Kernel, a0: FloatArray, a1: FloatArray) -> FloatArray:
    """Mean of ``Φ⁺`` over an interval on which the gap goes linearly from a0 to a1 (>= 0).

    ``Φ⁺`` is ``Φ`` on ``u > 0`` and 0 at ``u = 0``. The mean is
    ``(Ψ(a1) - Ψ(a0)) / (a1 - a0)`` (``Ψ' = Φ``, ``Ψ(0) = 0``), replaced by its Taylor series
    about the midpoint, ``Φ(m) + φ(m) (a1 - a0)² / 24``, when ``a1 - a0`` is tiny next to ``m``.
    """
    h = a1 - a0
    m = 0.5 * (a0 + a1)
    small = np.abs(h) <= _TAYLOR_RATIO * m
    pos0 = a0 > 0
    pos1 = a1 > 0
    p0 = np.where(pos0, kernel.psi(np.where(pos0, a0, 1.0)), 0.0)
    p1 = np.where(pos1, kernel.psi(np.where(pos1, a1, 1.0)), 0.0)
    out = (p1 - p0) / np.where(small, 1.0, h)
    idx = np.flatnonzero(small)
    if idx.size:
        ms, hh = m[idx], h[idx]
        safe = np.where(ms > 0, ms, 1.0)
        taylor = kernel.big_phi(safe) + kernel.force(safe) * hh * hh / 24.0
        out[idx] = np.where(ms > 0, taylor, 0.0)
    return out


# --------------------------------------------------------------------------------------------
# The edge-pair engine.
# --------------------------------------------------------------------------------------------


def _expand(start: NDArray[np.intp], end: NDArray[np.intp]) -> tuple[NDArray[np.intp], ...]:
    """Rows and positions of all ``range(start[i], end[i])`` concatenated."""
    counts = np.maximum(end - start, 0)
    csum = np.cumsum(counts)
    total = int(csum[-1]) if len(csum) else 0
    rows = np.repeat(np.arange(len(start)), counts)
    pos = np.arange(total) + (start + counts - csum)[rows]
    return rows, pos


@dataclass(frozen=True)
class _Pairs:
    """Edge pairs of A and B whose ranges of lines overlap, in every direction swept.

    ``a``/``b`` index the columns of the (5, D*E) edge attributes ``[v_lo, v_hi, s(v_lo),
    ds/dv, sign(dv)]``; ``direction`` is the row d of each pair.
    """

    a: NDArray[np.intp]
    b: NDArray[np.intp]
    direction: NDArray[np.intp]
    attrs: FloatArray


def _edge_attributes(
    v0: FloatArray, s0: FloatArray, v1: FloatArray, s1: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Edges from (s0, v0) to (s1, v1) as ``[v_lo, v_hi, s(v_lo), ds/dv, sign(dv)]``.

    Returns the (5, *v0.shape) attributes and which edges run downwards in ``v`` (their lower
    vertex is the end).
    """
    down = v1 < v0
    attrs = np.empty((5, *v0.shape))
    np.minimum(v0, v1, out=attrs[0])
    np.maximum(v0, v1, out=attrs[1])
    np.copyto(attrs[2], s0)
    np.copyto(attrs[2], s1, where=down)
    dv = v1 - v0
    np.divide(s1 - s0, np.where(dv != 0, dv, np.inf), out=attrs[3])
    np.sign(dv, out=attrs[4])
    return attrs, down


def _pairs(a: _Region, b: _Region, c: FloatArray, s: FloatArray) -> _Pairs:
    """All (edge of A, edge of B) pairs whose v-ranges overlap, for each direction (c, s).

    Both regions' vertices are put in one table (A first). Edge ``e`` runs from vertex ``e``
    to vertex ``nxt[e]``; ``low[e]``/``high[e]`` are its lower and upper vertices in ``v``.
    The vertices of both regions are sorted by ``v`` in each direction; ``≺`` is that order (a
    total order; ties broken arbitrarily). A pair overlaps iff ``low_e ≺ low_f ≺ high_e`` or
    ``low_f ≺ low_e ≺ high_f``: that finds every pair with a common range of positive length
    exactly once (pairs tied at a single ``v`` may come too; they weigh nothing). Cumulative
    counts of lower vertices along the order give, for every edge, the contiguous run (in the
    other region's edges sorted by lower vertex) that satisfies its case.
    """
    n, m = len(a.start), len(b.start)
    width = n + m
    n_dir = len(c)
    centre = 0.5 * (a.start[0] + b.start[0])
    pts = np.concatenate([a.start, b.start]) - centre
    nxt = np.concatenate([a.nxt, b.nxt + n])
    prv = np.concatenate([a.prv, b.prv + n])
    sv = (pts @ np.concatenate([np.stack([c, s]), np.stack([-s, c])], axis=1)).T
    s_all = sv[:n_dir]  # (D, N): position along u = (cos, sin)
    v_all = sv[n_dir:]  # position across, along n = (-sin, cos)
    # Directions in which no line meets both objects (A's range of v strictly below or above
    # B's) have no pair at all: every A-vertex comes before every B-vertex in the order, or
    # after. Leaving them out changes nothing else: the other rows, their pairs and the
    # pairs' order are the same.
    v_a, v_b = v_all[:, :n], v_all[:, n:]
    apart = (v_a.max(axis=1) < v_b.min(axis=1)) | (v_b.max(axis=1) < v_a.min(axis=1))
    kept: NDArray[np.intp] | None = None
    if apart.any():
        kept = np.flatnonzero(~apart)
        if kept.size == 0:
            none = np.zeros(0, dtype=np.intp)
            return _Pairs(a=none, b=none, direction=none, attrs=np.zeros((5, 0)))
        s_all, v_all = s_all[kept], v_all[kept]
        n_dir = kept.size
    attrs, down = _edge_attributes(v_all, s_all, v_all[:, nxt], s_all[:, nxt])
    idx = np.arange(width)
    low = idx + down * (nxt - idx)
    # Per vertex: how many edges it is the lower vertex of (0, 1, 2); an edge that shares its
    # lower vertex with the previous edge ranks second among the two.
    starts_low = ~down
    incoming_low = down[:, prv]
    mult = starts_low.astype(np.intp) + incoming_low
    second = starts_low & incoming_low

    row = np.arange(n_dir)[:, None]
    order = np.argsort(v_all, axis=1)
    is_b = order >= n
    order = (order + row * width).ravel()
    ms = mult.ravel()[order].reshape(n_dir, width)
    ma = np.where(is_b, 0, ms)
    mb = ms - ma
    # Per vertex: d*n + the number of A-edges whose lower vertex comes before it in the order
    # of direction d (cnt_a), and d*m + the same for B-edges (cnt_b). One cumulative sum runs
    # over all directions: each direction has n lower ends of A-edges and m of B-edges.
    cnt_a = np.empty(n_dir * width, dtype=np.intp)
    cnt_b = np.empty(n_dir * width, dtype=np.intp)
    ma = ma.ravel()
    mb = mb.ravel()
    cnt_a[order] = np.cumsum(ma) - ma
    cnt_b[order] = np.cumsum(mb) - mb
    flat_low = low + row * width
    flat_high = (nxt + idx - low) + row * width
    low_a, low_b = flat_low[:, :n].ravel(), flat_low[:, n:].ravel()
    high_a, high_b = flat_high[:, :n].ravel(), flat_high[:, n:].ravel()
    # Flat ids of the edges (columns of attrs), and the same sorted by lower vertex per
    # direction, B's block first, then A's.
    edges_a = (idx[:n] + row * width).ravel()
    edges_b = (idx[n:] + row * width).ravel()
    a_block = n_dir * m  # by_lo holds B's edges, then A's
    by_lo = np.empty(n_dir * width, dtype=np.intp)
    by_lo[cnt_b[low_b] + second[:, n:].ravel()] = edges_b
    by_lo[cnt_a[low_a] + (second[:, :n].ravel() + a_block)] = edges_a
    # Case 1, per A-edge: the B-edges with low_e ≺ low_f ≺ high_e (a run in B's block).
    # Case 2, per B-edge: the A-edges with low_f ≺ low_e ≺ high_f (a run in A's block).
    start = np.concatenate([cnt_b[low_a], cnt_a[low_b] + a_block])
    end = np.concatenate([cnt_b[high_a], cnt_a[high_b] + a_block])
    rows, pos = _expand(start, end)
    first = np.concatenate([edges_a, edges_b])[rows]
    other = by_lo[pos]
    case1 = rows < n_dir * n
    ia = np.where(case1, first, other)
    ib = np.where(case1, other, first)
    direction = ia // width
    return _Pairs(
        a=ia,
        b=ib,
        direction=direction if kept is None else kept[direction],
        attrs=attrs.reshape(5, -1),
    )


def _edge_pair_histograms(
    a: _Region, b: _Region, kernels: list[_Kernel], directions: int
) -> FloatArray:
    """Histograms for several kernels at once, shape ``(len(kernels), directions)``.

    With an even number of directions only the first half is swept: reversing the direction
    turns every ``d = s_A - s_B`` into ``-d`` and leaves the pairs and weights as they are, so
    the same pairs give ``F(θ + π)`` through ``Φ⁺(-d)``.
    """
    half = directions // 2 if directions % 2 == 0 else directions
    theta = 2.0 * np.pi * np.arange(half) / directions
    cos, sin = np.cos(theta), np.sin(theta)
    out = np.empty((len(kernels), directions))
    # Sweep the directions in blocks so that the temporaries stay small (cache-resident).
    width = len(a.start) + len(b.start)
    block = first_block = half if half * width <= 4 * _BLOCK else max(1, _BLOCK // width)
    first = 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        while first < half:
            rows = slice(first, min(first + block, half))
            first = rows.stop
            pairs = _pairs(a, b, cos[rows], sin[rows])
            # Next block: about _BLOCK_PAIRS pairs, judging by this one.
            per_row = max(len(pairs.a), 1) / (rows.stop - rows.start)
            block = max(1, min(int(_BLOCK_PAIRS / per_row), 4 * first_block))
            n_rows = rows.stop - rows.start
            for i, values in enumerate(_bin_values(pairs, kernels, n_rows, 2 * n_rows)):
                out[i, rows] = values[:n_rows]
                if half < directions:
                    out[i, rows.start + half : rows.stop + half] = values[n_rows:]
    return out


def _bin_values(
    pairs: _Pairs, kernels: list[_Kernel], n_rows: int, n_bins: int
) -> list[FloatArray]:
    """Sum every edge pair's force into its bin, for each kernel (arrays of ``n_bins``).

    A pair's bin is ``pairs.direction`` where the gap ``d = s_A - s_B`` is positive and
    ``pairs.direction + n_rows`` (the opposite direction) where it is negative.
    """
    lo_a, hi_a, s_a, k_a, sg_a = np.take(pairs.attrs, pairs.a, axis=1)
    lo_b, hi_b, s_b, k_b, sg_b = np.take(pairs.attrs, pairs.b, axis=1)
    lo = np.maximum(lo_a, lo_b)
    hi = np.minimum(hi_a, hi_b)
    d0 = (s_a + k_a * (lo - lo_a)) - (s_b + k_b * (lo - lo_b))
    d1 = (s_a + k_a * (hi - lo_a)) - (s_b + k_b * (hi - lo_b))
    # A-edges count + where they leave A (exit), B-edges + where they enter B.
    weight = (sg_a * sg_b) * np.minimum(lo - hi, 0.0)
    # A pair serves direction θ where d > 0 and θ + π where d < 0 (bin + n_rows). A pair
    # whose gap changes sign is split at the zero into one part for each.
    bins = pairs.direction + n_rows * ((d0 + d1) < 0)
    g0, g1 = np.abs(d0), np.abs(d1)
    cross = np.flatnonzero(d0 * d1 < 0)
    if cross.size:
        c0, c1, cw = d0[cross], d1[cross], weight[cross]
        frac = np.maximum(c0, c1) / (np.abs(c0) + np.abs(c1))
        g0[cross] = 0.0
        g1[cross] = np.maximum(c0, c1)
        weight[cross] = cw * frac
        bins[cross] = pairs.direction[cross]
        g0 = np.concatenate([g0, np.zeros(cross.size)])
        g1 = np.concatenate([g1, -np.minimum(c0, c1)])
        weight = np.concatenate([weight, cw * (1.0 - frac)])
        bins = np.concatenate([bins, pairs.direction[cross] + n_rows])
    return [
        np.asarray(
            np.bincount(bins, weights=weight * _mean_phi(kernel, g0, g1), minlength=n_bins),
            dtype=np.float64,
        )
        for kernel in kernels
    ]


def _many_pairs(items: Sequence[tuple[_Region, _Region]], c: FloatArray, s: FloatArray) -> _Pairs:
    """:func:`_pairs` of several pairs of regions at once, for the same directions (c, s).

    Each pair's vertices are projected and sorted exactly as :func:`_pairs` does (the same
    products, the same argsort of the same rows); the rows of all pairs then go through the
    cumulative counts together, laid end to end (row ``r`` of pair ``p`` is one run of
    ``n_p + m_p`` entries). ``direction`` is ``2 * len(c) * p + d`` for direction row ``d`` of
    pair ``p``. Restricted to one pair, the pairs found and their order are those of
    :func:`_pairs`, so binned sums are the same floats.
    """
    n_dir = len(c)
    dirs = np.concatenate([np.stack([c, s]), np.stack([-s, c])], axis=1)
    # Rows where the objects' ranges of v are apart have no pair (see _pairs). Here the ranges
    # come from each region's own vertices, once per region, and a row is left out only when
    # they are apart by more than 1e-9 times the coordinates' size: the pair's own positions
    # (taken from a shifted origin) differ from these by a few ulps of that size, so such a
    # row is apart in them too. A row kept although apart finds no pair either.
    extent: dict[int, tuple[FloatArray, FloatArray, float]] = {}
    for a, b in items:
        for r in (a, b):
            if id(r) not in extent:
                v = r.start @ dirs[:, n_dir:]
                extent[id(r)] = (v.min(axis=0), v.max(axis=0), float(np.abs(r.start).max()))
    lo_a, hi_a, size_a = zip(*(extent[id(a)] for a, _ in items), strict=True)
    lo_b, hi_b, size_b = zip(*(extent[id(b)] for _, b in items), strict=True)
    margin = 1e-9 * np.maximum(size_a, size_b)[:, None]
    apart_all = (np.stack(hi_a) < np.stack(lo_b) - margin) | (
        np.stack(hi_b) < np.stack(lo_a) - margin
    )
    vs, ss, orders, rows_kept, direction = [], [], [], [], []
    widths, firsts, nxt_local, prv_local = [], [], [], []
    for k, (a, b) in enumerate(items):
        kept = np.flatnonzero(~apart_all[k])
        if kept.size == 0:
            continue
        n, m = len(a.start), len(b.start)
        centre = 0.5 * (a.start[0] + b.start[0])
        sv = ((np.concatenate([a.start, b.start]) - centre) @ dirs).T
        s_all = sv[:n_dir]
        v_all = sv[n_dir:]
        if kept.size < n_dir:
            s_all, v_all = s_all[kept], v_all[kept]
        vs.append(v_all.ravel())
        ss.append(s_all.ravel())
        orders.append(np.argsort(v_all, axis=1).ravel())
        direction.append(2 * n_dir * k + kept)
        rows_kept.append(kept.size)
        widths.append(n + m)
        firsts.append(n)
        nxt_local.append(np.concatenate([a.nxt, b.nxt + n]))
        prv_local.append(np.concatenate([a.prv, b.prv + n]))
    if not vs:
        none = np.zeros(0, dtype=np.intp)
        return _Pairs(a=none, b=none, direction=none, attrs=np.zeros((5, 0)))
    # Entry e is column col[e] of a row that starts at entry row0[e]; its pair's vertex tables
    # (concatenated over the pairs) start at table0[e].
    row_width = np.repeat(widths, rows_kept)
    row_start = np.cumsum(row_width) - row_width
    base = int(row_width.sum())
    row0 = np.repeat(row_start, row_width)
    col = np.arange(base) - row0
    table_start = np.cumsum(widths) - widths
    table = np.repeat(table_start, rows_kept)
    table0 = np.repeat(table, row_width) + col
    v_all, s_all = np.concatenate(vs), np.concatenate(ss)
    nxt = row0 + np.concatenate(nxt_local)[table0]
    prv = row0 + np.concatenate(prv_local)[table0]
    order = row0 + np.concatenate(orders)
    b_vertex = col >= np.repeat(np.repeat(firsts, rows_kept), row_width)
    entry_direction = np.repeat(np.concatenate(direction), row_width)
    idx = np.arange(base)
    attrs, down = _edge_attributes(v_all, s_all, v_all[nxt], s_all[nxt])
    low = idx + down * (nxt - idx)
    starts_low = ~down
    incoming_low = down[prv]
    mult = starts_low.astype(np.intp) + incoming_low
    second = starts_low & incoming_low
    ms = mult[order]
    ma = np.where(b_vertex[order], 0, ms)
    mb = ms - ma
    cnt_a = np.empty(base, dtype=np.intp)
    cnt_b = np.empty(base, dtype=np.intp)
    cnt_a[order] = np.cumsum(ma) - ma
    cnt_b[order] = np.cumsum(mb) - mb
    high = nxt + idx - low
    edges_a = np.flatnonzero(~b_vertex)
    edges_b = np.flatnonzero(b_vertex)
    low_a, low_b = low[edges_a], low[edges_b]
    a_block = edges_b.size  # by_lo holds B's edges, then A's
    by_lo = np.empty(base, dtype=np.intp)
    by_lo[cnt_b[low_b] + second[edges_b]] = edges_b
    by_lo[cnt_a[low_a] + (second[edges_a] + a_block)] = edges_a
    start = np.concatenate([cnt_b[low_a], cnt_a[low_b] + a_block])
    end = np.concatenate([cnt_b[high[edges_a]], cnt_a[high[edges_b]] + a_block])
    rows, pos = _expand(start, end)
    first = np.concatenate([edges_a, edges_b])[rows]
    other = by_lo[pos]
    case1 = rows < edges_a.size
    ia = np.where(case1, first, other)
    ib = np.where(case1, other, first)
    return _Pairs(a=ia, b=ib, direction=entry_direction[ia], attrs=attrs)


def _many_f0_f2(items: Sequence[tuple[_Region, _Region]], directions: int) -> FloatArray:
    """``_edge_pair_histograms(a, b, [F0, F2], directions)`` of several pairs, one sweep.

    Returns an array of shape ``(len(items), 2, directions)``, each pair's the same floats as
    its own sweep. Pairs too large for a single block, or an odd number of directions, are
    swept one by one.
    """
    kernels = [_Kernel(0.0), _Kernel(2.0)]
    out = np.empty((len(items), 2, directions))
    half = directions // 2
    batch = [
        k
        for k, (a, b) in enumerate(items)
        if directions % 2 == 0 and half * (len(a.start) + len(b.start)) <= 4 * _BLOCK
    ]
    single = set(range(len(items))) - set(batch)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if batch:
            theta = 2.0 * np.pi * np.arange(half) / directions
            cos, sin = np.cos(theta), np.sin(theta)
            pairs = _many_pairs([items[k] for k in batch], cos, sin)
            values = _bin_values(pairs, kernels, half, 2 * half * len(batch))
            for i, v in enumerate(values):
                out[batch, i] = v.reshape(len(batch), directions)
    for k in sorted(single):
        out[k] = _edge_pair_histograms(*items[k], kernels, directions)
    return out
