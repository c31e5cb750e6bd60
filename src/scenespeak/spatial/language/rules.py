"""The rule base: force histograms → a decision (direction, hedges, compound, surround).

The steps, each with the threshold that governs it (:class:`~.thresholds.Thresholds`):
degrees of truth of the four directions from F0 and F2, *surrounded* first, then the primary
direction with its hedge, a compound direction, and the secondary direction or "extends to".
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TypedDict, Unpack

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError
from scenespeak.spatial.degrees import DIRECTIONS, DirectionDegree, four_degrees
from scenespeak.spatial.language.relation import Relation
from scenespeak.spatial.language.thresholds import DEFAULT_THRESHOLDS, Thresholds
from scenespeak.spatial.language.words import VERTICAL_WORDS, _Decision, _label, _render

__all__ = ["FactKeywords", "RelationFacts", "describe_relation"]

_ANGLE_DEG = {"right": 0.0, "behind": 90.0, "left": 180.0, "front": 270.0}


def _as_histogram(h: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        raw = np.asarray(h)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"must be a 1-D array of forces ({exc})") from None
    if raw.dtype.kind not in "iuf" or np.iscomplexobj(raw):
        raise InputError(name, f"must be a 1-D array of real forces, got dtype {raw.dtype}")
    a = raw.astype(np.float64)
    if a.ndim != 1 or a.size < 8 or a.size % 4:
        raise InputError(
            name,
            f"must be a 1-D histogram whose length is a multiple of 4 (>= 8), got shape "
            f"{a.shape}; compute it with scenespeak.spatial.forces (directions=180 by default)",
        )
    if not np.all(np.isfinite(a)):
        raise InputError(
            name,
            "has non-finite values; for touching or overlapping objects pass "
            "the hybrid F02 histogram (scenespeak.spatial.forces.hybrid_histogram)",
        )
    if np.any(a < -1e-9 * max(float(np.abs(a).max()), 1e-300)):
        raise InputError(name, "has negative forces; a force histogram is non-negative")
    return np.maximum(a, 0.0)


#: A histogram whose largest force is below this says nothing (all zero, or denormal noise).
_NOTHING = 1e-290


def _check_something(a: NDArray[np.float64], name: str) -> None:
    """Refuse a histogram with no force in any direction: it must never become a sentence."""
    top = float(a.max(initial=0.0))
    if not top > _NOTHING:
        raise InputError(
            name,
            "is zero in every direction (no force between the objects: empty, identical or "
            "degenerate regions), so nothing can be said about where one is from the other",
        )
    with np.errstate(over="ignore"):  # said once, below: not numpy's warning line too
        total = float(a.sum())
    if not math.isfinite(total):
        raise InputError(name, "forces are too large to add up in float64; normalise the histogram")


def _as_histograms(
    histograms: Sequence[NDArray[np.float64]], names: tuple[str, ...]
) -> list[NDArray[np.float64]]:
    """``[_as_histogram(h, names[k % len(names)]) for k, h in enumerate(histograms)]`` for
    float64 histograms of one length: the checks and the clipping at 0 done on all rows at
    once (the same values; the first bad one raises the same error)."""
    if not histograms:
        return []
    stack = np.stack(histograms)
    size = stack.shape[1]
    ok = size >= 8 and size % 4 == 0 and bool(np.isfinite(stack).all())
    if ok:
        floor = -1e-9 * np.maximum(np.abs(stack).max(axis=1), 1e-300)
        ok = not bool(np.any(stack < floor[:, None]))
    if not ok:
        return [_as_histogram(h, names[k % len(names)]) for k, h in enumerate(histograms)]
    return list(np.maximum(stack, 0.0))


def _coverage(f0: NDArray[np.float64], t: Thresholds) -> float:
    nbins = f0.size
    if float(f0.max()) <= 0.0:
        return 0.0
    k = round(t.coverage_smooth_deg / (360.0 / nbins))
    if k > 0:
        kernel = _box_kernel(k)
        padded = np.concatenate([f0[-k:], f0, f0[:k]])
        smooth = np.convolve(padded, kernel, mode="valid")
    else:
        smooth = f0
    return float(np.mean(smooth >= t.coverage_level * smooth.max()))


@functools.lru_cache(maxsize=16)
def _box_kernel(k: int) -> NDArray[np.float64]:
    """The moving average of ``2k + 1`` bins (read-only, computed once per ``k``)."""
    kernel = np.ones(2 * k + 1) / (2 * k + 1)
    kernel.setflags(write=False)
    return kernel


@functools.lru_cache(maxsize=64)
def _sector_weights(nbins: int, direction: str) -> NDArray[np.float64]:
    """Weights of :func:`_sector_share` (read-only, computed once per size and direction)."""
    ang = np.arange(nbins) * 360.0 / nbins
    off = np.abs((ang - _ANGLE_DEG[direction] + 180.0) % 360.0 - 180.0)
    w = np.where(off < 45.0 - 1e-9, 1.0, np.where(off <= 45.0 + 1e-9, 0.5, 0.0))
    w.setflags(write=False)
    return w


def _sector_share(f0: NDArray[np.float64], direction: str) -> float:
    """Share of F0's mass within 45° of ``direction`` (bins exactly at 45° count half)."""
    total = float(f0.sum())
    if total <= 0.0:
        return 0.0
    return float(_sector_weights(f0.size, direction) @ f0 / total)


