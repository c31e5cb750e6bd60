"""F0 + F2 of two convex regions in one direction by merging their boundary chains (private;
compiled by Numba).

For a direction θ, a convex polygon's boundary splits at its lowest and highest vertex (in
``v``, across the lines) into two chains, each monotone in ``v``: the right chain, where the
lines leave the polygon (edges traversed forward, ``dv > 0``, sign +1), and the left chain,
where they enter it (traversed backward from the lowest vertex, sign -1). The edge pairs of
two convex regions whose ranges of lines overlap are exactly the intervals of the merged
breakpoints of one chain of A and one chain of B, four chain pairs in all. No table is sorted
(the chains are sorted by construction), and consecutive intervals share a breakpoint, so the
gap ``d`` and ``Ψ(|d|)`` at each breakpoint are computed once: one logarithm per edge pair
instead of two. The terms are the general sweep's (``_sweep``, ``_batch``; Matsakis & Wendling
1999; ``docs/forces.md``), the sums the same up to rounding. Each merge runs in three passes
(:func:`chain_pair`): the merge alone, then the logarithms and the interval terms in loops the
compiler vectorises, then the sums in interval order.

The breakpoints of a chain are its vertices' ``v``, made non-decreasing by a running maximum:
rounding can put two nearly level vertices one ulp out of order, which would otherwise give an
interval of negative length.
"""

from __future__ import annotations

import numpy as np

from scenespeak.spatial.forces._jit import jit, jit_inline

# As in _sweep (the reference's _TAYLOR_RATIO).
TAYLOR_RATIO = 1e-3
LN2 = 0.6931471805599453
# The bits of sqrt(1/2) and of a float64's mantissa (_logs reduces to [sqrt(1/2), sqrt(2))).
_SQRT_HALF_BITS = 0x3FE6A09E667F3BCD
_MANTISSA = 0x000FFFFFFFFFFFFF
# Rows of chain_scratch after the four chains' 12: a merge's gaps, widths, logarithms, the
# bits of the reduced arguments, and four rows of terms.
GAP = 12
WIDTH = 13
LOG = 14
BITS = 15
TERMS = 16


@jit_inline
def _vs(pts: np.ndarray, k: int, cs: tuple[float, float]) -> tuple[float, float]:
    """``(v, s)`` of vertex k for direction ``cs = (cos θ, sin θ)`` (across, along the lines)."""
    c, s = cs
    return pts[k, 1] * c - pts[k, 0] * s, pts[k, 0] * c + pts[k, 1] * s


@jit_inline
def _descend(pts: np.ndarray, k: int, cs: tuple[float, float], r: tuple[int, int], up: bool) -> int:
    """From vertex k, the neighbouring vertices while ``v`` falls (rises if ``up``): the
    lowest (highest) vertex of a convex ring in ``lo_g:hi_g = r`` from a vertex near it."""
    sign = -1.0 if up else 1.0
    v = sign * _vs(pts, k, cs)[0]
    while True:
        n = _step(k, 1, r[0], r[1])
        vn = sign * _vs(pts, n, cs)[0]
        if vn < v:
            k, v = n, vn
            continue
        n = _step(k, -1, r[0], r[1])
        vn = sign * _vs(pts, n, cs)[0]
        if vn < v:
            k, v = n, vn
            continue
        return k


@jit_inline
def _lowest_highest(
    pts: np.ndarray, cs: tuple[float, float], r: tuple[int, int]
) -> tuple[int, int]:
    """The first lowest and first highest vertex of ``lo_g:hi_g = r`` (every vertex looked at)."""
    lo = r[0]
    hi = r[0]
    v_lo = _vs(pts, lo, cs)[0]
    v_hi = v_lo
    for k in range(r[0] + 1, r[1]):
        v = _vs(pts, k, cs)[0]
        if v < v_lo:
            lo, v_lo = k, v
        if v > v_hi:
            hi, v_hi = k, v
    return lo, hi


