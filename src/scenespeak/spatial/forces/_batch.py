"""F0 + F2 of two general (non-convex) regions in one direction, the edge pairs in batches
(private; compiled by Numba).

The two-pointer walk over the sorted edge tables of :mod:`~scenespeak.spatial.forces._sweep`
finds every (edge of A, edge of B) pair whose ranges of lines overlap; each contributes
``w ∫ Φ⁺(d(v)) dv`` over the common range, where the gap ``d`` is linear (Matsakis & Wendling
1999; ``docs/forces.md``). For F2 that is a divided difference of ``Ψ(u) = u - u log u``: two
logarithms per pair, which dominated the star's time when the walk took them one pair at a time
(``math.log`` is a call into libm that the compiler cannot vectorise). So the work is split in
two loops, each without branches so that the compiler turns it into SIMD instructions:

1. :func:`collect_pairs` walks the tables; for each edge of one region it finds the run of the
   other's rows that it pairs with (two pointers), then writes each pair's signed end gaps
   ``d0, d1`` and weight into the buffers in a counted loop (:func:`_fill`);
2. :func:`_sums` takes the logarithms of ``|d0|`` and ``|d1|`` (fdlibm's ``log``: from the
   float's bits, ``x = 2**k (1 + f)`` with ``1 + f`` in ``[√2/2, √2)``, then a polynomial in
   ``s = f / (2 + f)``; within 1 ulp of libm's; the two divisions of a pair share one) and adds
   the pairs' F0 and F2 terms to the side each serves (θ where ``d > 0``, θ + π where
   ``d < 0``) by selects; the sums may be reassociated (their order is not the walk's, which
   changes the last bits only). The bits are read in registers (:func:`~scenespeak.spatial.
   forces._jit.bitcasts`), so that this is one loop, not a pass through memory first.

A pair whose gap changes sign (its edges cross) or touches zero (below :data:`TINY`) weighs
nothing in those loops and is integrated afterwards by :func:`f0_f2_terms` with ``math.log``.
When a direction has more pairs than the buffers hold, :func:`collect_pairs` says how many it
needs and the caller grows them (:func:`grown`) and walks again, so memory stays linear in the
pairs that one direction holds.
"""

from __future__ import annotations

import math

import numpy as np

from scenespeak.spatial.forces._jit import bitcasts, jit, jit_inline, jit_reassoc

# Below this |h| / |m| the divided difference of Ψ is replaced by its Taylor series (the
# reference's _TAYLOR_RATIO).
TAYLOR_RATIO = 1e-3
# Smallest normal double: gaps below it take the scalar path (_logs reads exponent bits).
TINY = 2.2250738585072014e-308

# fdlibm's e_log.c: ln 2 split in two, and the coefficients of log(1+f) in s = f / (2 + f).
LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
LG1 = 6.666666666666735130e-01
LG2 = 3.999999999940941908e-01
LG3 = 2.857142874366239149e-01
LG4 = 2.222219843214978396e-01
LG5 = 1.818357216161805012e-01
LG6 = 1.531383769920937332e-01
LG7 = 1.479819860511658591e-01
MANTISSA = 0x000FFFFFFFFFFFFF
ONE_BITS = 0x3FF0000000000000
SQRT2_BITS = 0x3FF6A09E667F3BCD

as_float, as_int = bitcasts()


@jit
def _mean_f2(a0: float, a1: float) -> float:
    """Mean of Φ⁺(u) = -log u over a gap going linearly from a0 to a1 (>= 0, reference
    ``_Kernel`` for r = 2)."""
    h = a1 - a0
    m = 0.5 * (a0 + a1)
    if abs(h) <= TAYLOR_RATIO * m:
        if m > 0.0:
            return -math.log(m) + (1.0 / (m * m)) * h * h / 24.0
        return 0.0
    p0 = a0 - a0 * math.log(a0) if a0 > 0.0 else 0.0
    p1 = a1 - a1 * math.log(a1) if a1 > 0.0 else 0.0
    return (p1 - p0) / h


@jit
def f0_f2_terms(d0: float, d1: float, weight: float) -> tuple[float, float, float, float]:
    """One edge pair's F0 and F2 terms at θ and at θ + π, one pair at a time.

    The gap goes linearly from ``d0`` to ``d1``; where it is negative the pair serves θ + π
    (a pair whose gap changes sign is split at the zero). The F0 terms are six times the mean
    of ``u² / 2`` (``a0² + a0 a1 + a1²``): the caller divides their sum by 6 once.
    """
    if d0 * d1 < 0.0:
        top = d0 if d0 > d1 else d1
        bottom = d1 if d0 > d1 else d0
        frac = top / (abs(d0) + abs(d1))
        w_pos = weight * frac
        w_neg = weight * (1.0 - frac)
        nb = -bottom
        return (
            w_pos * (top * top),
            w_pos * _mean_f2(0.0, top),
            w_neg * (nb * nb),
            w_neg * _mean_f2(0.0, nb),
        )
    if d0 + d1 < 0.0:
        a0 = -d0
        a1 = -d1
        return 0.0, 0.0, weight * (a0 * a0 + a0 * a1 + a1 * a1), weight * _mean_f2(a0, a1)
    return weight * (d0 * d0 + d0 * d1 + d1 * d1), weight * _mean_f2(d0, d1), 0.0, 0.0


