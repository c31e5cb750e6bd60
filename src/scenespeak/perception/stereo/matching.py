"""Sparse left/right matching: ratio test, epipolar band, cross check, dense verification."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.calibration import Rectification
from scenespeak.perception.features import Features
from scenespeak.perception.stereo.options import MatchOptions
from scenespeak.perception.stereo.results import DenseDisparity, StereoMatches

__all__ = ["match_stereo"]

_SAME_PLACE_PX = 2.0  # keypoints closer than this are "the same place" (OpenCV duplicates)
_CHUNK = 1024  # left descriptors per block of the distance matrix (bounds memory)


@dataclass(frozen=True, eq=False)
class _Candidates:
    """Nearest right neighbours of every left descriptor, globally and inside the band."""

    g_best: NDArray[np.intp]  # global best right index
    g_d1: NDArray[np.float32]
    g_d2: NDArray[np.float32]  # second best at another place (inf if none)
    b_best: NDArray[np.intp]  # best inside the band (-1 if none)
    b_d1: NDArray[np.float32]
    b_d2: NDArray[np.float32]
    g_back: NDArray[np.intp]  # for each right keypoint, its global best left keypoint
    b_back: NDArray[np.intp]  # for each right keypoint, its best left keypoint inside the band
    left_rect: NDArray[np.float64]
    right_rect: NDArray[np.float64]


def _smallest(dist: NDArray[np.float32], k: int) -> NDArray[np.intp]:
    """Column indices of the k smallest values of each row, sorted."""
    n, m = dist.shape
    if k < m:
        part = np.argpartition(dist, k - 1, axis=1)[:, :k]
    else:
        part = np.tile(np.arange(m), (n, 1))
    return np.take_along_axis(part, np.argsort(np.take_along_axis(dist, part, 1), 1), 1)


def _group_best(
    ii: NDArray[np.intp],
    jj: NDArray[np.intp],
    dd: NDArray[np.float32],
    n: int,
    rxy: NDArray[np.float64],
) -> tuple[NDArray[np.intp], NDArray[np.float32], NDArray[np.float32]]:
    """Best and second best (at another place) per group ``ii`` of candidate pairs.

    The pairs are ordered by group, then distance, then as given: ``np.lexsort((dd, ii))``'s
    order, from one stable sort of a 64-bit key (the group in the high half, the distance's
    float32 bits in the low half; a non-negative float32's bits order as its value), about
    5x faster than the two-key sort (issue 16). ``ii`` are indices (0 <= ii < 2**32), ``dd``
    non-negative distances.
    """
    best = np.full(n, -1, np.intp)
    d1 = np.full(n, np.inf, np.float32)
    d2 = np.full(n, np.inf, np.float32)
    if len(ii) == 0:
        return best, d1, d2
    key = np.asarray(ii).astype(np.uint64) << np.uint64(32)
    key |= np.asarray(dd, np.float32).view(np.uint32)
    o = np.argsort(key, kind="stable")
    ii, jj, dd = ii[o], jj[o], dd[o]
    first = np.flatnonzero(np.r_[True, ii[1:] != ii[:-1]])
    best[ii[first]] = jj[first]
    d1[ii[first]] = dd[first]
    far = np.linalg.norm(rxy[jj] - rxy[best[ii]], axis=1) > _SAME_PLACE_PX
    fi = np.flatnonzero(far)
    if len(fi):
        grp = ii[fi]
        f2 = fi[np.r_[True, grp[1:] != grp[:-1]]]
        d2[ii[f2]] = dd[f2]
    return best, d1, d2


def _global_block(
    sq: NDArray[np.float32], k: int, rxy: NDArray[np.float64]
) -> tuple[
    NDArray[np.intp],
    NDArray[np.float32],
    NDArray[np.float32],
    NDArray[np.intp],
    NDArray[np.float32],
]:
    """Global nearest neighbours of one block of squared distances.

    Returns, for each left row, the best right index, its distance and the second best at
    another place (inf if none); for each right column, the block's nearest left row and its
    distance (the caller keeps the best over all blocks).
    """
    n, nr = sq.shape
    rows = np.arange(n)
    order = _smallest(sq, k)
    near = np.sqrt(np.take_along_axis(sq, order, 1))
    far = np.linalg.norm(rxy[order] - rxy[order[:, :1]], axis=2) > _SAME_PLACE_PX
    far[:, 0] = False
    d2 = np.where(far.any(1), near[rows, np.argmax(far, 1)], np.inf)
    cmin = sq.argmin(0)
    cval = np.sqrt(sq[cmin, np.arange(nr)])
    return order[:, 0], near[:, 0], d2, cmin, cval


def _band_pairs(
    dl: NDArray[np.uint8],
    dr: NDArray[np.uint8],
    lrect: NDArray[np.float64],
    rrect: NDArray[np.float64],
    band_px: float,
    lo_disp: float,
    hi_disp: float | None,
    chunk: int = 256,
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float32]]:
    """All (left, right, distance) pairs inside the epipolar band and disparity range.

    Left keypoints are taken in row order; each is compared only with the right keypoints in
    its band of rows (a run of the row-sorted right keypoints, within the run of its block of
    ``chunk`` left keypoints), and a descriptor distance is computed only for the pairs that
    pass the band and disparity tests, in integers from the uint8 descriptors. The pairs come
    in the order of the blocked float32 distance matrix this replaced (left in row order, then
    right in row order) with the same float32 distances: for whole numbers in 0..255 every
    partial sum of ``|l|² + |r|² - 2 l·r`` is a whole number below 2**24, which float32 holds
    exactly in any order (issue 16, session 7: 5-7x less time on the real pairs).
    """
    nl = len(dl)
    lo_order = np.argsort(lrect[:, 1], kind="stable")
    ro = np.argsort(rrect[:, 1], kind="stable")
    ry = rrect[ro, 1]
    ly = lrect[lo_order, 1]
    # each left keypoint's run of right keypoints: inside its block's run (the blocks' rows
    # as before), and a little wider than the band (the exact test below decides)
    first = np.empty(nl, np.intp)
    last = np.empty(nl, np.intp)
    for s in range(0, nl, chunk):
        lyc = ly[s : s + chunk]
        first[s : s + chunk] = int(np.searchsorted(ry, lyc.min() - band_px, "left"))
        last[s : s + chunk] = int(np.searchsorted(ry, lyc.max() + band_px, "right"))
    wide = band_px + 0.5  # more than any rounding of the test below
    np.maximum(first, np.searchsorted(ry, ly - wide, "left"), out=first)
    np.minimum(last, np.searchsorted(ry, ly + wide, "right"), out=last)
    count = np.maximum(last - first, 0)
    total = int(count.sum())
    pos = np.arange(total) - np.repeat(np.cumsum(count) - count, count)
    li = np.repeat(lo_order, count)
    rj = ro[np.repeat(first, count) + pos]
    ok = np.abs(lrect[li, 1] - rrect[rj, 1]) <= band_px
    dsp = lrect[li, 0] - rrect[rj, 0]
    ok &= dsp > lo_disp
    if hi_disp is not None:
        ok &= dsp <= hi_disp
    li, rj = li[ok], rj[ok]
    norm_l = np.einsum("ij,ij->i", dl, dl, dtype=np.int32)
    norm_r = np.einsum("ij,ij->i", dr, dr, dtype=np.int32)
    dot = np.einsum("ij,ij->i", dl[li], dr[rj], dtype=np.int32)
    sq = norm_l[li] + norm_r[rj] - 2 * dot
    return li, rj, np.sqrt(sq.astype(np.float32))


def _candidates(
    fl: Features,
    fr: Features,
    rect: Rectification,
    band_px: float,
    min_disparity: float,
    max_disparity: float | None,
    *,
    need_global: bool = True,
) -> _Candidates:
    """Global and in-band nearest neighbours.

    The global search (blocked full distance matrix) keeps the ``k`` nearest right descriptors
    of each left one and the best left one of each right one; the band search compares each
    left keypoint only with the right keypoints in its band of rows.
    """
    lrect = rect.rectify_points(fl.xy, "left")
    rrect = rect.rectify_points(fr.xy, "right")
    nl, nr = len(fl), len(fr)
    g_best = np.zeros(nl, np.intp)
    g_d1 = np.full(nl, np.inf, np.float32)
    g_d2 = np.full(nl, np.inf, np.float32)
    col_g = np.full(nr, np.inf, np.float32)
    g_back = np.zeros(nr, np.intp)
    if need_global:
        dl = fl.descriptors.astype(np.float32)
        dr = fr.descriptors.astype(np.float32)
        rn = (dr * dr).sum(1)
        k = min(4, nr)
        for s in range(0, nl, _CHUNK):
            q = dl[s : s + _CHUNK]
            sq = (q * q).sum(1)[:, None] + rn[None, :] - 2.0 * (q @ dr.T)
            np.maximum(sq, 0.0, out=sq)
            best, d1, d2, cmin, cval = _global_block(sq, k, fr.xy)
            g_best[s : s + len(q)] = best
            g_d1[s : s + len(q)] = d1
            g_d2[s : s + len(q)] = d2
            better = cval < col_g
            col_g[better] = cval[better]
            g_back[better] = cmin[better] + s
    doffs = rect.doffs
    bi, bj, bd = _band_pairs(
        fl.descriptors,
        fr.descriptors,
        lrect,
        rrect,
        band_px,
        min_disparity - doffs,
        None if max_disparity is None else max_disparity - doffs,
    )
    b_best, b_d1, b_d2 = _group_best(bi, bj, bd, nl, fr.xy)
    b_back, _, _ = _group_best(bj, bi, bd, nr, fl.xy)
    return _Candidates(g_best, g_d1, g_d2, b_best, b_d1, b_d2, g_back, b_back, lrect, rrect)


def _select(
    c: _Candidates,
    fl: Features,
    rect: Rectification,
    search: Literal["global", "band"],
    ratio: float,
    o: MatchOptions,
) -> StereoMatches:
    """The matches that pass the ratio test (``ratio``), the band and the cross check of ``o``."""
    band_px, min_disparity, max_disparity = o.band_px, o.min_disparity, o.max_disparity
    nl = len(c.g_best)
    li = np.arange(nl)
    if search == "global":
        ri = c.g_best
        d1, d2, back = c.g_d1, c.g_d2, c.g_back
        ok = d1 < ratio * d2
        dy = np.abs(c.left_rect[:, 1] - c.right_rect[ri, 1]) if nl else np.zeros(0)
        disp = (c.left_rect[:, 0] - c.right_rect[ri, 0] + rect.doffs) if nl else np.zeros(0)
        ok &= (dy <= band_px) & (disp > min_disparity)
        if max_disparity is not None:
            ok &= disp <= max_disparity
    else:
        ri = np.where(c.b_best >= 0, c.b_best, 0)
        d1, d2, back = c.b_d1, c.b_d2, c.b_back
        ok = (c.b_best >= 0) & (d1 < ratio * d2)
    if o.mutual and nl:
        bl = back[ri]
        ok &= (bl >= 0) & (
            np.linalg.norm(fl.xy[np.maximum(bl, 0)] - fl.xy, axis=1) <= _SAME_PLACE_PX
        )
    li, ri = li[ok], ri[ok]
    with np.errstate(invalid="ignore", divide="ignore"):
        rat = np.where(np.isfinite(d2[ok]), d1[ok] / d2[ok], 0.0).astype(np.float32)
    return StereoMatches(
        li.astype(np.intp),
        ri.astype(np.intp),
        c.left_rect[li],
        c.right_rect[ri],
        d1[ok].astype(np.float32),
        rat,
    )


def _verify_dense(
    m: StereoMatches, dense: DenseDisparity, tol: float, edge_px: float, window: int
) -> NDArray[np.bool_]:
    """Matches whose disparity agrees with the dense map and that sit on no depth edge."""
    disp = dense.disparity
    h, w = disp.shape
    if len(m) == 0:
        return np.zeros(0, bool)
    c = np.rint(m.left_rect).astype(np.intp)
    inside = (c[:, 0] >= 0) & (c[:, 0] < w) & (c[:, 1] >= 0) & (c[:, 1] < h)
    r = window // 2
    off = np.arange(-r, r + 1)
    ys = np.clip(c[:, 1, None, None] + off[None, :, None], 0, h - 1)
    xs = np.clip(c[:, 0, None, None] + off[None, None, :], 0, w - 1)
    patch = disp[ys, xs].reshape(len(m), -1)
    centre = disp[np.clip(c[:, 1], 0, h - 1), np.clip(c[:, 0], 0, w - 1)]
    with np.errstate(invalid="ignore"):
        agree = np.abs(centre - m.disparity) <= tol
        finite = np.all(np.isfinite(patch), axis=1)
        rng = np.where(finite, np.ptp(np.where(finite[:, None], patch, 0.0), axis=1), np.inf)
        smooth = rng <= edge_px
    return inside & agree & smooth


def match_stereo(
    features_left: Features,
    features_right: Features,
    rect: Rectification,
    *,
    dense: DenseDisparity | None = None,
    options: MatchOptions | None = None,
    **overrides: object,
) -> StereoMatches:
    """Match left to right keypoints of a stereo pair.

    Parameters
    ----------
    features_left, features_right : Features
        SIFT features of the input images (as given, not rectified).
    rect : Rectification
        From :func:`~scenespeak.perception.calibration.rectify`.
    dense : DenseDisparity, optional
        Verify matches against a dense map: keep a match when the dense disparity at the left
        keypoint agrees within ``dense_tol_px`` and the dense map varies by at most ``edge_px``
        in the ``edge_window`` × ``edge_window`` pixels around it (no depth edge, no hole).
    options : MatchOptions, optional
        Ratio test, band, disparity range, cross check, search, dense check (the defaults
        otherwise).
    **overrides
        Single fields of :class:`MatchOptions` (``ratio=0.7``, ``band_px=2.0``, ...), as the
        keywords this function took before it had options.

    Returns
    -------
    StereoMatches
        Possibly empty (e.g. textureless images).
    """
    o = MatchOptions.with_overrides(options, overrides)
    if not 0.0 < o.ratio <= 1.0:
        raise ValueError(f"ratio must be in (0, 1], got {o.ratio}")
    if len(features_left) == 0 or len(features_right) == 0:
        return _no_matches()
    mode: Literal["global", "band"] = (
        ("band" if dense is not None else "global") if o.search == "auto" else o.search
    )
    cand = _candidates(
        features_left,
        features_right,
        rect,
        o.band_px,
        o.min_disparity,
        o.max_disparity,
        need_global=mode == "global",
    )
    ratio = o.ratio if mode == "global" else o.band_ratio
    m = _select(cand, features_left, rect, mode, ratio, o)
    if dense is not None:
        m = m.subset(_verify_dense(m, dense, o.dense_tol_px, o.edge_px, o.edge_window))
    return m


def _no_matches() -> StereoMatches:
    z = np.zeros(0, np.intp)
    zf = np.zeros(0, np.float32)
    return StereoMatches(z, z.copy(), np.zeros((0, 2)), np.zeros((0, 2)), zf, zf.copy())