@jit_inline
def track_extremes(
    cs: tuple[float, float],
    pts: np.ndarray,
    region_start: np.ndarray,
    chained: np.ndarray,
    scratch: tuple[np.ndarray, np.ndarray],
    first: bool,
) -> None:
    """The lowest and highest vertex (``low_high[g]``) and their ``v`` (``extent[g]``) of every
    region with ``chained[g]``, ``scratch = (low_high, extent)``: every vertex looked at in
    the first direction, then a walk from the previous direction's (they move by about
    ``n / directions`` vertices from one direction to the next; a level run of vertices,
    parallel to the lines, lies only at the lowest or highest ``v`` of a convex ring, so the
    walk cannot stop inside one elsewhere)."""
    low_high, extent = scratch
    for g in range(region_start.size - 1):
        if not chained[g]:
            continue
        r = (region_start[g], region_start[g + 1])
        if first:  # every vertex (a walk could stop inside a level run of vertices)
            low_high[g, 0], low_high[g, 1] = _lowest_highest(pts, cs, r)
        else:
            low_high[g, 0] = _descend(pts, low_high[g, 0], cs, r, False)
            low_high[g, 1] = _descend(pts, low_high[g, 1], cs, r, True)
        extent[g, 0] = _vs(pts, low_high[g, 0], cs)[0]
        extent[g, 1] = _vs(pts, low_high[g, 1], cs)[0]


@jit_inline
def _step(k: int, step: int, lo_g: int, hi_g: int) -> int:
    """The next vertex along a chain: ``k + step`` cyclically in ``lo_g:hi_g``."""
    k += step
    if k >= hi_g:
        return lo_g
    if k < lo_g:
        return hi_g - 1
    return k


@jit_inline
def _chain(
    pts: np.ndarray,
    cs: tuple[float, float],
    r: tuple[int, int, int, int],
    step: int,
    shift: tuple[float, float],
    span: tuple[float, float],
    out: np.ndarray,
    row: int,
) -> None:
    """One chain's breakpoints over the lines ``span = (t, t_end)``, into rows ``row:row + 3``
    of ``out`` (rows, not views of them: a view costs two atomic reference counts).

    ``out[row, i]``, ``out[row + 1, i]``: ``v`` and ``s`` of the chain's i-th breakpoint, from the
    start of the edge whose range of lines holds ``t`` to the first vertex at or above
    ``t_end`` (``v`` made non-decreasing by a running maximum, B shifted into A's frame by
    ``shift``); ``out[row + 2, i]``: the slope ``ds/dv`` of edge i (0 for an edge of no height).
    Each edge's slope is computed once per direction, for both merges the chain takes part in.
    """
    t, t_end = span
    k = r[2]
    v, s = _vs(pts, k, cs)
    v += shift[0]
    s += shift[1]
    while True:  # to the edge whose range of lines holds t
        n = _step(k, step, r[0], r[1])
        if n == r[3]:
            break
        vn = max(_vs(pts, n, cs)[0] + shift[0], v)
        if vn > t:
            break
        k, v, s = n, vn, _vs(pts, n, cs)[1] + shift[1]
    out[row, 0] = v
    out[row + 1, 0] = s
    m = 0
    while True:
        n = _step(k, step, r[0], r[1])
        vn, sn = _vs(pts, n, cs)
        vn = max(vn + shift[0], v)
        sn += shift[1]
        out[row + 2, m] = (sn - s) / (vn - v) if vn > v else 0.0
        m += 1
        out[row, m] = vn
        out[row + 1, m] = sn
        if n == r[3] or vn >= t_end:
            return
        k, v, s = n, vn, sn


