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
def project_vertices(
    c: float, s: float, pts: np.ndarray, lo_g: int, hi_g: int, pv: np.ndarray, ps: np.ndarray
) -> tuple[int, int]:
    """``pv[k]``, ``ps[k]`` (across / along the lines) of vertices ``lo_g:hi_g`` for direction
    (c, s); returns the indices of the lowest and the highest vertex (first of equals)."""
    imin = lo_g
    imax = lo_g
    for k in range(lo_g, hi_g):
        x = pts[k, 0]
        y = pts[k, 1]
        v = y * c - x * s
        pv[k] = v
        ps[k] = x * c + y * s
        if v < pv[imin]:
            imin = k
        if v > pv[imax]:
            imax = k
    return imin, imax


@jit
def project_chained(
    c: float,
    s: float,
    pts: np.ndarray,
    region_start: np.ndarray,
    chained: np.ndarray,
    scratch: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """:func:`project_vertices` of every region with ``chained[g]``: ``scratch = (pv, ps,
    low_high, extent)``, ``low_high[g]`` its lowest and highest vertex, ``extent[g]`` their
    ``v`` (the same floats as the edge table's range)."""
    pv, ps, low_high, extent = scratch
    for g in range(region_start.size - 1):
        if chained[g]:
            lo, hi = project_vertices(c, s, pts, region_start[g], region_start[g + 1], pv, ps)
            low_high[g, 0] = lo
            low_high[g, 1] = hi
            extent[g, 0] = pv[lo]
            extent[g, 1] = pv[hi]


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
    pv: np.ndarray,
    ps: np.ndarray,
    r: tuple[int, int, int, int],
    step: int,
    shift: tuple[float, float],
    at: tuple[int, float, float],
) -> tuple[float, float, int, float, float, float]:
    """The chain's edge from the breakpoint ``at = (vertex, v, s)`` (shifted by ``shift``):
    ``(v, s, next vertex, its v, its s, ds/dv)``, the next ``v`` at least ``v`` (the running
    maximum that keeps a chain's breakpoints in order)."""
    lo_g, hi_g = r[0], r[1]
    k, v, s = at
    n = _step(k, step, lo_g, hi_g)
    vn = max(pv[n] + shift[0], v)
    sn = ps[n] + shift[1]
    return v, s, n, vn, sn, (sn - s) / (vn - v) if vn > v else 0.0


@jit
def _first_edge(
    pv: np.ndarray,
    ps: np.ndarray,
    r: tuple[int, int, int, int],
    step: int,
    shift: tuple[float, float],
    t: float,
) -> tuple[float, float, int, float, float, float]:
    """:func:`_edge` of the chain's edge whose range of lines holds ``t`` (from the lowest
    vertex up)."""
    k = r[2]
    e = _edge(pv, ps, r, step, shift, (k, pv[k] + shift[0], ps[k] + shift[1]))
    while e[3] <= t and e[2] != r[3]:
        e = _edge(pv, ps, r, step, shift, (e[2], e[3], e[4]))
    return e


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
    pv: np.ndarray,
    ps: np.ndarray,
    ra: tuple[int, int, int, int],
    step_a: int,
    rb: tuple[int, int, int, int],
    step_b: int,
    shift: tuple[float, float],
) -> tuple[float, float, float, float]:
    """``(F0(θ) * 6, F2(θ), F0(θ + π) * 6, F2(θ + π))`` of one chain of A and one of B.

    ``ra = (lo_g, hi_g, lowest, highest)`` of region A (vertices ``lo_g:hi_g``, its lowest
    and highest vertex in this direction); ``step_a`` +1 for the right chain, -1 for the left
    one (also the sign of its edges). B likewise, shifted into A's frame by ``shift = (dv,
    ds)``.
    """
    t_end = min(pv[ra[3]], pv[rb[3]] + shift[0])
    t = max(pv[ra[2]], pv[rb[2]] + shift[0])
    if not t_end > t:
        return 0.0, 0.0, 0.0, 0.0
    sign = float(step_a * step_b)
    # Each chain's current edge: from (v, s) to vertex n at (vn, sn), slope k = ds/dv.
    va, sa, na, vna, sna, ka = _first_edge(pv, ps, ra, step_a, (0.0, 0.0), t)
    vb, sb, nb, vnb, snb, kb = _first_edge(pv, ps, rb, step_b, shift, t)
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
            va, sa, na, vna, sna, ka = _edge(pv, ps, ra, step_a, (0.0, 0.0), (na, vna, sna))
        if vnb <= tn:
            vb, sb, nb, vnb, snb, kb = _edge(pv, ps, rb, step_b, shift, (nb, vnb, snb))
        t = tn
        d = dn
    return f0p, f2p, f0n, f2n


@jit
def walk_convex(
    pv: np.ndarray,
    ps: np.ndarray,
    ra: tuple[int, int, int, int],
    rb: tuple[int, int, int, int],
    shift: tuple[float, float],
) -> tuple[float, float, float, float]:
    """F0 and F2 of two convex regions in one direction: the four chain pairs.

    Returns ``(F0(θ), F2(θ), F0(θ + π), F2(θ + π))``, as ``_sweep._walk_f0_f2``.
    """
    t0 = 0.0
    t2 = 0.0
    p0 = 0.0
    p2 = 0.0
    for step_a in (1, -1):
        for step_b in (1, -1):
            x0, x2, y0, y2 = chain_pair(pv, ps, ra, step_a, rb, step_b, shift)
            t0 += x0
            t2 += x2
            p0 += y0
            p2 += y2
    return t0 / 6.0, t2, p0 / 6.0, p2
