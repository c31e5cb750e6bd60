"""The rule base on arrays of pairs: every step of :mod:`~.rules` for many histograms at once.

:func:`decide_pairs` takes the degrees of truth of many ordered pairs (rows) and returns, as
arrays, the decision :func:`~.rules._decide` takes for each row; :func:`coverages` and
:func:`sector_shares` are :func:`~.rules._coverage` and :func:`~.rules._sector_share` of many
rows. Each gives the same floats as the per-pair function it replaces (the same operations on
the same numbers, row by row; pinned by ``tests/spatial/test_relate_batch.py``), so that
:func:`~.relate.relate_objects` says exactly what :func:`~.pairs.relations_of_pair` says. The
per-pair functions stay the reference and the path of a single pair.

Codes of :class:`PairDecisions` (``-1`` is None):

- ``kind``: the index in :data:`KINDS`;
- ``primary``, ``secondary``: the index in :data:`~scenespeak.spatial.degrees.DIRECTIONS`,
  ``primary == 4`` for "surrounded";
- ``hedge``: the index in :data:`HEDGES`; ``secondary_hedge``: in :data:`SECONDARY_HEDGES`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scenespeak.spatial.degrees import DIRECTIONS
from scenespeak.spatial.language.rules import _coverage, _sector_weights
from scenespeak.spatial.language.thresholds import Thresholds
from scenespeak.spatial.language.words import _Decision, _render

__all__ = ["HEDGES", "KINDS", "SECONDARY_HEDGES", "PairDecisions", "coverages", "decide_pairs"]

#: ``PairDecisions.kind`` codes.
KINDS: tuple[str, ...] = (
    "direction",
    "compound",
    "surrounded",
    "partly surrounded",
    "surrounds",
    "partly surrounds",
)
#: ``PairDecisions.hedge`` codes.
HEDGES: tuple[str, ...] = ("directly", "mostly", "loosely")
#: ``PairDecisions.secondary_hedge`` codes.
SECONDARY_HEDGES: tuple[str, ...] = ("somewhat", "slightly", "extends")

_DIRECTION, _COMPOUND, _SURROUNDED, _PARTLY, _SURROUNDS, _PARTLY_SURROUNDS = range(6)
_DIRECTLY, _MOSTLY, _LOOSELY = range(3)
_SOMEWHAT, _SLIGHTLY, _EXTENDS = range(3)
_RIGHT, _BEHIND, _LEFT, _FRONT = range(4)
_SURROUND_PRIMARY = 4


@dataclass(frozen=True)
class PairDecisions:
    """:func:`~.rules._decide`'s decision for every row, as arrays (codes: see the module).

    Attributes
    ----------
    kind, primary, secondary, hedge, secondary_hedge : (R,) int arrays
    confidence, deviation, coverage, extends_share : (R,) float64 arrays
    """

    kind: NDArray[np.intp]
    primary: NDArray[np.intp]
    secondary: NDArray[np.intp]
    hedge: NDArray[np.intp]
    secondary_hedge: NDArray[np.intp]
    confidence: NDArray[np.float64]
    deviation: NDArray[np.float64]
    coverage: NDArray[np.float64]
    extends_share: NDArray[np.float64]


def coverages(f0: NDArray[np.float64], t: Thresholds) -> NDArray[np.float64]:
    """``[_coverage(row, t) for row in f0]``: the same floats, for all rows at once.

    The smoothed F0 is taken as a difference of running sums, which rounds differently from
    :func:`~.rules._coverage`'s convolution by at most ``~1e-13`` of the row's mass; a bin is
    covered when its smoothed force reaches ``coverage_level`` of the largest. Wherever a bin
    lies within ``1e-9`` of the row's mass of that level, so that the rounding could tell, the
    row is computed by :func:`~.rules._coverage` itself, so the result is the reference's.

    Examples
    --------
    >>> from scenespeak.spatial.language import DEFAULT_THRESHOLDS
    >>> h = np.zeros((2, 180)); h[0, 10:30] = 1.0; h[1] = 1.0
    >>> coverages(h, DEFAULT_THRESHOLDS).tolist()     # 20 bins and 4 each side; all
    [0.15555555555555556, 1.0]
    """
    # In blocks of rows, so that the temporaries stay in the cache.
    out = [_block_coverages(f0[lo : lo + _BLOCK], t) for lo in range(0, len(f0), _BLOCK)]
    return np.concatenate(out) if out else np.zeros(0)


#: Rows of one block of :func:`coverages`.
_BLOCK = 1024


def _block_coverages(f0: NDArray[np.float64], t: Thresholds) -> NDArray[np.float64]:
    """:func:`coverages` of one block of rows."""
    rows, nbins = f0.shape
    k = round(t.coverage_smooth_deg / (360.0 / nbins))
    top = f0.max(axis=1)
    kernel = _compiled_counts() if 0 < k and 2 * k + 1 <= nbins else None
    if kernel is not None:
        # The same counts in one compiled pass (the same guard: rows it cannot tell go to
        # the reference), where Numba is loaded already (for the force sweep).
        counts, exact = kernel(np.ascontiguousarray(f0), k, t.coverage_level)
        out = np.where(top > 0.0, counts / nbins, 0.0)
        for r in np.flatnonzero(~exact & (top > 0.0)).tolist():
            out[r] = _coverage(f0[r], t)
        return out
    if k <= 0 or 2 * k + 1 > nbins:
        # No smoothing: the reference's own operations. A window wider than the histogram:
        # the reference row by row.
        covered = f0 >= t.coverage_level * top[:, None]
        exact = np.full(rows, k <= 0)
    else:
        padded = np.concatenate([f0[:, -k:], f0, f0[:, :k]], axis=1)
        run = np.zeros((rows, padded.shape[1] + 1))
        np.cumsum(padded, axis=1, out=run[:, 1:])
        # Window sums (the smoothed F0 times 2k + 1) against the level times 2k + 1.
        window = run[:, 2 * k + 1 :] - run[:, : -(2 * k + 1)]
        gap = window - (t.coverage_level * window.max(axis=1))[:, None]
        covered = gap >= 0.0
        np.abs(gap, out=gap)
        exact = ~np.any(gap <= (1e-9 * run[:, -1])[:, None], axis=1)
    # np.mean of a boolean row is its count over its length: the same division.
    out = np.where(top > 0.0, covered.sum(axis=1) / nbins, 0.0)
    for r in np.flatnonzero(~exact & (top > 0.0)).tolist():
        out[r] = _coverage(f0[r], t)
    return out


def _window_counts(
    f0: NDArray[np.float64], k: int, level: float
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Per row: the bins whose circular window of ``2k + 1`` bins holds at least ``level`` of
    the largest window's sum, and whether no window lies within ``1e-9`` of the row's padded
    mass of that level (else the rounding could tell; :func:`_block_coverages`' guard).

    Plain loops for Numba (:func:`_compiled_counts`); a sliding sum, whose rounding (about
    ``nbins`` ulps of the mass) stays far inside the guard.
    """
    rows, nbins = f0.shape
    counts = np.zeros(rows, dtype=np.int64)
    exact = np.ones(rows, dtype=np.bool_)
    window = np.empty(nbins)
    for r in range(rows):
        s = 0.0
        for j in range(-k, k + 1):
            s += f0[r, j % nbins]
        mass = 0.0
        for j in range(nbins):
            mass += f0[r, j]
        for j in range(k):
            mass += f0[r, j] + f0[r, nbins - 1 - j]
        top = s
        enter, leave = k + 1, nbins - k  # the bins that enter and leave the next window
        for b in range(nbins):
            window[b] = s
            if s > top:
                top = s
            s += f0[r, enter % nbins] - f0[r, leave]
            enter += 1
            leave = leave + 1 if leave + 1 < nbins else 0
        cut = level * top
        tol = 1e-9 * mass
        n = 0
        for b in range(nbins):
            gap = window[b] - cut
            if gap >= 0.0:
                n += 1
            if abs(gap) <= tol:
                exact[r] = False
        counts[r] = n
    return counts, exact


