"""Marching squares for boolean masks: the iso-line at level 0.5, as oriented rings (private).

The outline passes through the midpoint of every *crack*, the side shared by a pixel inside
and a 4-neighbour outside (Lorensen & Cline 1987, in two dimensions). In each 2 x 2 cell of
pixel centres the segments join the cell's cracks, oriented with the inside on the left (in
``(x, y) = (col, -row)``, image up): going round the cell counter-clockwise, each crack
crossed from inside to outside is joined to the next one crossed from outside to inside.
That rule also settles the two saddle cells (diagonal pixels set): their inside pixels are
joined through the cell, i.e. the object is 8-connected, as ``skimage.measure.find_contours``
with ``fully_connected="high"``. Every crack then has one segment leaving it and one entering
it, so the segments link into closed rings: outer boundaries counter-clockwise, holes
clockwise. The result is the same polygon as scikit-image's (same vertices, same orientation);
only the first vertex of each ring differs (here: the first crack in scan order).

The table of links and the rings are plain loops (:func:`links_loop`, :func:`follow_rings`)
that :mod:`~scenespeak.spatial.forces._shapes` compiles when the compiled kernel is loaded;
otherwise the table is whole-array NumPy (:func:`crack_links`, the same table) and the rings
are followed by the interpreter, so both paths give the same rings.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

IntArray = NDArray[np.int64]

# The cell's corners counter-clockwise in (x, y): top-left, bottom-left, bottom-right,
# top-right; side k joins corner k to corner k + 1 (left, bottom, right, top).
# For each of the 16 cases (bit k: corner k inside), the segments (from side, to side).
_SEGMENTS = np.full((16, 2, 2), -1, dtype=np.int64)
for _case in range(1, 15):
    _inside = [(_case >> k) & 1 for k in range(4)]
    _leave = [k for k in range(4) if _inside[k] and not _inside[(k + 1) % 4]]
    for _n, _k in enumerate(_leave):
        _to = next(
            (_k + t) % 4
            for t in range(1, 4)
            if not _inside[(_k + t) % 4] and _inside[(_k + t + 1) % 4]
        )
        _SEGMENTS[_case, _n] = (_k, _to)


def crack_links(padded: NDArray[np.bool_]) -> IntArray:
    """For every crack of ``padded`` (False all round), the crack its outline goes to next.

    Crack ids: ``r * W + c`` for the horizontal crack between pixels ``(r, c)`` and
    ``(r, c + 1)``; ``H * W + r * W + c`` for the vertical one between ``(r, c)`` and
    ``(r + 1, c)``. ``-1`` where no outline passes.
    """
    h, w = padded.shape
    p = padded.astype(np.int64)
    case = p[:-1, :-1] | (p[1:, :-1] << 1) | (p[1:, 1:] << 2) | (p[:-1, 1:] << 3)
    rr, cc = np.nonzero((case != 0) & (case != 15))
    segs = _SEGMENTS[case[rr, cc]]  # (n, 2 segments, (from, to))
    # Crack id of side k of cell (r, c): left V(r, c), bottom H(r+1, c), right V(r, c+1),
    # top H(r, c).
    hw = h * w
    side_ids = np.stack(
        [hw + rr * w + cc, (rr + 1) * w + cc, hw + rr * w + cc + 1, rr * w + cc], axis=1
    )
    links = np.full(2 * hw, -1, dtype=np.int64)
    for n in range(2):
        ok = segs[:, n, 0] >= 0
        rows = np.flatnonzero(ok)
        links[side_ids[rows, segs[rows, n, 0]]] = side_ids[rows, segs[rows, n, 1]]
    return links


def follow_rings(links: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """The rings of ``links``: ``(points, ring_start)``, points as ``(row, col)``.

    Ring ``k`` is ``points[ring_start[k]:ring_start[k + 1]]``, starting at its first crack in
    id order; rings in the order of their first crack.
    """
    n = links.size
    hw = width * height
    count = 0
    for i in range(n):
        if links[i] >= 0:
            count += 1
    points = np.empty((count, 2))
    starts = np.empty(count + 1, dtype=np.int64)
    seen = np.zeros(n, dtype=np.bool_)
    k = 0
    rings = 0
    for i in range(n):
        if links[i] < 0 or seen[i]:
            continue
        starts[rings] = k
        rings += 1
        j = i
        while not seen[j]:
            seen[j] = True
            if j < hw:
                points[k, 0] = j // width
                points[k, 1] = j % width + 0.5
            else:
                points[k, 0] = (j - hw) // width + 0.5
                points[k, 1] = (j - hw) % width
            k += 1
            j = links[j]
    starts[rings] = k
    return points, starts[: rings + 1]


def _follow_numpy(links: IntArray, width: int, height: int) -> tuple[NDArray[np.float64], IntArray]:
    """:func:`follow_rings` for the interpreter: the same rings in the same order, visiting only
    the cracks an outline passes (a Python list walk), coordinates computed as arrays."""
    nxt = links.tolist()
    seen = set()
    order: list[int] = []
    starts = [0]
    for i in np.flatnonzero(links >= 0).tolist():
        if i in seen:
            continue
        j = i
        while j not in seen:
            seen.add(j)
            order.append(j)
            j = nxt[j]
        starts.append(len(order))
    ids = np.asarray(order, dtype=np.int64)
    hw = width * height
    vertical = ids >= hw
    local = np.where(vertical, ids - hw, ids)
    points = np.column_stack(
        [
            local // width + np.where(vertical, 0.5, 0.0),
            local % width + np.where(vertical, 0.0, 0.5),
        ]
    ).astype(np.float64)
    return points.reshape(-1, 2), np.asarray(starts, dtype=np.int64)


def links_loop(padded: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """:func:`crack_links` as one loop over the cells (the same table; compiled in _shapes)."""
    h, w = padded.shape
    hw = h * w
    links = np.full(2 * hw, -1, dtype=np.int64)
    ids = np.empty(4, dtype=np.int64)
    for r in range(h - 1):
        for c in range(w - 1):
            case = (
                np.int64(padded[r, c])
                | (np.int64(padded[r + 1, c]) << 1)
                | (np.int64(padded[r + 1, c + 1]) << 2)
                | (np.int64(padded[r, c + 1]) << 3)
            )
            if case == 0 or case == 15:
                continue
            ids[0] = hw + r * w + c
            ids[1] = (r + 1) * w + c
            ids[2] = hw + r * w + c + 1
            ids[3] = r * w + c
            for n in range(2):
                k = segments[case, n, 0]
                if k >= 0:
                    links[ids[k]] = ids[segments[case, n, 1]]
    return links


def ring_table(padded: NDArray[np.bool_]) -> tuple[NDArray[np.float64], IntArray]:
    """The outline of ``padded`` (False all round): ``(points, ring_start)`` as
    :func:`follow_rings` gives them (compiled once the kernel is loaded, else NumPy)."""
    from scenespeak.spatial.forces import _jit

    if _jit.loaded():
        from scenespeak.spatial.forces import _shapes

        links = _shapes.trace_links(np.ascontiguousarray(padded, dtype=np.bool_), _SEGMENTS)
        points, starts = _shapes.trace_rings(links, padded.shape[1], padded.shape[0])
        return points, starts
    return _follow_numpy(crack_links(padded), padded.shape[1], padded.shape[0])


def rings(padded: NDArray[np.bool_]) -> list[NDArray[np.float64]]:
    """The outline of ``padded`` (False all round) as rings of ``(row, col)`` points.

    Examples
    --------
    >>> m = np.zeros((4, 4), bool)
    >>> m[1:3, 1] = True   # two pixels, one above the other
    >>> [ring.tolist() for ring in rings(m)]   # crack midpoints, inside on the left
    [[[1.0, 0.5], [2.0, 0.5], [2.5, 1.0], [2.0, 1.5], [1.0, 1.5], [0.5, 1.0]]]
    """
    points, starts = ring_table(padded)
    return [points[starts[k] : starts[k + 1]] for k in range(len(starts) - 1)]