def _neighbours(direction: str) -> tuple[str, str]:
    """(counter-clockwise, clockwise) neighbours of a direction."""
    i = DIRECTIONS.index(direction)
    return DIRECTIONS[(i + 1) % 4], DIRECTIONS[(i - 1) % 4]


@dataclass(frozen=True)
class _Degrees:
    """The degrees of truth of the four directions: from F0, from F2 and their mean."""

    a0: dict[str, float]
    a2: dict[str, float]
    a: dict[str, float]

    @classmethod
    def of(
        cls, deg0: Mapping[str, DirectionDegree], deg2: Mapping[str, DirectionDegree]
    ) -> _Degrees:
        a0 = {d: deg0[d].degree for d in DIRECTIONS}
        a2 = {d: deg2[d].degree for d in DIRECTIONS}
        return cls(a0, a2, {d: 0.5 * (a0[d] + a2[d]) for d in DIRECTIONS})


def _surround_kind(
    coverage: float,
    best: float,
    t: Thresholds,
    overlap: float | None,
    referent_overlap: float | None,
) -> str | None:
    """Step 1: "surrounded" / "partly surrounded" (or "surrounds" ...), or None.

    Only possible for intersecting objects (``overlap`` None or > 0), and only when no
    direction fits. The histograms of "A inside B" and "B inside A" are mirror images; the
    areas decide which object encloses the other.
    """
    if not (overlap is None or overlap > 0.0):
        return None
    if coverage >= t.surround_full and best < t.fits:
        kind = "surrounded"
    elif coverage >= t.surround_part and best < t.fits_partly:
        kind = "partly surrounded"
    else:
        return None
    if overlap is not None and referent_overlap is not None and referent_overlap > overlap:
        return "surrounds" if kind == "surrounded" else "partly surrounds"
    return kind


def _compound(g: _Degrees, primary: str, near: str, t: Thresholds) -> tuple[str, str, float] | None:
    """Step 2: (front/behind, left/right, confidence) when the primary and its stronger
    neighbour are both clearly true and about equal, else None."""
    a = g.a
    if min(a[primary], a[near]) < t.compound_min or a[primary] - a[near] >= t.compound_gap:
        return None
    fb, lr = (primary, near) if primary in ("front", "behind") else (near, primary)
    agree = 1.0 - 0.5 * (abs(g.a0[fb] - g.a2[fb]) + abs(g.a0[lr] - g.a2[lr]))
    return fb, lr, 0.5 * (a[fb] + a[lr]) * agree


def _hedge(value: float, t: Thresholds) -> str | None:
    """Step 3: the hedge of the primary direction's degree."""
    if value >= t.directly:
        return "directly"
    if value >= t.plain:
        return None
    return "mostly" if value >= t.mostly else "loosely"


def _extends(
    f0: NDArray[np.float64], ccw: str, cw: str, deviation: float, t: Thresholds
) -> tuple[str, float] | None:
    """Step 4a: (side, share) when F2 says plainly P but F0's shape reaches into a side.

    Only a one-sided reach counts: a symmetric spread (adjacent objects) is no extension.
    """
    if not abs(math.degrees(deviation)) < t.extends_deviation_deg:
        return None
    shares = {d: _sector_share(f0, d) for d in (ccw, cw)}
    reach, other = (ccw, cw) if shares[ccw] >= shares[cw] else (cw, ccw)
    if shares[reach] - shares[other] >= t.extends_share:
        return reach, shares[reach]
    return None


def _secondary(
    a: Mapping[str, float], ccw: str, cw: str, near: str, deviation: float, t: Thresholds
) -> tuple[str | None, str | None]:
    """Step 4b: the secondary direction (the side F2 leans to) and its hedge, or (None, None)."""
    if deviation > 0:
        secondary: str | None = ccw
    elif deviation < 0:
        secondary = cw
    else:
        secondary = near if a[ccw] != a[cw] else None
    if secondary is None or a[secondary] < t.secondary_min:
        return None, None
    return secondary, "somewhat" if a[secondary] >= t.somewhat else "slightly"


