"""The edge tables of the force sweep, one direction at a time (private; compiled by Numba).

For a direction (c, s) each region's edges become rows ``[v_lo, v_hi, s(v_lo), ds/dv,
sign(dv)]`` (``v`` across the lines, ``s`` along them, in the region's own frame), sorted by
``v_lo`` for the two-pointer walk of :mod:`~scenespeak.spatial.forces._sweep`, and kept sorted
from one direction to the next (the order changes little between neighbours).
"""

from __future__ import annotations

import math

import numpy as np

from scenespeak.spatial.forces._jit import jit

# Regions with more edges than this are projected into ``tab`` and ordered by _order; the
# smaller ones are projected in place (_rows, _insertion_rows).
BUCKET_SORT_FROM = 96
# _order bucket-sorts a region before the insertion sort when its last insertion sort alone
# moved more than this many keys per edge (star 200 + 200 at 180 directions: about 1).
BUCKET_MOVES = 4


@jit
def _edge_row(
    c: float, s: float, pts: np.ndarray, nxt: np.ndarray, e: int, out: np.ndarray, j: int
) -> float:
    """Write edge ``e``'s row for direction (c, s) into ``out[j]``; returns its first ``v``.

    The row is ``[v_lo, v_hi, s(v_lo), ds/dv, sign(dv)]`` in the region's frame (``pts`` are
    relative to the region's origin).
    """
    f = nxt[e]
    s0 = pts[e, 0] * c + pts[e, 1] * s
    v0 = pts[e, 1] * c - pts[e, 0] * s
    s1 = pts[f, 0] * c + pts[f, 1] * s
    v1 = pts[f, 1] * c - pts[f, 0] * s
    dv = v1 - v0
    down = dv < 0.0  # selects, not branches: an outline's edges go up and down at random
    out[j, 0] = v1 if down else v0
    out[j, 1] = v0 if down else v1
    out[j, 2] = s1 if down else s0
    out[j, 4] = -1.0 if down else (1.0 if dv > 0.0 else 0.0)
    k = (s1 - s0) / dv
    out[j, 3] = k if dv != 0.0 else 0.0
    return v0


@jit
def _project(
    c: float, s: float, pts: np.ndarray, nxt: np.ndarray, lo_g: int, hi_g: int, tab: np.ndarray
) -> tuple[float, float]:
    """Rows ``lo_g:hi_g`` of the edge table for direction (c, s); returns the ``v`` range.

    ``tab[e]`` is edge ``e``'s row (:func:`_edge_row`).
    """
    vmin = math.inf
    vmax = -math.inf
    for e in range(lo_g, hi_g):
        v0 = _edge_row(c, s, pts, nxt, e, tab, e)
        vmin = min(vmin, v0)
        vmax = max(vmax, v0)
    return vmin, vmax


@jit
def _bucket(tab: np.ndarray, perm: np.ndarray, keys: np.ndarray, lo_g: int, hi_g: int) -> None:
    """Stable counting sort of ``perm[lo_g:hi_g]`` into ``n`` equal-width buckets of ``v_lo``;
    ``keys[lo_g:hi_g]`` are the ``v_lo`` of ``perm`` in the order it leaves."""
    n = hi_g - lo_g
    vmin = math.inf
    vmax = -math.inf
    for j in range(lo_g, hi_g):
        v = tab[perm[j], 0]
        keys[j] = v
        vmin = min(vmin, v)
        vmax = max(vmax, v)
    if not vmax > vmin:
        return  # keys already follow perm
    scale = (n - 1) / (vmax - vmin)
    counts = np.zeros(n + 1, dtype=np.int64)
    slot = np.empty(n, dtype=np.int64)
    for j in range(n):
        k = int((keys[lo_g + j] - vmin) * scale)
        k = min(max(k, 0), n - 1)
        slot[j] = k
        counts[k + 1] += 1
    for k in range(n):
        counts[k + 1] += counts[k]
    moved = np.empty(n, dtype=np.int64)
    moved_keys = np.empty(n)
    for j in range(n):
        k = slot[j]
        moved[counts[k]] = perm[lo_g + j]
        moved_keys[counts[k]] = keys[lo_g + j]
        counts[k] += 1
    for j in range(n):
        perm[lo_g + j] = moved[j]
        keys[lo_g + j] = moved_keys[j]


@jit
def _insertion(perm: np.ndarray, keys: np.ndarray, lo_g: int, hi_g: int) -> int:
    """Insertion sort of ``keys[lo_g:hi_g]``, ``perm`` with them; returns the keys moved."""
    moved = 0
    for j in range(lo_g + 1, hi_g):
        kv = keys[j]
        if keys[j - 1] <= kv:
            continue
        key = perm[j]
        i = j - 1
        while i >= lo_g and keys[i] > kv:
            perm[i + 1] = perm[i]
            keys[i + 1] = keys[i]
            i -= 1
        moved += j - 1 - i
        perm[i + 1] = key
        keys[i + 1] = kv
    return moved


