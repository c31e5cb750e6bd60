"""OpenCV's 3-way semi-global block matching as Numba loops (private; needs Numba).

The body of :func:`scenespeak.perception.stereo.sgbm.sgbm3way`: the same integers as OpenCV's
``StereoSGBM`` in ``MODE_SGBM_3WAY`` (``modules/stereo/src/stereosgbm.cpp``:
``calcPixelCostBT``, ``SGBM3WayMainLoop``, ``computeDisparity3WaySGBM``), written again as
plain loops over padded int16 rows that LLVM vectorises as wide as the host allows (32 int16
lanes with AVX-512BW, 16 with AVX2), where OpenCV's baseline build runs 8.

Every function here is compiled once and cached on disk (``cache=True``); they call only each
other (all in this file), so Numba's check of this file's source is enough to keep the cache
fresh. The callers guarantee the range in which int16 sums cannot saturate (OpenCV's
saturating adds and plain adds then agree): see ``sgbm.fits_int16``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_MAX = 32767  # SHRT_MAX, OpenCV's MAX_COST and the path costs' border


@njit(cache=True, nogil=True)
def channels(img: np.ndarray, out: np.ndarray, mirror: bool) -> None:  # pragma: no cover - compiled
    """The two matching channels of ``calcPixelCostBT`` for every row, with their half-pixel
    minima and maxima (Birchfield & Tomasi).

    ``out[y, c, k, x]``: c = 0 the clipped horizontal Sobel response (0..30, preFilterCap 15),
    c = 1 the intensity; k = 0 the value, 1 its minimum and 2 its maximum over the half-pixel
    neighbours ``(v + v[x ± 1]) // 2``. Columns 0 and w - 1 of both channels are 15 (OpenCV
    writes ``tab[0]`` there, whatever the pixel). With ``mirror``, each row is stored
    reversed (column ``w - 1 - x`` at x), as OpenCV keeps the right image's.
    """
    h, w = img.shape
    for y in range(h):
        yn = y - 1 if y > 0 else y
        ys = y + 1 if y < h - 1 else y
        g = out[y, 0, 0]
        v = out[y, 1, 0]
        g[0] = 15
        g[w - 1] = 15
        v[0] = 15
        v[w - 1] = 15
        for x in range(1, w - 1):
            s = (
                (np.int32(img[y, x + 1]) - np.int32(img[y, x - 1])) * 2
                + np.int32(img[yn, x + 1])
                - np.int32(img[yn, x - 1])
                + np.int32(img[ys, x + 1])
                - np.int32(img[ys, x - 1])
            )
            g[x] = max(-15, min(int(s), 15)) + 15
            v[x] = img[y, x]
        for c in range(2):
            val = out[y, c, 0]
            lo = out[y, c, 1]
            hi = out[y, c, 2]
            for x in range(w):
                u = np.int32(val[x])
                ul = (u + np.int32(val[x - 1])) // 2 if x > 0 else u
                ur = (u + np.int32(val[x + 1])) // 2 if x < w - 1 else u
                lo[x] = min(min(ul, ur), u)
                hi[x] = max(max(ul, ur), u)
        if mirror:  # column w - 1 - x at x (in cache: the row was just made)
            for c in range(2):
                for q in range(3):
                    r = out[y, c, q]
                    for x in range(w // 2):
                        t = r[x]
                        r[x] = r[w - 1 - x]
                        r[w - 1 - x] = t


@njit(cache=True, nogil=True)
def _pixel_costs(
    r1: np.ndarray, r2: np.ndarray, xl: int, base: int, out: np.ndarray, j: int
) -> None:  # pragma: no cover - compiled
    """``calcPixelCostBT`` for one left pixel: ``out[j, d]`` for d = 0 .. D-1.

    ``r1[c, k]``, ``r2[c, k]``: row y of :func:`channels` of the left image and of the mirrored
    right one (column ``w - 1 - i`` at i, as OpenCV keeps it, so that the partner of the left
    column ``xl``, ``xl - min_d - d``, is at ``base + d`` with ``base = w - 1 - xl + min_d``).
    Indices are unsigned: Numba then adds no wrap-around test and the loop vectorises.
    """
    nd = out.shape[1]
    gu = r1[0, 0, xl]
    gu0 = r1[0, 1, xl]
    gu1 = r1[0, 2, xl]
    iu = r1[1, 0, xl]
    iu0 = r1[1, 1, xl]
    iu1 = r1[1, 2, xl]
    ub = np.uint64(base)
    for d in range(nd):
        # max(0, u - v1, v0 - u) is the distance of u to [v0, v1]: max(u, v0) - min(u, v1),
        # exact in uint8 (v0 <= v1), so the loop runs in 8-bit lanes
        i = ub + np.uint64(d)
        gv = r2[0, 0, i]
        iv = r2[1, 0, i]
        a = np.uint8(max(gu, r2[0, 1, i]) - min(gu, r2[0, 2, i]))
        b = np.uint8(max(gv, gu0) - min(gv, gu1))
        c = np.uint8(max(iu, r2[1, 1, i]) - min(iu, r2[1, 2, i]))
        e = np.uint8(max(iv, iu0) - min(iv, iu1))
        out[j, d] = np.uint8(min(a, b) + (min(c, e) >> np.uint8(2)))


@njit(cache=True, nogil=True)
def _box_start(p: np.ndarray, half: int, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """The horizontal box sum at column 0 of one row of pixel costs ``p``: column 0 counted
    ``half + 1`` times (OpenCV replicates it), then columns 1 .. half."""
    w1, nd = p.shape
    for d in range(nd):
        out[d] = np.int16(np.int16(p[0, d]) * np.int16(half + 1))
    for j in range(1, half + 1):
        jj = min(j, w1 - 1)
        for d in range(nd):
            out[d] = np.int16(out[d] + p[jj, d])


@njit(cache=True, nogil=True)
def _row(
    imgs: tuple, k: int, paths_on: bool, geo: tuple, weights: tuple, bufs: tuple, pen: tuple
) -> None:  # pragma: no cover - compiled
    """One image row k into a stripe's running block costs, then (``paths_on``) the left and
    top paths of the current row, summed into ``lt``; column by column, so that every row of d
    stays in the L1 cache between its steps (one loop on purpose: a call per column costs more
    than the column).

    Block costs (``getRawMatchingCost``): ``padd`` gets row k's pixel costs (uint8, at most
    93) when k is inside the image (below it, ``padd`` holds the last row's, as OpenCV reuses
    them); ``hadd`` and ``hsub`` are the running horizontal box sums of ``padd`` and of
    ``psub`` (the row leaving the box), made column by column as OpenCV makes its rows of them;
    ``cvol += hadd · wa - hsub · ws`` with ``weights`` (wa, ws): (1, 1) on most rows; on a
    stripe's first row (half + 1, 0) for its first image row (rows above the stripe replicate
    it), then (1, 0).

    Paths: Hirschmüller's eq. 13 in OpenCV's form, ``L[d] = C[d] + min(min(prev[d-1],
    prev[d+1]) + P1, prev[d], min(prev) + P2) - (min(prev) + P2)``, over rows padded with
    ``SHRT_MAX - P1`` at d = -1 and d = D (OpenCV's SHRT_MAX saturates; this never wraps).
    ``top`` (each column's previous top path) and ``top_min`` are updated in place.

    ``imgs``: (left channels, mirrored right channels); ``geo``: (min_x1, min_d, half);
    ``bufs``: (padd, psub, hadd, hsub, cvol, left, top, top_min, tmp, lt); ``pen``: (P1, P2).
    """
    ch1, ch2r = imgs
    min_x1, min_d, half = geo
    wa, ws = np.int16(weights[0]), np.int16(weights[1])
    padd, psub, hadd, hsub, cvol, left, top, top_min, tmp, lt = bufs
    p1, p2 = pen
    h = ch1.shape[0]
    w = ch1.shape[3]
    w1, nd = cvol.shape
    r1 = ch1[min(k, h - 1)]
    r2 = ch2r[min(k, h - 1)]
    last = w1 if k < h else 0  # pixel costs are made for columns < last
    for j in range(min(half + 1, last)):
        _pixel_costs(r1, r2, min_x1 + j, w - 1 - min_x1 - j + min_d, padd, j)
    _box_start(padd, half, hadd)
    _box_start(psub, half, hsub)
    q1 = np.int16(p1)
    left[0, 1 : nd + 1] = 0
    lmin = np.int16(0)
    cur = 0
    for x in range(w1):
        j = x + half
        if 0 < x and j < last:
            _pixel_costs(r1, r2, min_x1 + j, w - 1 - min_x1 - j + min_d, padd, j)
        if x > 0:
            ja = min(j, w1 - 1)
            js = max(x - half - 1, 0)
            for d in range(nd):
                hadd[d] = np.int16(np.int16(hadd[d] + padd[ja, d]) - padd[js, d])
                hsub[d] = np.int16(np.int16(hsub[d] + psub[ja, d]) - psub[js, d])
        for d in range(nd):
            c = np.int16(np.int16(cvol[x, d] + np.int16(hadd[d] * wa)) - np.int16(hsub[d] * ws))
            cvol[x, d] = c
        if not paths_on:
            continue
        nxt = 1 - cur
        lm = np.int16(lmin + p2)
        tm = np.int16(top_min[x] + p2)
        ml = np.int16(_MAX)
        mt = np.int16(_MAX)
        for d in range(nd):
            c = cvol[x, d]
            a = np.int16(min(left[cur, d], left[cur, d + 2]) + q1)
            b = min(left[cur, d + 1], lm)
            v = np.int16(np.int16(c + min(a, b)) - lm)
            left[nxt, d + 1] = v
            ml = min(ml, v)
            a = np.int16(min(top[x, d], top[x, d + 2]) + q1)
            b = min(top[x, d + 1], tm)
            t = np.int16(np.int16(c + min(a, b)) - tm)
            tmp[d] = t
            mt = min(mt, t)
            lt[x, d] = np.int16(v + t)
        for d in range(nd):  # in place: the row is in L1, the volume's footprint stays one
            top[x, d + 1] = tmp[d]
        lmin = ml
        top_min[x] = mt
        cur = nxt


@njit(cache=True, nogil=True)
def _lane_best(s: np.ndarray, m: int, lanes: int) -> int:  # pragma: no cover - compiled
    """The disparity OpenCV's vector loop picks among equal summed costs ``m``: in each of
    ``lanes`` lanes (d mod lanes) the last d with that lane's minimum, then the smallest of
    those among the lanes that reach ``m``."""
    nd = s.shape[0]
    best = nd
    seen = np.zeros(lanes, np.bool_)
    for d in range(nd - 1, -1, -1):
        if s[d] == m:
            lane = d % lanes
            if not seen[lane]:
                seen[lane] = True
                best = min(best, d)
    return best


@njit(cache=True, nogil=True)
def _backward(
    cvol: np.ndarray, bufs: tuple, geo: tuple, cfg: tuple
) -> None:  # pragma: no cover - compiled
    """The right-to-left path of one row, the sum of the three paths, the choice of the
    disparity, the uniqueness test, the reverse map (``disp2``) and the sub-pixel parabola:
    ``row[min_x1 + x]`` for the pixels that pass (the others are left as they are).

    ``bufs``: (right, lt, s, row, disp2, disp2cost); ``geo``: (min_x1, min_d); ``cfg``: (P1, P2,
    uniquenessRatio, lanes).
    """
    right, lt, s, row, disp2, disp2cost = bufs
    min_x1, min_d = geo
    p1, p2, uniqueness, lanes = cfg
    w1, nd = cvol.shape
    w = row.shape[0]
    q1 = np.int16(p1)
    idx = np.arange(nd).astype(np.int32)
    right[0, 1 : nd + 1] = 0
    rmin = np.int16(0)
    cur = 0
    for x in range(w1 - 1, -1, -1):
        nxt = 1 - cur
        rm = np.int16(rmin + p2)
        mr = np.int16(_MAX)
        ms = np.int16(_MAX)
        for d in range(nd):
            a = np.int16(min(right[cur, d], right[cur, d + 2]) + q1)
            b = min(right[cur, d + 1], rm)
            v = np.int16(np.int16(cvol[x, d] + min(a, b)) - rm)
            right[nxt, d + 1] = v
            mr = min(mr, v)
            sv = np.int16(lt[x, d] + v)
            s[d] = sv
            ms = min(ms, sv)
        rmin = mr
        cur = nxt
        min_cost = ms
        # the first d with the minimum: min of (cost << 16 | d), 16 int32 lanes wide
        key = np.int32(2147483647)
        for d in range(nd):
            key = min(key, np.int32(np.int32(s[d]) * np.int32(65536) + idx[d]))
        best = int(key & 0xFFFF)
        if uniqueness > 0:
            # ties apart by more than 1 fail the test whichever of them is "best"
            thresh = np.int16((100 * np.int32(min_cost)) // (100 - uniqueness) + 1)
            other = np.int16(_MAX)
            for d in range(0, max(best - 1, 0)):
                other = min(other, s[d])
            tail = s[best + 2 :]  # a slice: no wrap-around test, the loop vectorises
            for d in range(tail.shape[0]):
                other = min(other, tail[d])
            if other < thresh:
                continue
        else:
            best = _lane_best(s, int(min_cost), lanes)
        x2 = x + min_x1 - best - min_d
        if 0 <= x2 < w and disp2cost[x2] > min_cost:
            disp2cost[x2] = min_cost
            disp2[x2] = best + min_d
        if 0 < best < nd - 1:
            sm = int(s[best - 1])
            sp = int(s[best + 1])
            denom2 = max(sm + sp - 2 * int(s[best]), 1)
            num = (sm - sp) * 16 + denom2
            q = abs(num) // (2 * denom2)
            dd = best * 16 + (q if num >= 0 else -q)
        else:
            dd = best * 16
        row[x + min_x1] = dd + min_d * 16


@njit(cache=True, nogil=True)
def stripe(
    imgs: tuple, n: int, geom: tuple, cfg: tuple, out: np.ndarray, work: tuple
) -> None:  # pragma: no cover - compiled
    """``SGBM3WayMainLoop`` for stripe n: what OpenCV writes into its ``dst_disp[n]`` (``out``,
    ``stripe_sz + overlap`` rows, all set here). ``work``: the buffers of :func:`workspace`
    (their contents do not matter; one set per thread, reused from stripe to stripe).

    ``imgs``: (left channels, mirrored right channels) of :func:`channels`; ``geom``:
    (stripe_sz, overlap); ``cfg``: (minDisparity, numDisparities, blockSize // 2, P1, P2,
    uniquenessRatio, disp12MaxDiff, lanes).
    """
    ch1 = imgs[0]
    stripe_sz, overlap = geom
    min_d, nd, half, p1, p2, uniqueness, disp12, lanes = cfg
    h = ch1.shape[0]
    w = ch1.shape[3]
    max_d = min_d + nd
    min_x1 = max(max_d, 0)
    max_x1 = w + min(min_d, 0)
    invalid = (min_d - 1) * 16
    out[:, :] = invalid
    y0 = max(min(n * stripe_sz - overlap, h), 0)
    y1 = min((n + 1) * stripe_sz, h)
    dst0 = overlap if n == 0 else 0
    ring, hadd, hsub, cvol, top, top_min, tmp, lt, left, right, s, disp2, disp2cost = work
    hrows = ring.shape[0]
    cvol[:, :] = p2
    top[:, :] = 0
    top_min[:] = 0
    edge = np.int16(_MAX - p1)  # the paths' border: never chosen, + P1 never wraps
    top[:, 0] = edge
    top[:, nd + 1] = edge
    for i in range(2):
        left[i, 0] = edge
        left[i, nd + 1] = edge
        right[i, 0] = edge
        right[i, nd + 1] = edge
    geo = (min_x1, min_d, half)
    pen = (p1, p2)
    bcfg = (p1, p2, uniqueness, lanes)
    for y in range(y0, y1):
        if y == y0:  # the stripe's first row: rows y0 .. y0 + half, y0 counted half + 1 times
            for k in range(y0, y0 + half + 1):
                pk = ring[min(k, h - 1) % hrows]
                bufs = (pk, pk, hadd, hsub, cvol, left, top, top_min, tmp, lt)
                weights = (half + 1 if k == y0 else 1, 0)
                _row(imgs, k, k == y0 + half, geo, weights, bufs, pen)
        else:
            k = y + half
            pk = ring[min(k, h - 1) % hrows]
            ps = ring[max(y - half - 1, y0) % hrows]
            bufs = (pk, ps, hadd, hsub, cvol, left, top, top_min, tmp, lt)
            _row(imgs, k, True, geo, (1, 1), bufs, pen)
        # --- backward: right-to-left path, the sum, the choice, uniqueness, sub-pixel
        row = out[dst0 + y - y0]
        disp2[:] = invalid
        disp2cost[:] = _MAX
        _backward(cvol, (right, lt, s, row, disp2, disp2cost), (min_x1, min_d), bcfg)
        _lr_check(row, disp2, (min_x1, max_x1, min_d, disp12))


@njit(cache=True, nogil=True)
def _lr_check(row: np.ndarray, disp2: np.ndarray, geo: tuple) -> None:  # pragma: no cover
    """OpenCV's pseudo left-right check of one row against its reverse map ``disp2``: a
    disparity whose floor and ceiling both land on reverse disparities (known ones) more than
    disp12MaxDiff away is dropped. ``geo``: (min_x1, max_x1, min_d, disp12MaxDiff)."""
    min_x1, max_x1, min_d, disp12 = geo
    w = row.shape[0]
    invalid = (min_d - 1) * 16
    for x in range(min_x1, max_x1):
        d1 = np.int32(row[x])
        if d1 == invalid:
            continue
        da = d1 >> 4
        db = (d1 + 15) >> 4
        xa = x - da
        xb = x - db
        if (
            0 <= xa < w
            and disp2[xa] >= min_d
            and abs(np.int32(disp2[xa]) - da) > disp12
            and 0 <= xb < w
            and disp2[xb] >= min_d
            and abs(np.int32(disp2[xb]) - db) > disp12
        ):
            row[x] = invalid


def workspace(w: int, w1: int, nd: int, half: int) -> tuple:
    """The buffers :func:`stripe` works in, for a crop ``w`` wide with ``w1`` matched columns,
    D = ``nd`` disparities and a block ``2·half + 1`` pixels high (about ``(half + 5) · w1 · D``
    int16)."""
    return (
        np.empty((2 * half + 2, w1, nd), np.uint8),  # the ring of the last rows' pixel costs
        np.empty(nd, np.int16),  # running horizontal box sum of the row entering the block
        np.empty(nd, np.int16),  # and of the row leaving it
        np.empty((w1, nd), np.int16),  # block costs C
        np.empty((w1, nd + 2), np.int16),  # the top path, padded
        np.empty(w1, np.int16),  # its minima
        np.empty(nd, np.int16),  # one top row being made
        np.empty((w1, nd), np.int16),  # left + top path sums
        np.empty((2, nd + 2), np.int16),  # the left path, two rows, padded
        np.empty((2, nd + 2), np.int16),  # the right path, two rows, padded
        np.empty(nd, np.int16),  # the summed costs of one pixel
        np.empty(w, np.int16),  # the reverse map of one row
        np.empty(w, np.int16),  # its costs
    )