def _decide(
    deg0: Mapping[str, DirectionDegree],
    deg2: Mapping[str, DirectionDegree],
    f0: NDArray[np.float64],
    t: Thresholds,
    overlap: float | None,
    referent_overlap: float | None,
    coverage: float | None = None,
) -> _Decision:
    g = _Degrees.of(deg0, deg2)
    a = g.a
    if coverage is None:
        coverage = _coverage(f0, t)
    best = max(a.values())
    primary = max(DIRECTIONS, key=a.__getitem__)  # ties: first in DIRECTIONS order
    deviation = deg2[primary].deviation

    kind = _surround_kind(coverage, best, t, overlap, referent_overlap)
    if kind is not None:
        conf = coverage * (1.0 - best)
        return _Decision(kind, "surrounded", None, None, None, conf, deviation, coverage, 0.0)

    ccw, cw = _neighbours(primary)
    near = ccw if a[ccw] > a[cw] or (a[ccw] == a[cw] and deviation >= 0) else cw
    compound = _compound(g, primary, near, t)
    if compound is not None:
        fb, lr, conf = compound
        return _Decision("compound", fb, lr, None, None, conf, deviation, coverage, 0.0)

    hedge = _hedge(a[primary], t)
    conf = a[primary] * (1.0 - abs(g.a0[primary] - g.a2[primary]))
    reach = _extends(f0, ccw, cw, deviation, t)
    if reach is not None:
        side, share = reach
        return _Decision(
            "direction", primary, side, hedge, "extends", conf, deviation, coverage, share
        )
    secondary, sec_hedge = _secondary(a, ccw, cw, near, deviation, t)
    share = _sector_share(f0, secondary) if secondary is not None else 0.0
    if hedge == "directly" and secondary is not None:
        hedge = None  # "directly ... but slightly" would contradict itself
    return _Decision(
        "direction", primary, secondary, hedge, sec_hedge, conf, deviation, coverage, share
    )


@dataclass(frozen=True)
class RelationFacts:
    """What :func:`describe_relation` is told about a pair besides its histograms.

    Attributes
    ----------
    overlap : float, optional
        area(A ∩ B) / area(A) if known. ``0`` rules out "surrounded" (disjoint objects cannot
        surround each other); ``None`` lets the histograms decide alone.
    referent_overlap : float, optional
        area(A ∩ B) / area(B). With ``overlap`` it tells which object encloses the other:
        when it is the larger, the sentence is "The A surrounds the B."
    vertical : str, optional
        A vertical relation from :func:`vertical_relation`; when given it takes precedence in
        ``sentence`` (the horizontal words stay in ``horizontal_sentence``).
    hybrid : bool
        Recorded in the relation: ``f2`` is the hybrid F02.

    Examples
    --------
    >>> h = np.zeros(180); h[80] = 1.0
    >>> describe_relation(h, h, facts=RelationFacts(overlap=0.0)).primary
    'left'
    """

    overlap: float | None = None
    referent_overlap: float | None = None
    vertical: str | None = None
    hybrid: bool = False


class FactKeywords(TypedDict, total=False):
    """The fields of :class:`RelationFacts` given one by one (``overlap=0.0``)."""

    overlap: float | None
    referent_overlap: float | None
    vertical: str | None
    hybrid: bool


def _facts_of(facts: RelationFacts | None, keywords: FactKeywords) -> RelationFacts:
    """``facts``, or the :class:`RelationFacts` of the keywords (never both)."""
    unknown = sorted(set(keywords) - set(FactKeywords.__annotations__))
    if unknown:
        raise TypeError(f"describe_relation() got an unexpected keyword argument {unknown[0]!r}")
    if facts is None:
        return RelationFacts(**keywords)
    if keywords:
        raise InputError(
            "facts",
            f"given together with {', '.join(sorted(keywords))}: pass either "
            "facts=RelationFacts(...) or the keywords overlap=..., vertical=..., not both",
        )
    return facts


