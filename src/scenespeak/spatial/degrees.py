"""Degrees of truth of the four directions from one force histogram (private).

Matsakis' effective-forces model (Matsakis, Keller, Wendling, Marjamaa, Sjahputera, IEEE SMC-B
31(4), 2001), as written down in ``docs/language.md``. For a histogram ``h`` of
``N`` bins (``N`` divisible by 4, ``n = N / 4`` bins per right angle) and a direction ``alpha``
(a bin index), with ``phi`` the signed bin offset from ``alpha``:

1. Contrary forces are the bins with ``|phi| >= n``; the opposite bin counts half to each side,
   and so does the bin at ``phi = 0`` on the favourable side (a uniform histogram then scores
   exactly 0).
2. On each side, the contrary forces form a moment ``sum f * (|phi| - n)`` about the pivot at
   ``+-90 deg``; the moment cancels favourable bins from the pivot inwards (a bin at distance
   ``d`` from the pivot consumes ``f * d``), the last one possibly in part. Cancelled mass joins
   the contrary mass ``Q``.
3. ``P`` is the favourable mass left; if ``P = 0`` the degree is 0.
4. A threshold ``tau``: the trapezoid-weighted mean of the remaining favourable forces around
   ``alpha`` (weight 1 within +-22.5 deg, falling to 0 at +-45 deg).
5. The mean deviation ``theta`` is the mean direction (relative to ``alpha``) of the forces above
   ``tau``: ``sum max(0, f - tau) * phi / sum max(0, f - tau)``.
6. Degree ``= max(0, 1 - |theta| / (pi/2)) * P / (P + Q)``.

One deliberate change from the design note: step 5 divides by the mass *above the threshold*
instead of by ``P``. With ``P`` in the denominator the deviation of a spike ``delta`` off the axis
shrinks by the factor ``1 - tau / f`` (about 3 % for 180 bins), so a spike would not score
``1 - delta/90``; with the thresholded mass it does, exactly (pinned by
``test_spike_degree_is_linear_in_the_offset``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError

#: The four directions, in the order of their angles 0, 90, 180, 270 degrees (docs/interfaces.md:
#: 0 = right, 90 = behind = farther from the camera, 180 = left, 270 = in front).
DIRECTIONS: tuple[str, str, str, str] = ("right", "behind", "left", "front")

#: Half-width (degrees) of the full-weight part of the threshold's trapezoid window.
TAU_FLAT_DEG = 22.5
#: Half-width (degrees) where the threshold's trapezoid window reaches 0.
TAU_ZERO_DEG = 45.0


@dataclass(frozen=True)
class DirectionDegree:
    """The degree of truth of one direction from one histogram, with what led to it.

    Attributes
    ----------
    degree : float
        In [0, 1].
    deviation : float
        Signed mean deviation (radians) of the effective forces from the direction; positive
        is counter-clockwise (from right towards behind, from behind towards left, ...).
    effective : float
        ``P``: favourable mass left after the contrary forces cancelled their share.
    contrary : float
        ``Q``: contrary mass plus cancelled favourable mass.
    """

    degree: float
    deviation: float
    effective: float
    contrary: float


def _cancel_side(fav: NDArray[np.float64], dist: NDArray[np.float64], moment: float) -> float:
    """Cancel favourable forces (ordered from the pivot inwards) with a moment, in place.

    Returns the cancelled mass.
    """
    if moment <= 0.0 or fav.size == 0:
        return 0.0
    cost = fav * dist
    cum = np.cumsum(cost)
    full = int(np.searchsorted(cum, moment, side="right"))  # bins consumed completely
    cancelled = float(fav[:full].sum())
    fav[:full] = 0.0
    if full < fav.size:
        left = moment - (float(cum[full - 1]) if full > 0 else 0.0)
        if left > 0.0 and dist[full] > 0.0:
            part = min(fav[full], left / dist[full])
            fav[full] -= part
            cancelled += float(part)
    return cancelled


@dataclass(frozen=True)
class _Constants:
    """Index arrays and weights of :func:`direction_degree` for one number of bins."""

    phis: NDArray[np.intp]
    neg_phis: NDArray[np.intp]
    dist: NDArray[np.float64]
    cphi: NDArray[np.intp]
    neg_cphi: NDArray[np.intp]
    arm: NDArray[np.float64]
    phi: NDArray[np.float64]
    weight: NDArray[np.float64]
    weight_sum: np.float64


@functools.lru_cache(maxsize=8)
def _constants(nbins: int) -> _Constants:
    """The arrays :func:`direction_degree` needs for ``nbins`` bins (computed once, read-only)."""
    n = nbins // 4
    bin_rad = 2.0 * np.pi / nbins
    phis = np.arange(n - 1, -1, -1)
    cphi = np.arange(n, 2 * n)
    phi = np.arange(-(n - 1), n) * bin_rad
    absdeg = np.degrees(np.abs(phi))
    weight = np.clip((TAU_ZERO_DEG - absdeg) / (TAU_ZERO_DEG - TAU_FLAT_DEG), 0.0, 1.0)
    arrays = {
        "phis": phis,
        "neg_phis": (-phis) % nbins,
        "dist": (n - phis).astype(np.float64),
        "cphi": cphi,
        "neg_cphi": (-cphi) % nbins,
        "arm": (cphi - n).astype(np.float64),
        "phi": phi,
        "weight": weight,
    }
    for a in arrays.values():
        a.setflags(write=False)
    return _Constants(**arrays, weight_sum=weight.sum())


def check_histogram(h: object, name: str = "histogram") -> NDArray[np.float64]:
    """``h`` as a 1-D float64 histogram, or :class:`InputError` saying why it is not one.

    A histogram of forces is real, finite and non-negative, with a number of bins divisible by
    4 (at most :attr:`~scenespeak.limits.Limits.max_directions`). All zero is allowed: every
    degree is then 0 (nothing is said, see :mod:`scenespeak.spatial.language`).
    """
    from scenespeak import limits

    try:
        arr = np.asarray(h)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"cannot be read as an array ({exc})") from None
    if arr.dtype.kind not in "iuf" or np.iscomplexobj(arr):
        raise InputError(name, f"must be real numbers, got dtype {arr.dtype}")
    if arr.ndim != 1 or arr.size < 4 or arr.size % 4:
        raise InputError(name, f"must be 1-D with a multiple of 4 bins, got shape {arr.shape}")
    if arr.size > limits.current().max_directions:
        raise InputError(name, limits.exceeded("max_directions", f"{arr.size} bins", 0))
    arr = arr.astype(np.float64)
    if not np.isfinite(arr).all():
        raise InputError(name, "contains NaN or infinite values")
    if (arr < 0).any():
        raise InputError(name, "has negative values; forces are never negative")
    with np.errstate(over="ignore"):
        if not np.isfinite(arr.sum()):
            raise InputError(
                name, "forces are too large to add up in float64; normalise the histogram"
            )
    return arr


def direction_degree(h: NDArray[np.float64], index: int) -> DirectionDegree:
    """Degree of truth that the argument lies in the direction of bin ``index``.

    Parameters
    ----------
    h : ndarray, shape (N,)
        A non-negative force histogram; ``N`` divisible by 4.
    index : int
        The bin of the direction (``N/4`` per right angle).

    Returns
    -------
    DirectionDegree

    Examples
    --------
    >>> h = np.zeros(180); h[75] = 1.0          # a spike at 150 deg
    >>> round(direction_degree(h, 90).degree, 4)   # 30 deg off "left" (180 deg)
    0.6667
    """
    h = check_histogram(h)
    if isinstance(index, bool) or not isinstance(index, int | np.integer):
        raise InputError("index", f"must be a bin number, got {index!r}")
    if not 0 <= index < h.size:
        raise InputError("index", f"must be a bin in 0..{h.size - 1}, got {index}")
    nbins = h.size
    n = nbins // 4
    c = _constants(nbins)
    # np.roll(h, -index), without its general-purpose overhead (the same values).
    k = index % nbins if nbins else 0
    g = np.concatenate([h[k:], h[:k]]).astype(np.float64)
    # Favourable bins on each side, ordered from the pivot inwards: phi = n-1, ..., 1, 0(half).
    dist = c.dist
    fav_pos = g[c.phis]
    fav_neg = g[c.neg_phis]
    fav_pos[-1] *= 0.5
    fav_neg[-1] *= 0.5
    # Contrary bins on each side: |phi| = n .. 2n-1, plus the opposite bin (half each).
    con_pos = g[c.cphi]
    con_neg = g[c.neg_cphi]
    opposite = 0.5 * g[2 * n]
    arm = c.arm
    m_pos = float(con_pos @ arm) + opposite * n
    m_neg = float(con_neg @ arm) + opposite * n
    contrary = float(con_pos.sum() + con_neg.sum()) + 2.0 * opposite
    contrary += _cancel_side(fav_pos, dist, m_pos)
    contrary += _cancel_side(fav_neg, dist, m_neg)

    # Effective forces as one array over phi = -(n-1) .. (n-1), the bin at 0 whole again.
    eff = np.concatenate([fav_neg[:-1], [fav_pos[-1] + fav_neg[-1]], fav_pos[::-1][1:]])
    phi = c.phi
    total = float(eff.sum())
    scale = max(total + contrary, 1e-300)
    if total <= 1e-12 * scale:
        return DirectionDegree(0.0, 0.0, max(total, 0.0), contrary)
    weight = c.weight
    tau = float(weight @ eff / c.weight_sum)
    above = np.maximum(eff - tau, 0.0)
    mass = float(above.sum())
    theta = float(above @ phi / mass) if mass > 0.0 else float(eff @ phi / total)
    degree = max(0.0, 1.0 - abs(theta) / (np.pi / 2.0)) * total / (total + contrary)
    return DirectionDegree(float(min(max(degree, 0.0), 1.0)), theta, total, contrary)


def _prefix_sums(x: NDArray[np.float64], length: NDArray[np.intp]) -> NDArray[np.float64]:
    """``x[r, :length[r]].sum()`` for every row ``r``, bit for bit (rows of at most 128).

    NumPy sums a contiguous run of ``L <= 128`` float64 values in a fixed order: eight running
    sums ``r[j] = x[j] + x[j+8] + ...`` over the first ``8 * (L // 8)`` values, combined as
    ``((r0+r1)+(r2+r3))+((r4+r5)+(r6+r7))``, then the last ``L % 8`` values one by one (for
    ``L < 8`` only the one-by-one part, from 0). This does the same for all rows at once;
    adding 0.0 for the values past a row's length changes nothing. Pinned by
    ``test_prefix_sums_match_numpy_bit_for_bit``.
    """
    rows, width = x.shape
    if width > 128:
        raise ValueError("runs longer than 128 values are summed in another order")
    r = np.arange(rows)
    nblk = width // 8
    full = length // 8
    res = np.zeros(rows)
    if nblk:
        acc = x[:, : 8 * nblk].reshape(rows, nblk, 8).cumsum(axis=1)[r, np.maximum(full - 1, 0)]
        tree = ((acc[:, 0] + acc[:, 1]) + (acc[:, 2] + acc[:, 3])) + (
            (acc[:, 4] + acc[:, 5]) + (acc[:, 6] + acc[:, 7])
        )
        res = np.where(full > 0, tree, 0.0)
    col = 8 * full[:, None] + np.arange(7)
    tail = np.where(col < length[:, None], x[r[:, None], np.minimum(col, width - 1)], 0.0)
    return np.cumsum(np.concatenate([res[:, None], tail], axis=1), axis=1)[:, -1]


def _row_dots(x: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``[row @ v for row in x]``, bit for bit.

    A stack of ``(1, n) @ (n, 1)`` products is taken by NumPy's 1-D dot (BLAS ``ddot``) row by
    row, whereas ``x @ v`` (``gemv``) may add the terms in another order.
    """
    return np.matmul(x[:, None, :], v[:, None])[:, 0, 0]


#: Rows of one block of :func:`many_degrees` / :func:`four_direction_degrees`: the block's
#: temporaries (a few arrays of ``2 * rows * N/4`` floats) stay in a core's cache.
DEGREE_BLOCK = 1024


def many_degrees(
    h: NDArray[np.float64], index: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`direction_degree` of many (histogram, direction) rows at once, bit for bit.

    Parameters
    ----------
    h : ndarray, shape (R, N)
        Non-negative force histograms, one per row; ``N`` divisible by 4 (rows of more than
        512 bins are passed to :func:`direction_degree` one by one).
    index : ndarray of int, shape (R,)
        The direction (bin) of each row.

    Returns
    -------
    degree, deviation, effective, contrary : ndarray, shape (R,)
        The fields of :class:`DirectionDegree` for each row: the same floats as
        ``direction_degree(h[r], index[r])`` (the same operations in the same order). Pinned
        by ``test_many_degrees_match_direction_degree_bit_for_bit``.

    Examples
    --------
    >>> h = np.zeros((2, 180)); h[:, 75] = 1.0
    >>> [round(float(x), 4) for x in many_degrees(h, np.array([90, 0]))[0]]
    [0.6667, 0.0]
    """
    h = np.asarray(h, dtype=np.float64)
    rows, nbins = h.shape
    index = np.asarray(index, dtype=np.intp)
    if nbins // 4 > 128:  # longer prefix sums are added in another order: row by row
        found = [direction_degree(h[r], int(index[r])) for r in range(rows)]
        d, t, e, q = (
            np.array([getattr(x, f) for x in found], dtype=np.float64)
            for f in ("degree", "deviation", "effective", "contrary")
        )
        return d, t, e, q
    out = np.empty((4, rows))
    bins = np.arange(nbins)
    for lo in range(0, rows, DEGREE_BLOCK):
        hi = min(lo + DEGREE_BLOCK, rows)
        # Each row turned so that its direction is bin 0 (C-contiguous, as np.take gives it).
        g = np.take_along_axis(h[lo:hi], (index[lo:hi, None] + bins) % nbins, axis=1)
        out[:, lo:hi] = _turned_degrees(g)
    return out[0], out[1], out[2], out[3]


def four_direction_degrees(
    h: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Degrees and deviations of the four :data:`DIRECTIONS` for every row of ``h``.

    The same floats as ``four_degrees(h[r])[d].degree`` and ``.deviation`` (bit for bit; pinned
    by ``test_four_direction_degrees_match_four_degrees``), computed block by block
    (:data:`DEGREE_BLOCK` rows) so that memory stays linear in the rows and the temporaries in
    the cache.

    Parameters
    ----------
    h : ndarray, shape (R, N)
        Non-negative force histograms; ``N`` divisible by 4.

    Returns
    -------
    degree, deviation : ndarray, shape (R, 4)
        Column ``k`` is direction ``DIRECTIONS[k]``.

    Examples
    --------
    >>> h = np.zeros((1, 180)); h[0, 80] = 1.0          # 160°: left, leaning behind
    >>> degree, deviation = four_direction_degrees(h)
    >>> [round(float(x), 4) for x in degree[0]]
    [0.0, 0.2222, 0.7778, 0.0]
    """
    h = np.asarray(h, dtype=np.float64)
    rows, nbins = h.shape
    n = nbins // 4
    if n > 128:  # longer prefix sums are added in another order (_prefix_sums)
        index = np.tile(np.arange(4) * n, rows)
        d, t, _, _ = many_degrees(np.repeat(h, 4, axis=0), index)
        return d.reshape(rows, 4), t.reshape(rows, 4)
    # A direction with no force within 90° of it has no effective force: degree and
    # deviation 0 (as direction_degree finds), so only the other (row, direction) are computed.
    degree = np.zeros((rows, 4))
    deviation = np.zeros((rows, 4))
    # Direction k's bins -(n-1) .. n-1 are quadrant k and quadrant k-1 but its first bin.
    # The other 2n + 1 bins are its contrary forces: quadrants k+1 and k+2 and the first bin
    # of quadrant k+3. Without any, nothing cancels: the contrary mass is 0.
    quadrants = (h != 0.0).reshape(rows, 4, n)
    whole, inner = quadrants.any(axis=2), quadrants[:, :, 1:].any(axis=2)
    first = quadrants[:, :, 0]
    for k in range(4):
        live = whole[:, k] | inner[:, (k - 1) % 4]
        against = whole[:, (k + 1) % 4] | whole[:, (k + 2) % 4] | first[:, (k + 3) % 4]
        for contrary in (True, False):
            chosen = np.flatnonzero(live & (against == contrary))
            for lo in range(0, chosen.size, DEGREE_BLOCK):
                at = chosen[lo : lo + DEGREE_BLOCK]
                found = _block_degrees(h, at, k * n, contrary)
                degree[at, k], deviation[at, k] = found[0], found[1]
    return degree, deviation


@functools.lru_cache(maxsize=32)
def _turned_columns(
    nbins: int, shift: int
) -> tuple[NDArray[np.intp], NDArray[np.intp], int, NDArray[np.intp]]:
    """The columns of :func:`_block_degrees` for the direction of bin ``shift``: the
    favourable bins of both sides (positive side, then negative, each from the pivot inwards),
    the contrary bins of both sides, the opposite bin, and the favourable bins in the order of
    the effective forces, ``phi = -(n-1) .. n-1`` (all read-only)."""
    c = _constants(nbins)
    n = nbins // 4
    fav = (shift + np.concatenate([c.phis, c.neg_phis])) % nbins
    con = (shift + np.concatenate([c.cphi, c.neg_cphi])) % nbins
    eff = (shift + np.arange(-(n - 1), n)) % nbins
    for a in (fav, con, eff):
        a.setflags(write=False)
    return fav, con, (shift + nbins // 2) % nbins, eff


def _gathered(
    flat: NDArray[np.float64], base: NDArray[np.intp], columns: NDArray[np.intp]
) -> NDArray[np.float64]:
    """``(len(base), len(columns))``: ``flat[base[i] + columns[j]]`` (C-ordered), where ``flat``
    is a C-ordered ``(R, N)`` array raveled and ``base`` the rows' offsets ``row * N``: the
    rows' columns in one ``take`` of the values needed (not the whole rows first)."""
    index = base[:, None] + columns
    return flat.take(index)


def _cancelled(
    fav: NDArray[np.float64], moment: NDArray[np.float64], dist: NDArray[np.float64]
) -> NDArray[np.float64]:
    """:func:`_cancel_side` of every row of ``fav`` (in place) with its ``moment``: the
    cancelled mass of each row (rows without a moment cancel nothing, 0.0)."""
    kernel = _compiled_cancel()
    if kernel is not None and fav.flags.c_contiguous:
        return kernel(fav, np.ascontiguousarray(moment), np.ascontiguousarray(dist))
    cancelled = np.zeros(len(fav))
    rows = np.flatnonzero(moment > 0.0)
    if rows.size == 0:
        return cancelled
    n = fav.shape[1]
    side, moment = fav[rows], moment[rows]
    cum = np.cumsum(side * dist, axis=1)
    full = (cum <= moment[:, None]).sum(axis=1)  # searchsorted "right"
    done = _prefix_sums(side, full)
    side[np.arange(n) < full[:, None]] = 0.0
    every = np.arange(len(rows))
    at = np.minimum(full, n - 1)
    left = moment - np.where(full > 0, cum[every, np.maximum(full - 1, 0)], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        part = np.minimum(side[every, at], left / dist[at])
    cut = np.flatnonzero((full < n) & (left > 0.0) & (dist[at] > 0.0))
    side[cut, at[cut]] -= part[cut]
    done[cut] += part[cut]
    fav[rows] = side
    cancelled[rows] = done
    return cancelled


def _cancel_rows(
    fav: NDArray[np.float64], moment: NDArray[np.float64], dist: NDArray[np.float64]
) -> NDArray[np.float64]:
    """:func:`_cancelled` in plain loops for Numba (:func:`_compiled_cancel`): the same
    operations in the same order on each row, so the same floats (the cumulative cost
    from the pivot inwards, the count of bins it does not pass, the consumed bins' sum in
    :func:`_prefix_sums`' order, the partial bin)."""
    rows, n = fav.shape
    out = np.zeros(rows)
    cum = np.zeros(n + 1)  # cum[j + 1]: the cost of bins 0..j; cum[0] = 0.0
    acc = np.empty(8)
    for r in range(rows):
        m = moment[r]
        if not m > 0.0:
            continue
        run = 0.0
        full = 0
        for j in range(n):
            run += fav[r, j] * dist[j]
            cum[j + 1] = run
            if run <= m:
                full += 1
        blocks = full // 8
        done = 0.0
        if blocks > 0:
            for j in range(8):
                acc[j] = fav[r, j]
            for b in range(1, blocks):
                for j in range(8):
                    acc[j] += fav[r, 8 * b + j]
            done = ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
        for i in range(7):
            col = 8 * blocks + i
            done += fav[r, col] if col < full else 0.0
        for j in range(full):
            fav[r, j] = 0.0
        at = min(full, n - 1)
        left = m - cum[full]
        if full < n and left > 0.0 and dist[at] > 0.0:
            part = min(fav[r, at], left / dist[at])
            fav[r, at] -= part
            done += part
        out[r] = done
    return out


_CANCEL: list[object] = []


def _compiled_cancel() -> Callable[..., NDArray[np.float64]] | None:
    """:func:`_cancel_rows` compiled, when Numba is loaded in this process already (by the
    force sweep; never loaded for this alone), else None. Bit for bit the NumPy path's floats
    (pinned by ``test_compiled_cancellation_is_bit_identical``), so the choice never changes a
    result."""
    from scenespeak.spatial.forces import _jit

    if not _jit.loaded():
        return None
    if not _CANCEL:
        _CANCEL.append(_jit.jit(_cancel_rows))
    return _CANCEL[0]  # type: ignore[return-value]


def _turned_degrees(g: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(4, R)``: degree, deviation, effective and contrary of bin 0's direction of each row
    of ``g`` (``N/4 <= 128``), the operations of :func:`direction_degree`."""
    return _block_degrees(g, np.arange(len(g)), 0)


def _block_degrees(
    h: NDArray[np.float64], at: NDArray[np.intp], shift: int, contrary_forces: bool = True
) -> NDArray[np.float64]:
    """``(4, len(at))``: degree, deviation, effective and contrary of the direction of bin
    ``shift`` of the rows ``at`` of ``h`` (``N/4 <= 128``): the operations of
    :func:`direction_degree`, on all rows at once. ``contrary_forces=False`` says that these
    rows have no force outside the favourable bins: their contrary mass is then 0.0 and
    nothing is cancelled (what :func:`direction_degree` finds), without gathering them."""
    nbins = h.shape[1]
    n = nbins // 4
    rows = len(at)
    c = _constants(nbins)
    fav_cols, con_cols, opposite_col, eff_cols = _turned_columns(nbins, shift)
    # Each value is gathered from the raveled histograms at once (``_gathered``: one
    # ``take`` of the columns needed, about twice as fast as taking the rows first and then
    # their columns). Every array is C-contiguous: NumPy sums a row of a C-ordered array in
    # the same order as a 1-D array, but not always a row of an F-ordered one.
    flat = np.ascontiguousarray(h).reshape(-1)
    base = np.asarray(at, dtype=np.intp) * nbins
    if contrary_forces:
        # Both sides of each row, interleaved: row 2i is row i's positive side, 2i + 1 its
        # negative side.
        fav = _gathered(flat, base, fav_cols).reshape(2 * rows, n)
        fav[:, -1] *= 0.5
        con = _gathered(flat, base, con_cols).reshape(2 * rows, n)
        opposite = 0.5 * flat.take(base + opposite_col)
        moment = _row_dots(con, c.arm) + np.repeat(opposite, 2) * n
        con_sum = con.sum(axis=1)
        contrary = (con_sum[0::2] + con_sum[1::2]) + 2.0 * opposite
        cancelled = _cancelled(fav, moment, c.dist)
        contrary = (contrary + cancelled[0::2]) + cancelled[1::2]
        fav_pos, fav_neg = fav[0::2], fav[1::2]
        eff = np.concatenate(
            [fav_neg[:, :-1], fav_pos[:, -1:] + fav_neg[:, -1:], fav_pos[:, ::-1][:, 1:]], axis=1
        )
    else:
        # Nothing cancelled: the effective forces are the favourable bins in the order of
        # phi, the bin at phi = 0 the sum of its two halves (the same floats as above).
        eff = _gathered(flat, base, eff_cols)
        half = 0.5 * eff[:, n - 1]
        eff[:, n - 1] = half + half
        contrary = np.zeros(rows)
    total = eff.sum(axis=1)
    scale = np.maximum(total + contrary, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = _row_dots(eff, c.weight) / c.weight_sum
        above = eff - tau[:, None]
        np.maximum(above, 0.0, out=above)
        mass = above.sum(axis=1)
        if bool((mass > 0.0).all()):
            theta = _row_dots(above, c.phi) / mass
        else:
            theta = np.where(
                mass > 0.0, _row_dots(above, c.phi) / mass, _row_dots(eff, c.phi) / total
            )
        degree = np.maximum(0.0, 1.0 - np.abs(theta) / (np.pi / 2.0)) * total / (total + contrary)
    zero = total <= 1e-12 * scale
    out = np.empty((4, rows))
    out[0] = np.where(zero, 0.0, np.minimum(np.maximum(degree, 0.0), 1.0))
    out[1] = np.where(zero, 0.0, theta)
    out[2] = np.where(zero, np.maximum(total, 0.0), total)
    out[3] = contrary
    return out


def four_degrees(h: NDArray[np.float64]) -> dict[str, DirectionDegree]:
    """Degrees of truth of the four directions (see :data:`DIRECTIONS`).

    Examples
    --------
    >>> h = np.ones(180)
    >>> [round(d.degree, 12) for d in four_degrees(h).values()]
    [0.0, 0.0, 0.0, 0.0]
    """
    h = check_histogram(h)
    n = h.size // 4
    return {name: direction_degree(h, k * n) for k, name in enumerate(DIRECTIONS)}