_KERNEL: list[object] = []


def _compiled_counts() -> Callable[..., tuple[NDArray[np.int64], NDArray[np.bool_]]] | None:
    """:func:`_window_counts` compiled, when Numba is loaded in this process (by the force
    sweep; never loaded for this alone), else None. The counts are exact either way (rows
    the guard cannot tell take the reference), so the choice never changes a result."""
    from scenespeak.spatial.forces import _jit

    if not _jit.loaded():
        return None
    if not _KERNEL:
        _KERNEL.append(_jit.jit(_window_counts))
    return _KERNEL[0]  # type: ignore[return-value]


def sector_shares(f0: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(R, 4)``: :func:`~.rules._sector_share` of every row and every direction.

    The same floats: each row's total is its own (pairwise) sum and each weighted sum one dot
    product of the row with the direction's weights, as for a single histogram.
    """
    rows, nbins = f0.shape
    total = f0.sum(axis=1)
    out = np.zeros((rows, 4))
    live = total > 0.0
    if not live.any():
        return out
    part = f0 if bool(live.all()) else f0[live]
    for k, name in enumerate(DIRECTIONS):
        weight = _sector_weights(nbins, name)
        # A stack of (1, N) @ (N, 1) is one dot product per row (as ``weight @ f0``).
        dots = np.matmul(part[:, None, :], weight[:, None])[:, 0, 0]
        out[live, k] = dots / total[live]
    return out


def decide_pairs(
    degrees: tuple[NDArray[np.float64], NDArray[np.float64]],
    deviation2: NDArray[np.float64],
    shares: NDArray[np.float64],
    overlaps: tuple[NDArray[np.float64], NDArray[np.float64]],
    coverage: NDArray[np.float64],
    t: Thresholds,
) -> PairDecisions:
    """:func:`~.rules._decide` of every row: surround, compound, hedge, extends, secondary.

    Parameters
    ----------
    degrees : ((R, 4), (R, 4)) float arrays
        The degrees of truth of the four directions from F0 and from F2 (or F02).
    deviation2 : (R, 4) float array
        F2's mean deviation from each direction (radians).
    shares : (R, 4) float array
        :func:`sector_shares` of F0.
    overlaps : ((R,), (R,)) float arrays
        ``overlap`` and ``referent_overlap`` of each pair (0 for disjoint footprints).
    coverage : (R,) float array
        :func:`coverages` of F0.
    t : Thresholds

    Returns
    -------
    PairDecisions

    Examples
    --------
    >>> from scenespeak.spatial.language import DEFAULT_THRESHOLDS
    >>> a = np.array([[0.0, 0.2, 0.8, 0.0]])               # left, leaning behind
    >>> z = np.zeros(1)
    >>> got = decide_pairs((a, a), np.full((1, 4), -0.3), np.zeros((1, 4)), (z, z), z,
    ...                    DEFAULT_THRESHOLDS)
    >>> DIRECTIONS[got.primary[0]], DIRECTIONS[got.secondary[0]]
    ('left', 'behind')
    >>> SECONDARY_HEDGES[got.secondary_hedge[0]]
    'slightly'
    """
    a0, a2 = degrees
    rows = np.arange(len(a0))
    a = 0.5 * (a0 + a2)
    primary = np.argmax(a, axis=1)  # ties: the first in DIRECTIONS order, as max() takes it
    best = a[rows, primary]
    deviation = deviation2[rows, primary]
    ccw, cw = (primary + 1) % 4, (primary - 1) % 4
    a_ccw, a_cw = a[rows, ccw], a[rows, cw]
    near = np.where((a_ccw > a_cw) | ((a_ccw == a_cw) & (deviation >= 0)), ccw, cw)

    surround, surround_kind = _surround_kinds(coverage, best, overlaps, t)
    a_near = a[rows, near]
    compound = ~surround & ~(
        (np.minimum(best, a_near) < t.compound_min) | (best - a_near >= t.compound_gap)
    )
    upright = (primary == _BEHIND) | (primary == _FRONT)
    fb, lr = np.where(upright, primary, near), np.where(upright, near, primary)
    agree = 1.0 - 0.5 * (np.abs(a0[rows, fb] - a2[rows, fb]) + np.abs(a0[rows, lr] - a2[rows, lr]))
    compound_conf = 0.5 * (a[rows, fb] + a[rows, lr]) * agree

    hedge = _hedges(best, t)
    conf = best * (1.0 - np.abs(a0[rows, primary] - a2[rows, primary]))
    s_ccw, s_cw = shares[rows, ccw], shares[rows, cw]
    first = s_ccw >= s_cw
    reach, s_reach = np.where(first, ccw, cw), np.where(first, s_ccw, s_cw)
    s_other = np.where(first, s_cw, s_ccw)
    extends = (
        ~surround
        & ~compound
        & (np.abs(deviation * (180.0 / math.pi)) < t.extends_deviation_deg)
        & (s_reach - s_other >= t.extends_share)
    )
    secondary, secondary_hedge = _secondaries(a, (ccw, cw, near), deviation, t)
    has_secondary = secondary >= 0
    share = np.where(has_secondary, shares[rows, np.maximum(secondary, 0)], 0.0)
    # "directly ... but slightly" would contradict itself.
    plain_hedge = np.where(has_secondary & (hedge == _DIRECTLY), -1, hedge)

    by_kind = (surround, compound, extends)
    return PairDecisions(
        kind=np.select(by_kind, [surround_kind, _COMPOUND, _DIRECTION], _DIRECTION),
        primary=np.select(by_kind, [_SURROUND_PRIMARY, fb, primary], primary),
        secondary=np.select(by_kind, [-1, lr, reach], secondary),
        hedge=np.select(by_kind, [-1, -1, hedge], plain_hedge),
        secondary_hedge=np.select(by_kind, [-1, -1, _EXTENDS], secondary_hedge),
        confidence=np.select(by_kind, [coverage * (1.0 - best), compound_conf, conf], conf),
        deviation=deviation,
        coverage=coverage,
        extends_share=np.select(by_kind, [0.0, 0.0, s_reach], share),
    )


def _surround_kinds(
    coverage: NDArray[np.float64],
    best: NDArray[np.float64],
    overlaps: tuple[NDArray[np.float64], NDArray[np.float64]],
    t: Thresholds,
) -> tuple[NDArray[np.bool_], NDArray[np.intp]]:
    """Step 1 of every row (:func:`~.rules._surround_kind`): whether it is a surround, and
    which kind."""
    overlap, referent_overlap = overlaps
    can = overlap > 0.0
    full = can & (coverage >= t.surround_full) & (best < t.fits)
    part = can & ~full & (coverage >= t.surround_part) & (best < t.fits_partly)
    encloses = referent_overlap > overlap
    kind = np.where(full, _SURROUNDED, _PARTLY) + np.where(encloses, 2, 0)
    return full | part, kind


def _hedges(value: NDArray[np.float64], t: Thresholds) -> NDArray[np.intp]:
    """Step 3 of every row (:func:`~.rules._hedge`); -1 for no hedge."""
    return np.select(
        [value >= t.directly, value >= t.plain, value >= t.mostly],
        [_DIRECTLY, -1, _MOSTLY],
        _LOOSELY,
    )


def _secondaries(
    a: NDArray[np.float64],
    sides: tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]],
    deviation: NDArray[np.float64],
    t: Thresholds,
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Step 4b of every row (:func:`~.rules._secondary`): the secondary direction and its
    hedge, -1 for none."""
    ccw, cw, near = sides
    rows = np.arange(len(a))
    tie = a[rows, ccw] == a[rows, cw]
    side = np.select([deviation > 0, deviation < 0, ~tie], [ccw, cw, near], -1)
    value = a[rows, np.maximum(side, 0)]
    keep = (side >= 0) & (value >= t.secondary_min)
    hedge = np.where(value >= t.somewhat, _SOMEWHAT, _SLIGHTLY)
    return np.where(keep, side, -1), np.where(keep, hedge, -1)


def sentence_templates(
    decisions: PairDecisions, frame: str = "object"
) -> tuple[list[str], dict[str, str]]:
    """Each row's horizontal sentence with ``{argument}`` and ``{referent}`` left to fill, and
    the vertical sentences' templates by word (the patterns of :mod:`~.words`)."""
    from scenespeak.spatial.language.words import VERTICAL_WORDS

    d = decisions
    # One code per distinct decision; each decision's template is rendered once.
    code = d.kind * 5 + (d.primary + 1)
    for part, size in ((d.secondary, 5), (d.hedge, 4), (d.secondary_hedge, 4)):
        code = code * size + (part + 1)
    _, first, inverse = np.unique(code, return_index=True, return_inverse=True)
    parts = np.column_stack([d.kind, d.primary, d.secondary, d.hedge, d.secondary_hedge])
    rendered = [_template(*row, frame=frame) for row in parts[first].tolist()]
    out: list[str] = np.array(rendered, dtype=object)[inverse.reshape(-1)].tolist()
    blank = _Decision("direction", "left", None, None, None, 0.0, 0.0, 0.0, 0.0)
    vertical = {
        word: _render(blank, "{argument}", "{referent}", frame, word) for word in VERTICAL_WORDS
    }
    return out, vertical


def _template(
    kind: int, primary: int, secondary: int, hedge: int, secondary_hedge: int, *, frame: str
) -> str:
    """The sentence of one decision with ``{argument}`` / ``{referent}`` left to fill."""
    decision = _Decision(
        KINDS[kind],
        "surrounded" if primary == _SURROUND_PRIMARY else DIRECTIONS[primary],
        None if secondary < 0 else DIRECTIONS[secondary],
        None if hedge < 0 else HEDGES[hedge],
        None if secondary_hedge < 0 else SECONDARY_HEDGES[secondary_hedge],
        0.0,
        0.0,
        0.0,
        0.0,
    )
    return _render(decision, "{argument}", "{referent}", frame)