@jit
def _order(
    tab: np.ndarray,
    perm: np.ndarray,
    keys: np.ndarray,
    span: tuple[int, int],
    first: bool,
    moves: np.ndarray,
    g: int,
) -> None:
    """Keep ``perm[lo_g:hi_g]`` (``span``) sorted by ``v_lo``: a full sort the first time, then
    insertion sort from the previous direction's order (few inversions between neighbours), on
    the keys copied contiguous so that the shifts read and write neighbouring memory.

    Over half a turn every pair of vertices swaps once, so insertion sort alone costs ``n² / 2``
    moves per region over the half turn: few per direction for outlines of a few hundred
    vertices, many for traced masks of thousands. So the moves of region ``g``'s last plain
    insertion sort are kept in ``moves[g]`` (-1 before the first), and when they exceed
    :data:`BUCKET_MOVES` per edge the previous order is first distributed into ``n`` buckets of
    equal ``v`` width (:func:`_bucket`), which leaves only the few inversions inside each
    bucket: linear time per direction. Both give the same order (the stable sort of the
    previous order), so the choice changes the time only.
    """
    lo_g, hi_g = span
    if first:
        order = np.argsort(tab[lo_g:hi_g, 0])
        for j in range(hi_g - lo_g):
            perm[lo_g + j] = lo_g + order[j]
        moves[g] = -1
        return
    if moves[g] > BUCKET_MOVES * (hi_g - lo_g):
        _bucket(tab, perm, keys, lo_g, hi_g)  # leaves the keys in perm's new order
        _insertion(perm, keys, lo_g, hi_g)
        return
    for j in range(lo_g, hi_g):
        keys[j] = tab[perm[j], 0]
    moves[g] = _insertion(perm, keys, lo_g, hi_g)


@jit
def _rows(
    c: float,
    s: float,
    pts: np.ndarray,
    nxt: np.ndarray,
    perm: np.ndarray,
    srt: np.ndarray,
    lo_g: int,
    hi_g: int,
) -> tuple[float, float]:
    """:func:`_project` straight into ``srt`` in the order of ``perm`` (row ``j`` is edge
    ``perm[j]``): for small regions, where the rows that change place between neighbouring
    directions are few and moving them costs less than a gather; returns the ``v`` range."""
    vmin = math.inf
    vmax = -math.inf
    for j in range(lo_g, hi_g):
        v0 = _edge_row(c, s, pts, nxt, perm[j], srt, j)
        vmin = min(vmin, v0)
        vmax = max(vmax, v0)
    return vmin, vmax


@jit
def _insertion_rows(srt: np.ndarray, perm: np.ndarray, lo_g: int, hi_g: int) -> None:
    """Insertion sort of rows ``lo_g:hi_g`` (and ``perm`` with them) by ``v_lo``: the same
    moves as :func:`_order`'s insertion sort on keys, so the same order."""
    for j in range(lo_g + 1, hi_g):
        kv = srt[j, 0]
        if srt[j - 1, 0] <= kv:
            continue
        key = perm[j]
        r1 = srt[j, 1]
        r2 = srt[j, 2]
        r3 = srt[j, 3]
        r4 = srt[j, 4]
        i = j - 1
        while i >= lo_g and srt[i, 0] > kv:
            for q in range(5):
                srt[i + 1, q] = srt[i, q]
            perm[i + 1] = perm[i]
            i -= 1
        perm[i + 1] = key
        srt[i + 1, 0] = kv
        srt[i + 1, 1] = r1
        srt[i + 1, 2] = r2
        srt[i + 1, 3] = r3
        srt[i + 1, 4] = r4


@jit
def _tables(
    c: float,
    s: float,
    pts: np.ndarray,
    nxt: np.ndarray,
    region_start: np.ndarray,
    first: bool,
    scratch: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    needed: np.ndarray,
) -> None:
    """Every region's edge table for direction (c, s), each sorted by the edge's ``v_lo``.

    ``scratch`` is ``(tab, perm, extent, srt, keys, moves)``: ``tab`` the rows of
    :func:`_project`, ``perm`` each region's edges by ``v_lo``, ``extent[g]`` region g's range of
    ``v``, ``srt[j] = tab[perm[j]]`` (the rows in sorted order, contiguous), ``keys`` scratch,
    ``moves`` :func:`_order`'s record of each region's last insertion sort.
    Regions of at most :data:`BUCKET_SORT_FROM` edges skip ``tab``: their rows are projected
    in the previous order and moved into place (:func:`_rows`, :func:`_insertion_rows`).
    Regions with ``needed[g]`` False (only in convex chain walks) are left alone.
    """
    tab, perm, extent, srt, keys, moves = scratch
    for g in range(region_start.size - 1):
        if not needed[g]:
            continue
        lo_g = region_start[g]
        hi_g = region_start[g + 1]
        if hi_g - lo_g <= BUCKET_SORT_FROM:  # small: rows projected in place, then moved
            extent[g, 0], extent[g, 1] = _rows(c, s, pts, nxt, perm, srt, lo_g, hi_g)
            if first:
                order = np.argsort(srt[lo_g:hi_g, 0])
                perm[lo_g:hi_g] = perm[lo_g:hi_g][order]
                _rows(c, s, pts, nxt, perm, srt, lo_g, hi_g)
            _insertion_rows(srt, perm, lo_g, hi_g)
            continue
        extent[g, 0], extent[g, 1] = _project(c, s, pts, nxt, lo_g, hi_g, tab)
        _order(tab, perm, keys, (lo_g, hi_g), first, moves, g)
        for j in range(lo_g, hi_g):
            e = perm[j]
            srt[j, 0] = tab[e, 0]
            srt[j, 1] = tab[e, 1]
            srt[j, 2] = tab[e, 2]
            srt[j, 3] = tab[e, 3]
            srt[j, 4] = tab[e, 4]