@jit_inline
def _logs(buf: np.ndarray, ints: np.ndarray, n: int) -> None:
    """``buf[LOG, k] = log(max(|buf[GAP, k]|, 1e-300))`` for ``k < n``, in loops the compiler
    vectorises (the C library's ``log`` is one call per value): ``x = 2**e * m`` with ``m`` in
    ``[sqrt(1/2), sqrt(2))`` from the bits (``ints``, the same memory as int64), ``log m = 2
    atanh(f)``, ``f = (m - 1) / (m + 1)``, by its series to ``f**23`` (``|f| <= 0.172``:
    truncation below 1e-18; within 3e-16 of ``math.log`` relative)."""
    for k in range(n):
        u = abs(buf[GAP, k])
        b = ints[GAP, k] & 0x7FFFFFFFFFFFFFFF
        b = b if u > 1e-300 else np.int64(0x01A56E1FC2F8F359)  # the bits of 1e-300
        t = b - _SQRT_HALF_BITS
        ints[BITS, k] = (t & _MANTISSA) + _SQRT_HALF_BITS
        buf[LOG, k] = float(t >> 52)
    for k in range(n):
        m = buf[BITS, k]
        f = (m - 1.0) / (m + 1.0)
        s = f * f
        p = 1.0 / 21.0 + s * (1.0 / 23.0)
        p = 1.0 / 19.0 + s * p
        p = 1.0 / 17.0 + s * p
        p = 1.0 / 15.0 + s * p
        p = 1.0 / 13.0 + s * p
        p = 1.0 / 11.0 + s * p
        p = 1.0 / 9.0 + s * p
        p = 1.0 / 7.0 + s * p
        p = 1.0 / 5.0 + s * p
        p = 1.0 / 3.0 + s * p
        buf[LOG, k] = buf[LOG, k] * LN2 + (2.0 * f + 2.0 * f * (s * p))


@jit_inline
def _merge(buf: np.ndarray, rows: tuple[int, int], span: tuple[float, float]) -> int:
    """Merge one chain of A and one of B: the gap at every breakpoint into ``buf[GAP]``
    (``buf[GAP, q]`` at the start of interval q, ``buf[GAP, n]`` at the end of the last), each
    interval's ``t_q - t_(q+1)`` (<= 0) into ``buf[WIDTH]``; returns the number of intervals.

    ``rows = (ra, rb)``: the chains' first rows in ``buf`` (:func:`_chain`, B in A's frame);
    ``span = (t, t_end)`` the lines that meet both regions. Each chain advances by a comparison
    added to its index, not by a branch: which chain breaks next is as good as random, and a
    mispredicted branch per interval cost more than the interval's arithmetic.
    """
    t, t_end = span
    ra, rb = rows
    i = 0
    j = 0
    buf[GAP, 0] = (buf[ra + 1, 0] + buf[ra + 2, 0] * (t - buf[ra, 0])) - (
        buf[rb + 1, 0] + buf[rb + 2, 0] * (t - buf[rb, 0])
    )
    q = 0
    while True:
        vna = buf[ra, i + 1]
        vnb = buf[rb, j + 1]
        tn = min(vna, vnb, t_end)
        xa = (
            buf[ra + 1, i + 1] if tn == vna else buf[ra + 1, i] + buf[ra + 2, i] * (tn - buf[ra, i])
        )
        xb = (
            buf[rb + 1, j + 1] if tn == vnb else buf[rb + 1, j] + buf[rb + 2, j] * (tn - buf[rb, j])
        )
        buf[WIDTH, q] = t - tn
        q += 1
        buf[GAP, q] = xa - xb
        if tn >= t_end:
            return q
        i += vna <= tn
        j += vnb <= tn
        t = tn


@jit_inline
def _mean_f2(a: tuple[float, float], logs: tuple[float, float], psi: tuple[float, float]) -> float:
    """The mean of Φ⁺ = -log over a gap going linearly from ``a[0]`` to ``a[1]`` (same sign,
    absolute values), from their logarithms and ``Ψ``: the divided difference of ``Ψ``, or its
    series where ``|h| <= 1e-3 m`` (see :func:`_terms`); selects only, no branch."""
    h = a[1] - a[0]
    m = 0.5 * (a[0] + a[1])
    mm = m if m > 0.0 else 1.0
    hh = h if h != 0.0 else 1.0
    x2 = (h * h) / (4.0 * (mm * mm))
    log_m = 0.5 * (logs[0] + logs[1]) + x2 * (0.5 + 0.25 * x2)
    mean = -log_m + x2 / 6.0 if abs(h) <= TAYLOR_RATIO * m else (psi[1] - psi[0]) / hh
    return mean if m > 0.0 else 0.0


