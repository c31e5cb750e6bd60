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
instead of two. The terms are those of :func:`~scenespeak.spatial.forces._sweep._f0_f2_terms`
(Matsakis & Wendling 1999; ``docs/forces.md``), the sums the same up to rounding.

The breakpoints of a chain are its vertices' ``v``, made non-decreasing by a running maximum:
rounding can put two nearly level vertices one ulp out of order, which would otherwise give an
interval of negative length.
"""

from __future__ import annotations

import math

import numpy as np

from scenespeak.spatial.forces._jit import jit, jit_inline

# As in _sweep (the reference's _TAYLOR_RATIO).
TAYLOR_RATIO = 1e-3


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
def _psi2(u: float) -> float:
    """Ψ of gravitational forces, ``u - u log u`` (0 at u = 0)."""
    return u - u * math.log(u) if u > 0.0 else 0.0


@jit_inline
def _chain(
    pts: np.ndarray,
    cs: tuple[float, float],
    r: tuple[int, int, int, int],
    step: int,
    shift: tuple[float, float],
    span: tuple[float, float],
    out: np.ndarray,
) -> None:
    """One chain's breakpoints over the lines ``span = (t, t_end)``, into ``out`` (3 rows).

    ``out[0, i]``, ``out[1, i]``: ``v`` and ``s`` of the chain's i-th breakpoint, from the
    start of the edge whose range of lines holds ``t`` to the first vertex at or above
    ``t_end`` (``v`` made non-decreasing by a running maximum, B shifted into A's frame by
    ``shift``); ``out[2, i]``: the slope ``ds/dv`` of edge i (0 for an edge of no height).
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
    out[0, 0] = v
    out[1, 0] = s
    m = 0
    while True:
        n = _step(k, step, r[0], r[1])
        vn, sn = _vs(pts, n, cs)
        vn = max(vn + shift[0], v)
        sn += shift[1]
        out[2, m] = (sn - s) / (vn - v) if vn > v else 0.0
        m += 1
        out[0, m] = vn
        out[1, m] = sn
        if n == r[3] or vn >= t_end:
            return
        k, v, s = n, vn, sn


@jit_inline
def _same_side_f2(
    a0: float, a1: float, weight: float, psi: tuple[float, bool]
) -> tuple[float, float, bool]:
    """``(F2 term, Ψ(a1), whether it was computed)``: ``weight`` times the mean of Φ⁺ = -log
    over a gap going from a0 to a1 (absolute values, same sign; ``_sweep._mean_f2``), with
    ``psi = (Ψ(a0), known)`` from the previous interval."""
    h = a1 - a0
    m = 0.5 * (a0 + a1)
    if abs(h) <= TAYLOR_RATIO * m:
        if m > 0.0:
            return weight * (-math.log(m) + (1.0 / (m * m)) * h * h / 24.0), 0.0, False
        return 0.0, 0.0, False
    p0 = psi[0] if psi[1] else _psi2(a0)
    p1 = _psi2(a1)
    return weight * ((p1 - p0) / h), p1, True


@jit_inline
def _interval(
    d: float, dn: float, weight: float, psi: tuple[float, bool]
) -> tuple[float, float, float, float, float, bool]:
    """``(6 F0(θ), F2(θ), 6 F0(θ + π), F2(θ + π), Ψ(|dn|), known)`` of one interval whose gap
    goes linearly from ``d`` to ``dn`` (``_sweep._f0_f2_terms``), ``psi = (Ψ(|d|), known)``;
    nothing for an interval of zero length (``weight`` 0)."""
    if weight == 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, False
    if d * dn < 0.0:  # the gap changes sign: split at its zero
        p0 = psi[0] if psi[1] else _psi2(abs(d))
        p1 = _psi2(abs(dn))
        total = abs(d) + abs(dn)
        top = d if d > dn else dn
        bottom = dn if d > dn else d
        frac = top / total
        f0p = weight * frac * (top * top)
        f0n = weight * (1.0 - frac) * (bottom * bottom)
        f2p = weight * ((p0 if d > dn else p1) / total)
        f2n = weight * ((p1 if d > dn else p0) / total)
        return f0p, f2p, f0n, f2n, p1, True
    a0 = abs(d)
    a1 = abs(dn)
    f0 = weight * (a0 * a0 + a0 * a1 + a1 * a1)
    f2, p1, known = _same_side_f2(a0, a1, weight, psi)
    if d + dn < 0.0:
        return 0.0, 0.0, f0, f2, p1, known
    return f0, f2, 0.0, 0.0, p1, known


@jit_inline
def chain_pair(
    ca: np.ndarray, cb: np.ndarray, sign: float, span: tuple[float, float]
) -> tuple[float, float, float, float]:
    """``(F0(θ) * 6, F2(θ), F0(θ + π) * 6, F2(θ + π))`` of one chain of A and one of B.

    ``ca``, ``cb``: the chains' breakpoints and slopes (:func:`_chain`, B in A's frame);
    ``sign``: the product of the chains' signs (+1 for a right chain, -1 for a left one);
    ``span = (t, t_end)`` the lines that meet both regions. The merge advances each chain by
    a comparison added to its index, not by a branch: which chain breaks next is as good as
    random, and a mispredicted branch per interval cost more than the interval's arithmetic.
    """
    t, t_end = span
    i = 0
    j = 0
    d = (ca[1, 0] + ca[2, 0] * (t - ca[0, 0])) - (cb[1, 0] + cb[2, 0] * (t - cb[0, 0]))
    psi = 0.0  # Ψ(|d|) when known
    known = False
    f0p = 0.0
    f2p = 0.0
    f0n = 0.0
    f2n = 0.0
    while True:
        vna = ca[0, i + 1]
        vnb = cb[0, j + 1]
        tn = min(vna, vnb, t_end)
        xa = ca[1, i + 1] if tn == vna else ca[1, i] + ca[2, i] * (tn - ca[0, i])
        xb = cb[1, j + 1] if tn == vnb else cb[1, j] + cb[2, j] * (tn - cb[0, j])
        dn = xa - xb
        x0, x2, y0, y2, psi, known = _interval(d, dn, sign * (t - tn), (psi, known and tn > t))
        f0p += x0
        f2p += x2
        f0n += y0
        f2n += y2
        if tn >= t_end:
            break
        i += vna <= tn
        j += vnb <= tn
        t = tn
        d = dn
    return f0p, f2p, f0n, f2n


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

    ``scratch``: at least ``(4, 3, n + 1)`` floats, ``n`` the larger region's vertex count.
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
        _chain(pts, cs, regions[k], steps[k], shifts[k], span, scratch[k])
    merges = ((0, 2), (0, 3), (1, 2), (1, 3))
    t0 = 0.0
    t2 = 0.0
    p0 = 0.0
    p2 = 0.0
    for k in range(4):
        i, j = merges[k]
        x = chain_pair(scratch[i], scratch[j], float(steps[i] * steps[j]), span)
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
    size = max(region_start[1] - region_start[0], region_start[2] - region_start[1])
    scratch = np.empty((4, 3, size + 1))
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