def describe_relation(
    f0: ArrayLike,
    f2: ArrayLike,
    argument: str = "A",
    referent: str = "B",
    *,
    facts: RelationFacts | None = None,
    thresholds: Thresholds | None = None,
    **keywords: Unpack[FactKeywords],
) -> Relation:
    """Describe where the argument is relative to the referent from their force histograms.

    Parameters
    ----------
    f0, f2 : array_like, shape (N,)
        F0 (constant forces) and F2 (gravitational forces) of the argument relative to the
        referent, bin ``k`` at angle ``2πk/N`` (0 = right, π/2 = behind). Pass the hybrid F02
        as ``f2`` where F2 is undefined. ``N`` must be a multiple of 4.
    argument, referent : str
        Labels used in the sentence.
    facts : RelationFacts, optional
        The overlaps, the vertical relation and whether ``f2`` is the hybrid F02 (see
        :class:`RelationFacts`); none known by default.
    thresholds : Thresholds, optional
        The rule base's thresholds; defaults documented in :class:`Thresholds`.
    **keywords
        The fields of :class:`RelationFacts` one by one (``overlap=0.0``, ``referent_overlap``,
        ``vertical``, ``hybrid``), as before ``facts`` existed; not together with ``facts``.

    Returns
    -------
    Relation

    Raises
    ------
    InputError
        For histograms of the wrong shape, with negative or non-finite values, or of different
        lengths; for an unknown ``vertical`` word or empty labels; for ``facts`` given together
        with its keywords.

    Examples
    --------
    >>> h = np.zeros(180); h[80] = 1.0               # 160°: left, leaning 20° behind
    >>> rel = describe_relation(h, h, argument="hat", referent="mug")
    >>> rel.primary, rel.secondary, rel.hedge, rel.secondary_hedge
    ('left', 'behind', 'mostly', 'slightly')
    """
    given = _facts_of(facts, keywords)
    overlap, referent_overlap = given.overlap, given.referent_overlap
    vertical, hybrid = given.vertical, given.hybrid
    t = thresholds or DEFAULT_THRESHOLDS
    argument = _label(argument, "argument")
    referent = _label(referent, "referent")
    h0 = _as_histogram(f0, "f0")
    h2 = _as_histogram(f2, "f2")
    _check_something(h0, "f0")
    _check_something(h2, "f2")
    if h0.size != h2.size:
        raise InputError("f2", f"has {h2.size} bins but f0 has {h0.size}; use one `directions`")
    if vertical is not None and vertical not in VERTICAL_WORDS:
        raise InputError("vertical", f"must be one of {sorted(VERTICAL_WORDS)} or None")
    told = _Facts(overlap, referent_overlap, vertical, hybrid, "object")
    return _relation_from(h0, h2, (argument, referent), t, told)


@dataclass(frozen=True)
class _Facts:
    """What the rule base is told besides the histograms (see :func:`describe_relation`)."""

    overlap: float | None = None
    referent_overlap: float | None = None
    vertical: str | None = None
    hybrid: bool = False
    frame: str = "object"


def _relation_from(
    h0: NDArray[np.float64],
    h2: NDArray[np.float64],
    names: tuple[str, str],
    t: Thresholds,
    facts: _Facts,
    *,
    degrees: tuple[dict[str, DirectionDegree], dict[str, DirectionDegree]] | None = None,
    coverage: float | None = None,
) -> Relation:
    argument, referent = names
    overlap, referent_overlap, vertical = facts.overlap, facts.referent_overlap, facts.vertical
    hybrid, frame = facts.hybrid, facts.frame
    deg0, deg2 = (four_degrees(h0), four_degrees(h2)) if degrees is None else degrees
    decision = _decide(deg0, deg2, h0, t, overlap, referent_overlap, coverage)
    horizontal = _render(decision, argument, referent, frame)
    sentence = _render(decision, argument, referent, frame, vertical)
    a0 = {d: deg0[d].degree for d in DIRECTIONS}
    a2 = {d: deg2[d].degree for d in DIRECTIONS}
    confidence = decision.confidence
    if vertical is not None and overlap is not None:
        confidence = max(confidence, min(1.0, 2.0 * overlap))
    return Relation(
        argument=argument,
        referent=referent,
        primary=decision.primary,
        secondary=decision.secondary,
        hedge=decision.hedge,
        sentence=sentence,
        confidence=float(min(max(confidence, 0.0), 1.0)),
        secondary_hedge=decision.secondary_hedge,
        kind=decision.kind,
        horizontal_sentence=horizontal,
        degrees0=a0,
        degrees2=a2,
        degrees={d: 0.5 * (a0[d] + a2[d]) for d in DIRECTIONS},
        deviation0={d: deg0[d].deviation for d in DIRECTIONS},
        deviation2={d: deg2[d].deviation for d in DIRECTIONS},
        deviation=decision.deviation,
        coverage=decision.coverage,
        extends_share=decision.extends_share,
        overlap=overlap,
        referent_overlap=referent_overlap,
        vertical=vertical,
        hybrid=hybrid,
        frame=frame,
    )