@jit_inline
def _crossing(
    d: float, dn: float, w: float, psi: tuple[float, float]
) -> tuple[float, float, float, float]:
    """The terms of an interval whose gap goes from ``d`` to ``dn`` through zero, split there:
    ``(6 F0(θ), F2(θ), 6 F0(θ + π), F2(θ + π))``, ``psi = (Ψ(|d|), Ψ(|dn|))`` (selects
    only; finite whatever the signs, used only when ``d * dn < 0``)."""
    cross = d * dn < 0.0
    inv = 1.0 / (abs(d) + abs(dn) if cross else 1.0)
    top = d if d > dn else dn
    bottom = dn if d > dn else d
    frac = top * inv
    return (
        w * frac * (top * top),
        w * ((psi[0] if d > dn else psi[1]) * inv),
        w * (1.0 - frac) * (bottom * bottom),
        w * ((psi[1] if d > dn else psi[0]) * inv),
    )


@jit_inline
def _terms(buf: np.ndarray, n: int, sign: float) -> None:
    """Each interval's ``6 F0(θ), F2(θ), 6 F0(θ + π), F2(θ + π)`` into ``buf[TERMS:TERMS + 4,
    q]`` (the general sweep's F0 + F2 terms; Matsakis & Wendling 1999) from the gaps ``buf[GAP]``,
    the widths ``buf[WIDTH]`` and ``log |gap|`` in ``buf[LOG]``, with selects instead of
    branches so that the loop is vectorised. ``sign``: the product of the chains' signs.

    A gap going from ``d`` to ``dn`` (absolute values ``a0``, ``a1``, ``h = a1 - a0``,
    ``m = (a0 + a1) / 2``) on one side of zero gives ``w (a0² + a0 a1 + a1²)`` and ``w (Ψ(a1) -
    Ψ(a0)) / h`` with ``Ψ(u) = u - u log u``, or for ``|h| <= 1e-3 m`` the series ``w (-log m +
    h² / (24 m²))`` with ``log m = (log a0 + log a1) / 2 + x² / 2 + x⁴ / 4``, ``x = h / (2m)``
    (``log(1 - x²) = -x² - x⁴ / 2 - ...``); a gap changing sign is split at its zero.
    """
    for q in range(n):
        d = buf[GAP, q]
        dn = buf[GAP, q + 1]
        w = sign * buf[WIDTH, q]
        a0 = abs(d)
        a1 = abs(dn)
        logs = (buf[LOG, q], buf[LOG, q + 1])
        psi = (a0 - a0 * logs[0], a1 - a1 * logs[1])
        f0 = w * (a0 * a0 + a0 * a1 + a1 * a1)
        f2 = w * _mean_f2((a0, a1), logs, psi)
        c0p, c2p, c0n, c2n = _crossing(d, dn, w, psi)
        cross = d * dn < 0.0
        neg = d + dn < 0.0
        buf[TERMS, q] = c0p if cross else (0.0 if neg else f0)
        buf[TERMS + 1, q] = c2p if cross else (0.0 if neg else f2)
        buf[TERMS + 2, q] = c0n if cross else (f0 if neg else 0.0)
        buf[TERMS + 3, q] = c2n if cross else (f2 if neg else 0.0)


@jit_inline
def chain_pair(
    buf: np.ndarray, ints: np.ndarray, rows: tuple[int, int], sign: float, span: tuple[float, float]
) -> tuple[float, float, float, float]:
    """``(F0(θ) * 6, F2(θ), F0(θ + π) * 6, F2(θ + π))`` of one chain of A and one of B.

    ``buf``: :func:`chain_scratch` (``ints`` the same memory as int64) holding the chains at
    ``rows`` (:func:`_chain`); ``sign``: the product of their signs (+1 for a right chain, -1
    for a left one); ``span = (t, t_end)``. Three passes: the merge (sequential), the
    logarithms and the interval terms (vectorised), then the sums in interval order.
    """
    n = _merge(buf, rows, span)
    _logs(buf, ints, n + 1)
    _terms(buf, n, sign)
    f0p = 0.0
    f2p = 0.0
    f0n = 0.0
    f2n = 0.0
    for q in range(n):
        f0p += buf[TERMS, q]
        f2p += buf[TERMS + 1, q]
        f0n += buf[TERMS + 2, q]
        f2n += buf[TERMS + 3, q]
    return f0p, f2p, f0n, f2n


