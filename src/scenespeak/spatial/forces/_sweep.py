"""The force sweep as plain loops: the body of the compiled kernel (private).

Written in the subset of Python that Numba compiles (:mod:`~scenespeak.spatial.forces.kernel`
compiles it, with an on-disk cache); run by the interpreter it would be correct but very slow,
so without Numba the package uses :mod:`~scenespeak.spatial.forces.reference` instead. The
mathematics are the reference's (Matsakis & Wendling 1999; ``docs/forces.md``): for each
direction, every (edge of A, edge of B) pair whose ranges of lines overlap contributes the
closed-form integral ``w ∫ Φ⁺(s_A(v) - s_B(v)) dv``, a divided difference of ``Ψ``. What
differs is the order of work, chosen for the hardware:

* one direction at a time, all regions and all pairs: each region's edges are projected once
  per direction (not once per pair) into a small table sorted by the lower end of the edge's
  range of lines, kept sorted from one direction to the next by insertion sort (the order
  changes little between neighbouring directions; :mod:`~scenespeak.spatial.forces._table`);
* a pair is skipped before any per-edge work when the two regions' ranges of lines are apart
  in that direction (no line meets both);
* the overlapping edge pairs come from a two-pointer walk over the two sorted tables (each pair
  with an overlap of positive length exactly once), and are integrated on the spot: nothing of
  size "pairs × edges" is ever stored, memory is linear in regions' edges plus pairs' output.

Kernel codes (``codes[k]``): 0 constant forces ``r = 0``; 1 gravitational ``r = 2``; 2 hybrid
F02 ``1 / max(d, y0)**2`` with ``y0`` per pair; 3 any other ``r`` (``rs[k]``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeVar

import numpy as np

from scenespeak.spatial.forces._batch import (
    collect_pairs,
    grown,
    integrate_pairs,
    scratch_jit,
)
from scenespeak.spatial.forces._batch import (
    f0_f2_terms as _f0_f2_terms,  # noqa: F401 - the name other modules' docs use
)
from scenespeak.spatial.forces._convex import chain_scratch, track_extremes, walk_convex
from scenespeak.spatial.forces._jit import jit
from scenespeak.spatial.forces._table import _tables

F = TypeVar("F", bound=Callable[..., object])

# Below this |h| / |m| the divided difference of Ψ is replaced by its Taylor series (the
# reference's _TAYLOR_RATIO).
TAYLOR_RATIO = 1e-3


@jit
def _psi(code: int, r: float, y0: float, u: float) -> float:
    """Ψ(u) for u > 0 (Ψ' = Φ, Φ'' = φ; reference ``_Kernel.psi``)."""
    if code == 0:
        return u * u * u / 6.0
    if code == 1:
        return u - u * math.log(u)
    if code == 2:
        if u <= y0:
            return u * u * u / (6.0 * y0 * y0)
        return u * u / y0 - 0.5 * u - u * math.log(u / y0) - y0 / 3.0
    if r == 1.0:
        return 0.5 * u * u * math.log(u) - 0.25 * u * u
    if r == 3.0:
        return 0.5 * math.log(u)
    return u ** (3.0 - r) / ((1.0 - r) * (2.0 - r) * (3.0 - r))


@jit
def _big_phi(code: int, r: float, y0: float, u: float) -> float:
    """Φ(u) for u > 0 (reference ``_Kernel.big_phi``)."""
    if code == 0:
        return 0.5 * u * u
    if code == 1:
        return -math.log(u)
    if code == 2:
        if u <= y0:
            return u * u / (2.0 * y0 * y0)
        return 2.0 * u / y0 - 1.5 - math.log(u / y0)
    if r == 1.0:
        return u * math.log(u)
    if r == 2.0:
        return -math.log(u)
    return u ** (2.0 - r) / ((1.0 - r) * (2.0 - r))


@jit
def _force(code: int, r: float, y0: float, u: float) -> float:
    """φ(u) = u**-r, or 1 / max(u, y0)**2 (reference ``_Kernel.force``)."""
    if code == 0:
        return 1.0
    if code == 1:
        return 1.0 / (u * u)
    if code == 2:
        m = u if u > y0 else y0
        return 1.0 / (m * m)
    return u ** (-r)


@jit
def _mean_phi(code: int, r: float, y0: float, a0: float, a1: float) -> float:
    """Mean of Φ⁺ over an interval where the gap goes linearly from a0 to a1 (>= 0).

    For constant forces the mean of ``u²/2`` is ``(a0² + a0 a1 + a1²) / 6`` exactly (the
    reference's divided difference and Taylor branch, without their rounding).
    """
    if code == 0:
        return (a0 * a0 + a0 * a1 + a1 * a1) / 6.0
    h = a1 - a0
    m = 0.5 * (a0 + a1)
    if abs(h) <= TAYLOR_RATIO * m:
        if m > 0.0:
            return _big_phi(code, r, y0, m) + _force(code, r, y0, m) * h * h / 24.0
        return 0.0
    p0 = _psi(code, r, y0, a0) if a0 > 0.0 else 0.0
    p1 = _psi(code, r, y0, a1) if a1 > 0.0 else 0.0
    return (p1 - p0) / h


@jit
def _collect(
    srt: np.ndarray,
    a0: int,
    a1: int,
    b0: int,
    b1: int,
    dvb: float,
    buf: np.ndarray,
) -> int:
    """The overlapping edge pairs of two regions in one direction, into ``buf`` (two pointers
    over the sorted rows ``srt``; the pairs as row indices).

    Case 1: for each A-edge, the B-edges with ``lo_a <= lo_b < hi_a``; case 2: for each B-edge,
    the A-edges with ``lo_b < lo_a < hi_b``. Every pair whose ranges overlap on a positive
    length is in exactly one of them. Returns the number of pairs, or minus the number needed
    when ``buf`` is too small.
    """
    size = buf.shape[0]
    count = 0
    j = b0
    for i in range(a0, a1):
        lo_a = srt[i, 0]
        hi_a = srt[i, 1]
        while j < b1 and srt[j, 0] + dvb < lo_a:
            j += 1
        jj = j
        while jj < b1 and srt[jj, 0] + dvb < hi_a:
            if count < size:
                buf[count, 0] = i
                buf[count, 1] = jj
            count += 1
            jj += 1
    i = a0
    for j in range(b0, b1):
        lo_b = srt[j, 0] + dvb
        hi_b = srt[j, 1] + dvb
        while i < a1 and srt[i, 0] <= lo_b:
            i += 1
        ii = i
        while ii < a1 and srt[ii, 0] < hi_b:
            if count < size:
                buf[count, 0] = ii
                buf[count, 1] = j
            count += 1
            ii += 1
    return count if count <= size else -count


@jit
def _integrate(
    srt: np.ndarray,
    buf: np.ndarray,
    count: int,
    shift: tuple[float, float],
    codes: np.ndarray,
    rs: np.ndarray,
    y0: float,
    acc: np.ndarray,
) -> None:
    """Add the integrals of ``count`` edge pairs into ``acc[0, k]`` (θ) and ``acc[1, k]`` (θ+π).

    Pair (A edge e, B edge f), B shifted into A's frame by ``shift = (dv, ds)``: on the common
    range of lines ``[lo, hi]`` the gap ``d(v) = s_A(v) - s_B(v)`` is linear; the pair weighs
    ``sign_e sign_f (lo - hi)`` (A-edges count + where they leave A, B-edges + where they enter
    B) times the mean of Φ⁺(d) over the range, and serves θ where d > 0, θ + π where d < 0 (a
    pair whose gap changes sign is split at the zero).
    """
    dvb, dsb = shift
    n_k = codes.size
    for q in range(count):
        e = buf[q, 0]
        f = buf[q, 1]
        lo_a = srt[e, 0]
        lo_b = srt[f, 0] + dvb
        hi_a = srt[e, 1]
        hi_b = srt[f, 1] + dvb
        lo = lo_a if lo_a > lo_b else lo_b
        hi = hi_a if hi_a < hi_b else hi_b
        if not hi > lo:
            continue
        s_a = srt[e, 2]
        k_a = srt[e, 3]
        s_b = srt[f, 2] + dsb
        k_b = srt[f, 3]
        d0 = (s_a + k_a * (lo - lo_a)) - (s_b + k_b * (lo - lo_b))
        d1 = (s_a + k_a * (hi - lo_a)) - (s_b + k_b * (hi - lo_b))
        weight = (srt[e, 4] * srt[f, 4]) * (lo - hi)
        if d0 * d1 < 0.0:
            top = d0 if d0 > d1 else d1
            bottom = d1 if d0 > d1 else d0
            frac = top / (abs(d0) + abs(d1))
            for k in range(n_k):
                acc[0, k] += weight * frac * _mean_phi(codes[k], rs[k], y0, 0.0, top)
                acc[1, k] += weight * (1.0 - frac) * _mean_phi(codes[k], rs[k], y0, 0.0, -bottom)
        elif d0 + d1 < 0.0:
            for k in range(n_k):
                acc[1, k] += weight * _mean_phi(codes[k], rs[k], y0, -d0, -d1)
        else:
            for k in range(n_k):
                acc[0, k] += weight * _mean_phi(codes[k], rs[k], y0, d0, d1)


@jit
def _walk_f0_f2(
    srt: np.ndarray,
    ranges: tuple[int, int, int, int],
    shift: tuple[float, float],
    bufs: np.ndarray,
    acc: np.ndarray,
) -> np.ndarray:
    """F0 and F2 of one pair in one direction into ``acc`` = ``(F0(θ), F2(θ), F0(θ + π),
    F2(θ + π))``: :func:`_collect`'s two-pointer walk over the sorted rows ``a0:a1, b0:b1 =
    ranges``, the edge pairs in batches (:mod:`~scenespeak.spatial.forces._batch`: branch-free,
    their logarithms vectorised). Returns the pairs' buffer, grown when this direction needed more.
    """
    n = collect_pairs(srt, ranges, shift, bufs)
    if n < 0:
        bufs = grown(bufs, -n)
        n = collect_pairs(srt, ranges, shift, bufs)
    acc[:] = 0.0
    integrate_pairs(bufs, n, acc)
    acc[0] /= 6.0
    acc[2] /= 6.0
    return bufs


@jit
def _convex_pairs(
    convex: np.ndarray, pair_a: np.ndarray, pair_b: np.ndarray, fast: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which pairs take the chain walk of :mod:`~scenespeak.spatial.forces._convex` (both
    regions convex, F0 + F2), which regions need the sorted edge tables (in another pair)
    and which the vertices' projections (in a chain walk)."""
    both = np.zeros(pair_a.size, dtype=np.bool_)
    table = np.zeros(convex.size, dtype=np.bool_)
    chained = np.zeros(convex.size, dtype=np.bool_)
    for p in range(pair_a.size):
        ga = pair_a[p]
        gb = pair_b[p]
        both[p] = fast and convex[ga] and convex[gb]
        if both[p]:
            chained[ga] = True
            chained[gb] = True
        else:
            table[ga] = True
            table[gb] = True
    return both, table, chained


@jit
def sweep(
    regions: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    pair_a: np.ndarray,
    pair_b: np.ndarray,
    y0: np.ndarray,
    kernels: tuple[np.ndarray, np.ndarray],
    directions: int,
) -> np.ndarray:
    """Force histograms of many pairs of regions, shape ``(pairs, kernels, directions)``.

    The regions and the kernels come as tuples of arrays (Numba takes a tuple of arrays as one
    argument, not a dataclass): ``regions = (pts, nxt, region_start, origin)`` and
    ``kernels = (codes, rs)``.

    Parameters
    ----------
    regions : tuple
        ``(pts, nxt, region_start, origin)``, as below.
    pts : (E, 2) float
        Every region's vertices, region after region, each relative to its ``origin``.
    nxt : (E,) int
        Global index of the next vertex along the boundary (edge e runs e → nxt[e]).
    region_start : (G + 1,) int
        Region g owns vertices ``region_start[g]:region_start[g + 1]``.
    origin : (G, 2) float
        Each region's origin (absolute coordinates).
    convex : (G,) bool
        Whether region g is one convex ring (its pairs with convex regions take the chain
        walk of :mod:`~scenespeak.spatial.forces._convex` for F0 + F2).
    pair_a, pair_b : (P,) int
        The argument and referent region of each pair.
    y0 : (P,) float
        The hybrid kernel's ``Y0`` of each pair (read for code 2 only).
    kernels : tuple
        ``(codes, rs)``, as below.
    codes, rs : (K,)
        The kernels (see the module docstring).
    directions : int
        Histogram bins; with an even number only half are swept (``F(θ + π)`` from the
        same pairs through ``Φ⁺(-d)``); with an odd number the θ + π parts are dropped.
    """
    pts, nxt, region_start, origin, convex = regions
    codes, rs = kernels
    n_pairs = pair_a.size
    n_k = codes.size
    both = directions % 2 == 0
    half = directions // 2 if both else directions
    out = np.zeros((n_pairs, n_k, directions))
    tab = np.empty((pts.shape[0], 5))
    perm = np.arange(pts.shape[0])  # the small regions' first order (see _tables)
    extent = np.empty((region_start.size - 1, 2))
    srt = np.empty((pts.shape[0], 5))
    keys = np.empty(pts.shape[0])
    moves = np.full(region_start.size - 1, -1, dtype=np.int64)  # _order's
    buf = np.empty((1024, 2), dtype=np.int64)
    acc = np.empty((2, n_k))
    # F0 + F2 (what every caller of f0_f2_pairs and force_histograms() asks for): fused walk.
    fast = n_k == 2 and codes[0] == 0 and codes[1] == 1
    chains, table, chained = _convex_pairs(convex, pair_a, pair_b, fast)
    low_high = np.zeros((region_start.size - 1, 2), dtype=np.int64)
    scratch = chain_scratch(region_start)  # walk_convex's
    # _walk_f0_f2's buffers (grown when a direction has more edge pairs) and sums.
    bufs = scratch_jit(16 * np.diff(region_start).max() + 64)
    sums = np.zeros(4)
    for d in range(half):
        theta = 2.0 * math.pi * d / directions
        c = math.cos(theta)
        s = math.sin(theta)
        _tables(c, s, pts, nxt, region_start, d == 0, (tab, perm, extent, srt, keys, moves), table)
        track_extremes((c, s), pts, region_start, chained, (low_high, extent), d == 0)
        for p in range(n_pairs):
            ga = pair_a[p]
            gb = pair_b[p]
            ox = origin[gb, 0] - origin[ga, 0]
            oy = origin[gb, 1] - origin[ga, 1]
            dvb = oy * c - ox * s
            if extent[ga, 1] < extent[gb, 0] + dvb or extent[gb, 1] + dvb < extent[ga, 0]:
                continue  # no line of this direction meets both objects
            a0, a1 = region_start[ga], region_start[ga + 1]
            b0, b1 = region_start[gb], region_start[gb + 1]
            if chains[p]:
                t0, t2, q0, q2 = walk_convex(
                    pts,
                    (c, s),
                    (a0, a1, low_high[ga, 0], low_high[ga, 1]),
                    (b0, b1, low_high[gb, 0], low_high[gb, 1]),
                    (dvb, ox * c + oy * s),
                    scratch,
                )
                out[p, 0, d] += t0
                out[p, 1, d] += t2
                if both:
                    out[p, 0, d + half] += q0
                    out[p, 1, d + half] += q2
                continue
            if fast:
                bufs = _walk_f0_f2(srt, (a0, a1, b0, b1), (dvb, ox * c + oy * s), bufs, sums)
                out[p, 0, d] += sums[0]
                out[p, 1, d] += sums[1]
                if both:
                    out[p, 0, d + half] += sums[2]
                    out[p, 1, d + half] += sums[3]
                continue
            count = _collect(srt, a0, a1, b0, b1, dvb, buf)
            if count < 0:
                buf = np.empty((2 * -count, 2), dtype=np.int64)
                count = _collect(srt, a0, a1, b0, b1, dvb, buf)
            acc[:] = 0.0
            _integrate(srt, buf, count, (dvb, ox * c + oy * s), codes, rs, y0[p], acc)
            for k in range(n_k):
                out[p, k, d] += acc[0, k]
                if both:
                    out[p, k, d + half] += acc[1, k]
    return out