def scratch(capacity: int) -> np.ndarray:
    """Buffer for ``capacity`` pairs: rows ``d0, d1, weight`` (:func:`collect_pairs`)."""
    return np.empty((3, capacity))


scratch_jit = jit(scratch)


@jit
def grown(pairs: np.ndarray, needed: int) -> np.ndarray:
    """``pairs``, or a larger buffer when a direction needs ``needed`` pairs (twice as many)."""
    if needed <= pairs.shape[1]:
        return pairs
    return scratch_jit(2 * needed)


@jit_inline
def _fill(
    srt: np.ndarray,
    o: int,
    inner: tuple[int, int],
    offsets: tuple[float, float, float, float],
    sgn: float,
    pairs: np.ndarray,
    n: int,
) -> int:
    """Pairs of row ``o`` with rows ``inner = (j0, j1)`` into ``pairs[:, n:]``; returns the new
    ``n``. Row ``o`` is shifted by ``offsets[0:2]`` (``v``, ``s``), the inner rows by
    ``offsets[2:4]``; ``sgn`` is +1 when ``o`` is an A-edge, -1 when it is a B-edge, so that the
    gap is always ``s_A - s_B``. A pair that does not overlap on a positive length weighs 0.
    The same floats as the pair-at-a-time walk (``_sweep._integrate``)."""
    ov, os_, iv, is_ = offsets
    lo_o = srt[o, 0] + ov
    hi_o = srt[o, 1] + ov
    s_o = srt[o, 2] + os_
    k_o = srt[o, 3]
    g_o = srt[o, 4]
    d0s = pairs[0]
    d1s = pairs[1]
    ws = pairs[2]
    for jj in range(inner[0], inner[1]):
        lo_i = srt[jj, 0] + iv
        hi_i = srt[jj, 1] + iv
        s_i = srt[jj, 2] + is_
        k_i = srt[jj, 3]
        lo = lo_o if lo_o > lo_i else lo_i
        hi = hi_o if hi_o < hi_i else hi_i
        span = lo - hi
        ws[n] = (g_o * srt[jj, 4]) * (span if span < 0.0 else 0.0)
        d0s[n] = sgn * ((s_o + k_o * (lo - lo_o)) - (s_i + k_i * (lo - lo_i)))
        d1s[n] = sgn * ((s_o + k_o * (hi - lo_o)) - (s_i + k_i * (hi - lo_i)))
        n += 1
    return n


@jit
def collect_pairs(
    srt: np.ndarray,
    ranges: tuple[int, int, int, int],
    shift: tuple[float, float],
    pairs: np.ndarray,
) -> int:
    """Every overlapping edge pair of A (rows ``a0:a1``) and B (rows ``b0:b1``, shifted by
    ``shift = (dvb, dsb)``) into ``pairs``; returns their number, or minus the number needed
    when ``pairs`` is too small (then its contents are of no use).

    Case 0: for each A-edge, the B-edges with ``lo_a <= lo_b < hi_a``; case 1: for each
    B-edge, the A-edges with ``lo_b < lo_a < hi_b``: each pair once (two pointers over rows
    sorted by ``lo``, as ``_sweep._collect``). One loop body serves both cases.
    """
    a0, a1, b0, b1 = ranges
    dvb, dsb = shift
    capacity = pairs.shape[1]
    n = 0
    needed = 0
    for case in range(2):
        o0, o1, i0, i1 = (a0, a1, b0, b1) if case == 0 else (b0, b1, a0, a1)
        offsets = (0.0, 0.0, dvb, dsb) if case == 0 else (dvb, dsb, 0.0, 0.0)
        sgn = 1.0 if case == 0 else -1.0
        off_o = offsets[0]
        off_i = offsets[2]
        j = i0
        for o in range(o0, o1):
            lo_o = srt[o, 0] + off_o
            hi_o = srt[o, 1] + off_o
            # Inner rows starting before this one (case 1: or with it) pair with it in the
            # other case; each pair of equal starts is taken once.
            while j < i1 and (
                srt[j, 0] + off_i < lo_o or (case == 1 and srt[j, 0] + off_i == lo_o)
            ):
                j += 1
            if j == i1:
                break  # every inner edge starts below this one, hence below the rest
            end = j
            while end < i1 and srt[end, 0] + off_i < hi_o:
                end += 1
            needed += end - j
            if needed <= capacity:
                n = _fill(srt, o, (j, end), offsets, sgn, pairs, n)
    return n if needed <= capacity else -needed