@jit_inline
def chain_scratch(region_start: np.ndarray) -> np.ndarray:
    """Scratch for :func:`walk_convex` on regions ``region_start[g]:region_start[g + 1]``: four
    chains of 3 rows, then the rows ``GAP`` to ``TERMS + 3`` of a merge, each row as long as
    two chains (a merge has at most both chains' breakpoints)."""
    size = np.diff(region_start).max()
    return np.empty((TERMS + 4, 2 * size + 3))


@jit
def walk_convex(
    pts: np.ndarray,
    cs: tuple[float, float],
    ra: tuple[int, int, int, int],
    rb: tuple[int, int, int, int],
    shift: tuple[float, float],
    scratch: np.ndarray,
) -> tuple[float, float, float, float]:
    """F0 and F2 of two convex regions in one direction: the four chain pairs.

    ``scratch``: :func:`chain_scratch` of the larger region's vertex count.
    Returns ``(F0(θ), F2(θ), F0(θ + π), F2(θ + π))``, as ``_sweep._walk_f0_f2``.
    """
    t_end = min(_vs(pts, ra[3], cs)[0], _vs(pts, rb[3], cs)[0] + shift[0])
    t = max(_vs(pts, ra[2], cs)[0], _vs(pts, rb[2], cs)[0] + shift[0])
    if not t_end > t:
        return 0.0, 0.0, 0.0, 0.0
    none = (0.0, 0.0)
    span = (t, t_end)
    # The four chains from their edges at t (A right, A left, B right, B left), each used in
    # two merges; loops over them so that the inlined bodies are compiled once.
    regions = (ra, ra, rb, rb)
    steps = (1, -1, 1, -1)
    shifts = (none, none, shift, shift)
    for k in range(4):
        _chain(pts, cs, regions[k], steps[k], shifts[k], span, scratch, 3 * k)
    ints = scratch.view(np.int64)
    merges = ((0, 2), (0, 3), (1, 2), (1, 3))
    t0 = 0.0
    t2 = 0.0
    p0 = 0.0
    p2 = 0.0
    for k in range(4):
        i, j = merges[k]
        x = chain_pair(scratch, ints, (3 * i, 3 * j), float(steps[i] * steps[j]), span)
        t0 += x[0]
        t2 += x[1]
        p0 += x[2]
        p2 += x[3]
    return t0 / 6.0, t2, p0 / 6.0, p2


@jit
def convex_pair(
    regions: tuple[np.ndarray, np.ndarray, np.ndarray], table: np.ndarray
) -> np.ndarray:
    """F0 and F2 of two convex regions, shape ``(2, directions)``: what
    :func:`~scenespeak.spatial.forces._sweep.sweep` gives for this one pair (the same
    operations, so the same floats), without its edge tables and general pair loop.

    ``regions = (pts, region_start, origin)`` as for ``sweep`` with two regions, both convex and
    counter-clockwise; ``table[d] = (cos θ, sin θ)`` with ``θ = 2π d / directions``, one row
    per direction (:func:`~scenespeak.spatial.forces.kernel.direction_table`).
    """
    pts, region_start, origin = regions
    directions = table.shape[0]
    both = directions % 2 == 0
    half = directions // 2 if both else directions
    out = np.zeros((2, directions))
    chained = np.ones(2, dtype=np.bool_)
    low_high = np.zeros((2, 2), dtype=np.int64)
    extent = np.empty((2, 2))
    scratch = chain_scratch(region_start)
    ox = origin[1, 0] - origin[0, 0]
    oy = origin[1, 1] - origin[0, 1]
    for d in range(half):
        c = table[d, 0]
        s = table[d, 1]
        track_extremes((c, s), pts, region_start, chained, (low_high, extent), d == 0)
        dvb = oy * c - ox * s
        if extent[0, 1] < extent[1, 0] + dvb or extent[1, 1] + dvb < extent[0, 0]:
            continue  # no line of this direction meets both objects
        t0, t2, q0, q2 = walk_convex(
            pts,
            (c, s),
            (region_start[0], region_start[1], low_high[0, 0], low_high[0, 1]),
            (region_start[1], region_start[2], low_high[1, 0], low_high[1, 1]),
            (dvb, ox * c + oy * s),
            scratch,
        )
        out[0, d] += t0
        out[1, d] += t2
        if both:
            out[0, d + half] += q0
            out[1, d + half] += q2
    return out
