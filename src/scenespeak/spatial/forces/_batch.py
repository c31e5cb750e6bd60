"""F0 + F2 of two general (non-convex) regions in one direction, the edge pairs in batches
(private; compiled by Numba).

The two-pointer walk over the sorted edge tables of :mod:`~scenespeak.spatial.forces._sweep`
finds every (edge of A, edge of B) pair whose ranges of lines overlap; each contributes
``w ∫ Φ⁺(d(v)) dv`` over the common range, where the gap ``d`` is linear (Matsakis & Wendling
1999; ``docs/forces.md``). For F2 that is a divided difference of ``Ψ(u) = u - u log u``: two
logarithms per pair, which dominated the star's time when the walk took them one pair at a time
(``math.log`` is a call into libm that the compiler cannot vectorise). So the work is split in
three loops:

1. :func:`collect_gaps` walks the tables and writes each pair's end gaps ``|d0|, |d1|`` and
   weight into the buffers of its side (θ where ``d > 0``, θ + π where ``d < 0``);
2. :func:`_logs` takes the logarithms of a whole buffer at once, in a branch-free loop the
   compiler turns into SIMD instructions (fdlibm's ``log``: reduction to ``[√2/2, √2)`` by the
   exponent bits, then a polynomial in ``s = f / (2 + f)``; within 1 ulp of libm's);
3. :func:`_sums` adds the pairs' F0 and F2 terms, also vectorised (the sums may be
   reassociated: their order is not the walk's, which changes the last bits only).

A pair whose gap changes sign (its edges cross) or touches zero, or one that does not fit in the
buffers, is integrated on the spot by :func:`f0_f2_terms` with ``math.log``. The buffers grow
for the next direction when a direction overflowed them (:func:`grown`), so memory stays linear
in the pairs that one direction holds.
"""

from __future__ import annotations

import math

import numpy as np

from scenespeak.spatial.forces._jit import jit, jit_inline, jit_reassoc

# Below this |h| / |m| the divided difference of Ψ is replaced by its Taylor series (the
# reference's _TAYLOR_RATIO).
TAYLOR_RATIO = 1e-3
# Smallest normal double: gaps below it take the scalar path (_logs reads exponent bits).
TINY = 2.2250738585072014e-308
# Largest buffer (pairs per side and direction); pairs beyond it take the scalar path.
MAX_CAPACITY = 1 << 18

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


