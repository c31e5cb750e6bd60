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

from scenespeak.spatial.forces._jit import jit

# As in _sweep (the reference's _TAYLOR_RATIO).
TAYLOR_RATIO = 1e-3


@jit
def _vs(pts: np.ndarray, k: int, cs: tuple[float, float]) -> tuple[float, float]:
    """``(v, s)`` of vertex k for direction ``cs = (cos θ, sin θ)`` (across, along the lines)."""
    c, s = cs
    return pts[k, 1] * c - pts[k, 0] * s, pts[k, 0] * c + pts[k, 1] * s


@jit
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


@jit
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


@jit
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


@jit
def _step(k: int, step: int, lo_g: int, hi_g: int) -> int:
    """The next vertex along a chain: ``k + step`` cyclically in ``lo_g:hi_g``."""
    k += step
    if k >= hi_g:
        return lo_g
    if k < lo_g:
        return hi_g - 1
    return k


@jit
def _psi2(u: float) -> float:
    """Ψ of gravitational forces, ``u - u log u`` (0 at u = 0)."""
    return u - u * math.log(u) if u > 0.0 else 0.0


@jit
def _edge(
    pts: np.ndarray,
    cs: tuple[float, float],
    r: tuple[int, int, int, int],
    step: int,
    shift: tuple[float, float],
    at: tuple[int, float, float],
) -> tuple[float, float, int, float, float, float]:
    """The chain's edge from the breakpoint ``at = (vertex, v, s)`` (shifted by ``shift``):
    ``(v, s, next vertex, its v, its s, ds/dv)``, the next ``v`` at least ``v`` (the running
    maximum that keeps a chain's breakpoints in order)."""
    k, v, s = at
    n = _step(k, step, r[0], r[1])
    vn, sn = _vs(pts, n, cs)
    vn = max(vn + shift[0], v)
    sn += shift[1]
    return v, s, n, vn, sn, (sn - s) / (vn - v) if vn > v else 0.0


@jit
def _first_edge(
    pts: np.ndarray,
    cs: tuple[float, float],
    r: tuple[int, int, int, int],
    step: int,
    shift: tuple[float, float],
    t: float,
) -> tuple[float, float, int, float, float, float]:
    """:func:`_edge` of the chain's edge whose range of lines holds ``t`` (from the lowest
    vertex up; the slope computed for that edge only)."""
    k = r[2]
    v, s = _vs(pts, k, cs)
    v += shift[0]
    s += shift[1]
    while True:
        n = _step(k, step, r[0], r[1])
        if n == r[3]:
            break
        vn = max(_vs(pts, n, cs)[0] + shift[0], v)
        if vn > t:
            break
        k, v, s = n, vn, _vs(pts, n, cs)[1] + shift[1]
    return _edge(pts, cs, r, step, shift, (k, v, s))


@jit
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


@jit
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


@jit
def chain_pair(
    pts: np.ndarray,
    cs: tuple[float, float],
    regions: tuple[tuple[int, int, int, int], tuple[int, int, int, int]],
    steps: tuple[int, int],
    starts: tuple[tuple[float, float, int, float, float, float], ...],
    shift: tuple[float, float],
    span: tuple[float, float],
) -> tuple[float, float, float, float]:
    """``(F0(θ) * 6, F2(θ), F0(θ + π) * 6, F2(θ + π))`` of one chain of A and one of B.

    ``regions = (ra, rb)``, ``ra = (lo_g, hi_g, lowest, highest)`` of region A (vertices
    ``lo_g:hi_g``, its lowest and highest vertex in this direction); ``steps = (step_a,
    step_b)``, +1 for a right chain, -1 for a left one (also the sign of its edges);
    ``starts`` each chain's :func:`_first_edge` at ``t``; B shifted into A's frame by
    ``shift = (dv, ds)``; ``span = (t, t_end)`` the lines that meet both regions.
    """
    ra, rb = regions
    step_a, step_b = steps
    t, t_end = span
    sign = float(step_a * step_b)
    # Each chain's current edge: from (v, s) to vertex n at (vn, sn), slope k = ds/dv.
    va, sa, na, vna, sna, ka = starts[0]
    vb, sb, nb, vnb, snb, kb = starts[1]
    d = (sa + ka * (t - va)) - (sb + kb * (t - vb))
    psi = 0.0  # Ψ(|d|) when known
    known = False
    f0p = 0.0
    f2p = 0.0
    f0n = 0.0
    f2n = 0.0
    while True:
        tn = min(vna, vnb, t_end)
        xa = sna if tn == vna else sa + ka * (tn - va)
        xb = snb if tn == vnb else sb + kb * (tn - vb)
        dn = xa - xb
        x0, x2, y0, y2, psi, known = _interval(d, dn, sign * (t - tn), (psi, known and tn > t))
        f0p += x0
        f2p += x2
        f0n += y0
        f2n += y2
        if tn >= t_end:
            break
        if vna <= tn:
            va, sa, na, vna, sna, ka = _edge(pts, cs, ra, step_a, (0.0, 0.0), (na, vna, sna))
        if vnb <= tn:
            vb, sb, nb, vnb, snb, kb = _edge(pts, cs, rb, step_b, shift, (nb, vnb, snb))
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
) -> tuple[float, float, float, float]:
    """F0 and F2 of two convex regions in one direction: the four chain pairs.

    Returns ``(F0(θ), F2(θ), F0(θ + π), F2(θ + π))``, as ``_sweep._walk_f0_f2``.
    """
    t_end = min(_vs(pts, ra[3], cs)[0], _vs(pts, rb[3], cs)[0] + shift[0])
    t = max(_vs(pts, ra[2], cs)[0], _vs(pts, rb[2], cs)[0] + shift[0])
    if not t_end > t:
        return 0.0, 0.0, 0.0, 0.0
    none = (0.0, 0.0)
    # The four chains' edges at t: the same for both merges a chain takes part in.
    a_right = _first_edge(pts, cs, ra, 1, none, t)
    a_left = _first_edge(pts, cs, ra, -1, none, t)
    b_right = _first_edge(pts, cs, rb, 1, shift, t)
    b_left = _first_edge(pts, cs, rb, -1, shift, t)
    rs = (ra, rb)
    span = (t, t_end)
    x = chain_pair(pts, cs, rs, (1, 1), (a_right, b_right), shift, span)
    y = chain_pair(pts, cs, rs, (1, -1), (a_right, b_left), shift, span)
    z = chain_pair(pts, cs, rs, (-1, 1), (a_left, b_right), shift, span)
    w = chain_pair(pts, cs, rs, (-1, -1), (a_left, b_left), shift, span)
    t0 = ((x[0] + y[0]) + z[0]) + w[0]
    t2 = ((x[1] + y[1]) + z[1]) + w[1]
    p0 = ((x[2] + y[2]) + z[2]) + w[2]
    p2 = ((x[3] + y[3]) + z[3]) + w[3]
    return t0 / 6.0, t2, p0 / 6.0, p2