@jit_inline
def _usable(d0: float, d1: float) -> bool:
    """Whether a pair goes through the vectorised loops: a gap of one sign, both ends at least
    :data:`TINY` (bitwise ``&``: no branch)."""
    return (d0 * d1 > 0.0) & (abs(d0) >= TINY) & (abs(d1) >= TINY)


@jit_inline
def _reduce(x: float) -> tuple[float, float]:
    """fdlibm's reduction of a positive normal double: ``(f, k)`` with ``x = 2**k (1 + f)``,
    ``1 + f`` in ``[√2/2, √2)`` (from its bits)."""
    b = as_int(x)
    mb = (b & MANTISSA) | ONE_BITS
    big = mb > SQRT2_BITS
    return as_float(mb - (1 << 52) if big else mb) - 1.0, float(
        (b >> 52) - 1023 + (1 if big else 0)
    )


@jit_inline
def _log_poly(f: float, s: float, k: float) -> float:
    """fdlibm's ``log(2**k (1 + f))`` given ``s = f / (2 + f)`` (``e_log.c``)."""
    z = s * s
    w = z * z
    r = z * (LG1 + w * (LG3 + w * (LG5 + w * LG7))) + w * (LG2 + w * (LG4 + w * LG6))
    hfsq = 0.5 * f * f
    return k * LN2_HI - ((hfsq - (s * (hfsq + r) + k * LN2_LO)) - f)


@jit_reassoc
def _sums(pairs: np.ndarray, n: int) -> tuple[float, float, float, float, int]:
    """``(Σ 6 F0, Σ F2)`` of the θ side, then of the θ + π side, over the :func:`_usable` pairs,
    and the number of pairs that are not.

    F0: ``w (a0² + a0 a1 + a1²)`` (six times the mean of ``u² / 2``); F2: :func:`_mean_f2`
    from the logarithms of ``a0 = |d0|, a1 = |d1|``, its Taylor branch as ``-(l0 + l1) / 2 -
    x² / 12 - x⁴ / 64``, ``x = h / m`` (``-log m + x² / 24`` to O(x⁶)). The two divisions of
    fdlibm's ``s`` share one (``1 / ((2 + f0)(2 + f1))``), as do ``1 / h`` and ``1 / m``."""
    d0s = pairs[0]
    d1s = pairs[1]
    ws = pairs[2]
    bad = 0
    p0 = 0.0
    p2 = 0.0
    q0 = 0.0
    q2 = 0.0
    for i in range(n):
        d0 = d0s[i]
        d1 = d1s[i]
        ok = _usable(d0, d1)
        a0 = abs(d0) if ok else 1.0
        a1 = abs(d1) if ok else 1.0
        w = ws[i] if ok else 0.0
        bad += 0 if ok else 1
        f0, k0 = _reduce(a0)
        f1, k1 = _reduce(a1)
        inv = 1.0 / ((2.0 + f0) * (2.0 + f1))
        l0 = _log_poly(f0, f0 * (2.0 + f1) * inv, k0)
        l1 = _log_poly(f1, f1 * (2.0 + f0) * inv, k1)
        t0 = w * (a0 * a0 + a0 * a1 + a1 * a1)
        h = a1 - a0
        m = 0.5 * (a0 + a1)
        taylor = abs(h) <= TAYLOR_RATIO * m
        hh = m if taylor else h
        inv_hm = 1.0 / (hh * m)
        dd = ((a1 - a1 * l1) - (a0 - a0 * l0)) * (m * inv_hm)
        x = h * (hh * inv_hm)
        xx = x * x
        tay = -0.5 * (l0 + l1) - xx * (1.0 / 12.0 + xx / 64.0)
        t2 = w * (tay if taylor else dd)
        neg = d0 + d1 < 0.0
        p0 += 0.0 if neg else t0
        p2 += 0.0 if neg else t2
        q0 += t0 if neg else 0.0
        q2 += t2 if neg else 0.0
    return p0, p2, q0, q2, bad


@jit
def integrate_pairs(pairs: np.ndarray, n: int, acc: np.ndarray) -> None:
    """Add the ``n`` collected pairs' F0 (times 6) and F2 terms to ``acc`` (θ: ``acc[0:2]``,
    θ + π: ``acc[2:4]``); the pairs that are not :func:`_usable` one at a time."""
    p0, p2, q0, q2, bad = _sums(pairs, n)
    acc[0] += p0
    acc[1] += p2
    acc[2] += q0
    acc[3] += q2
    if bad == 0:
        return
    for i in range(n):
        d0 = pairs[0, i]
        d1 = pairs[1, i]
        w = pairs[2, i]
        if w != 0.0 and not _usable(d0, d1):
            x0, x2, y0, y2 = f0_f2_terms(d0, d1, w)
            acc[0] += x0
            acc[1] += x2
            acc[2] += y0
            acc[3] += y2