def scratch(capacity: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Buffers for ``capacity`` pairs per side: ``(gaps, logs, weights, bits)``.

    ``gaps[0:2]`` are the end gaps of the θ side's pairs, ``gaps[2:4]`` of the θ + π side's,
    ``weights[0]`` and ``weights[1]`` their weights, ``logs`` the logarithms of ``gaps``,
    ``bits`` the scratch of :func:`_logs`.
    """
    return (
        np.empty((4, capacity)),
        np.empty((4, capacity)),
        np.empty((2, capacity)),
        np.empty((2, capacity), dtype=np.int64),
    )


scratch_jit = jit(scratch)


@jit
def grown(
    bufs: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], missed: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Larger buffers when the last direction had ``missed`` pairs that did not fit."""
    capacity = bufs[2].shape[1]
    if missed == 0 or capacity >= MAX_CAPACITY:
        return bufs
    return scratch_jit(min(2 * capacity + missed, MAX_CAPACITY))


@jit_inline
def _gap(
    srt: np.ndarray, o: int, i: int, shift: tuple[float, float], case: int
) -> tuple[float, float, float]:
    """``(d0, d1, weight)`` of A-edge row ``e`` and B-edge row ``f`` (B shifted by ``shift =
    (dvb, dsb)``; ``(e, f) = (o, i)`` in case 0, ``(i, o)`` in case 1): the gap at both ends of
    their common range of lines and the pair's weight, 0 when the ranges do not overlap on a
    positive length."""
    dvb, dsb = shift
    e = o if case == 0 else i
    f = i if case == 0 else o
    lo_a = srt[e, 0]
    hi_a = srt[e, 1]
    lo_b = srt[f, 0] + dvb
    hi_b = srt[f, 1] + dvb
    lo = lo_a if lo_a > lo_b else lo_b
    hi = hi_a if hi_a < hi_b else hi_b
    weight = (srt[e, 4] * srt[f, 4]) * (lo - hi) if hi > lo else 0.0
    s_a = srt[e, 2]
    k_a = srt[e, 3]
    s_b = srt[f, 2] + dsb
    k_b = srt[f, 3]
    d0 = (s_a + k_a * (lo - lo_a)) - (s_b + k_b * (lo - lo_b))
    d1 = (s_a + k_a * (hi - lo_a)) - (s_b + k_b * (hi - lo_b))
    return d0, d1, weight


@jit
def _scalar(d0: float, d1: float, weight: float, acc: np.ndarray) -> None:
    """One pair integrated on the spot (:func:`f0_f2_terms`), added to ``acc``."""
    x0, x2, y0, y2 = f0_f2_terms(d0, d1, weight)
    acc[0] += x0
    acc[1] += x2
    acc[2] += y0
    acc[3] += y2


@jit_inline
def _slot(
    pair: tuple[float, float, float], cnt: tuple[int, int, int], capacity: int
) -> tuple[int, int, tuple[int, int, int]]:
    """Where pair ``(d0, d1, weight)`` goes: ``(row, n, counts)``, its side's first buffer row
    (0 for θ, 2 for θ + π) and index, or row -1 when it is integrated on the spot (a gap that
    changes sign or is below :data:`TINY`, full buffers), -2 when it weighs nothing; the counts
    ``(θ side, θ + π side, did not fit)`` updated. Scalars only: arrays handed to a helper of
    the inner loop are reference-counted at every pair."""
    d0, d1, w = pair
    n_pos, n_neg, missed = cnt
    if w == 0.0:
        return -2, 0, cnt
    neg = d0 + d1 < 0.0
    n = n_neg if neg else n_pos
    if n >= capacity:
        return -1, 0, (n_pos, n_neg, missed + 1)
    if d0 * d1 > 0.0 and abs(d0) >= TINY and abs(d1) >= TINY:
        return (2, n, (n_pos, n + 1, missed)) if neg else (0, n, (n + 1, n_neg, missed))
    return -1, 0, cnt


@jit_inline
def _roles(
    ranges: tuple[int, int, int, int], dvb: float, case: int
) -> tuple[int, int, int, int, float, float]:
    """``(outer rows, inner rows, their v offsets)`` of :func:`collect_gaps`'s case."""
    a0, a1, b0, b1 = ranges
    if case == 0:
        return a0, a1, b0, b1, 0.0, dvb
    return b0, b1, a0, a1, dvb, 0.0


@jit_inline
def _before(v: float, lo: float, case: int) -> bool:
    """Whether an inner edge starting at ``v`` comes before an outer one starting at ``lo``
    (case 0: ``v < lo``, case 1: ``v <= lo``; each pair of equal starts is taken once)."""
    return v < lo or (case == 1 and v == lo)


@jit
def collect_gaps(
    srt: np.ndarray,
    ranges: tuple[int, int, int, int],
    shift: tuple[float, float],
    bufs: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    counts: np.ndarray,
    acc: np.ndarray,
) -> None:
    """Every overlapping edge pair of A (rows ``a0:a1``) and B (rows ``b0:b1``) into the
    buffers of its side, by the two-pointer walk of ``_sweep._collect``; ``counts[0:2]`` the
    pairs per side, ``counts[2]`` those that did not fit.

    Case 0: for each A-edge, the B-edges with ``lo_a <= lo_b < hi_a``; case 1: for each
    B-edge, the A-edges with ``lo_b < lo_a < hi_b``: each pair once. A pair whose edges cross
    or touch, with a gap below :data:`TINY`, or that does not fit, is integrated on the spot
    (:func:`_scalar`). One loop body serves both cases.
    """
    dvb, dsb = shift
    gaps = bufs[0]
    weights = bufs[2]
    capacity = weights.shape[1]
    cnt = (0, 0, 0)
    for case in range(2):
        o0, o1, i0, i1, off_o, off_i = _roles(ranges, dvb, case)
        j = i0
        for o in range(o0, o1):
            lo_o = srt[o, 0] + off_o
            hi_o = srt[o, 1] + off_o
            while j < i1 and _before(srt[j, 0] + off_i, lo_o, case):
                j += 1
            if j == i1:
                break  # every inner edge starts below this one, hence below the rest
            jj = j
            while jj < i1 and srt[jj, 0] + off_i < hi_o:
                d0, d1, w = _gap(srt, o, jj, (dvb, dsb), case)
                jj += 1
                row, n, cnt = _slot((d0, d1, w), cnt, capacity)
                if row >= 0:
                    gaps[row, n] = abs(d0)
                    gaps[row + 1, n] = abs(d1)
                    weights[row // 2, n] = w
                elif row == -1:
                    _scalar(d0, d1, w, acc)
    counts[0], counts[1], counts[2] = cnt


@jit
def _logs(x: np.ndarray, out: np.ndarray, n: int, bits: np.ndarray) -> None:
    """``out[:n] = log(x[:n])`` for positive normal doubles, vectorisable (fdlibm ``e_log.c``:
    ``x = 2**k (1 + f)`` with ``1 + f`` in ``[√2/2, √2)``, ``log(1 + f)`` from a polynomial
    in ``s = f / (2 + f)``; error below 1 ulp). ``bits`` is int64 scratch of 2 rows."""
    xb = x.view(np.int64)
    mant = bits[0]
    expo = bits[1].view(np.float64)
    for i in range(n):
        b = xb[i]
        mb = (b & MANTISSA) | ONE_BITS
        big = mb > SQRT2_BITS
        mant[i] = mb - (1 << 52) if big else mb
        expo[i] = float((b >> 52) - 1023 + (1 if big else 0))
    m = mant.view(np.float64)
    for i in range(n):
        f = m[i] - 1.0
        s = f / (2.0 + f)
        z = s * s
        w = z * z
        r = z * (LG1 + w * (LG3 + w * (LG5 + w * LG7))) + w * (LG2 + w * (LG4 + w * LG6))
        hfsq = 0.5 * f * f
        k = expo[i]
        out[i] = k * LN2_HI - ((hfsq - (s * (hfsq + r) + k * LN2_LO)) - f)


@jit_reassoc
def _sums(
    a0s: np.ndarray, a1s: np.ndarray, l0s: np.ndarray, l1s: np.ndarray, ws: np.ndarray, n: int
) -> tuple[float, float]:
    """``(Σ w (a0² + a0 a1 + a1²), Σ w mean Φ⁺)`` over one side's ``n`` pairs (F2:
    :func:`_mean_f2` from the buffered logarithms; its Taylor branch as ``-(l0 + l1) / 2 -
    x² / 12 - x⁴ / 64``, ``x = h / m``, which is ``-log m + x² / 24`` to O(x⁶))."""
    t0 = 0.0
    t2 = 0.0
    for i in range(n):
        a0 = a0s[i]
        a1 = a1s[i]
        l0 = l0s[i]
        l1 = l1s[i]
        w = ws[i]
        t0 += w * (a0 * a0 + a0 * a1 + a1 * a1)
        h = a1 - a0
        m = 0.5 * (a0 + a1)
        dd = ((a1 - a1 * l1) - (a0 - a0 * l0)) / h
        x = h / m
        xx = x * x
        tay = -0.5 * (l0 + l1) - xx * (1.0 / 12.0 + xx / 64.0)
        t2 += w * (tay if abs(h) <= TAYLOR_RATIO * m else dd)
    return t0, t2


@jit
def integrate_gaps(
    bufs: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], counts: np.ndarray, acc: np.ndarray
) -> None:
    """Add the buffered pairs' F0 and F2 terms to ``acc`` (θ: ``acc[0:2]``, θ + π: ``acc[2:4]``)."""
    gaps, logs, weights, bits = bufs
    for side in range(2):
        n = counts[side]
        _logs(gaps[2 * side], logs[2 * side], n, bits)
        _logs(gaps[2 * side + 1], logs[2 * side + 1], n, bits)
        t0, t2 = _sums(
            gaps[2 * side], gaps[2 * side + 1], logs[2 * side], logs[2 * side + 1], weights[side], n
        )
        acc[2 * side] += t0
        acc[2 * side + 1] += t2
