"""Stage: force histograms → relations and sentences.

A fuzzy rule base in the spirit of Matsakis et al. (IEEE SMC-B 31(4), 2001) and Skubic et al.
(Autonomous Robots 14(1), 2003) turns the pair of force histograms of two objects (F0, constant
forces, and F2, gravitational forces — or the hybrid F02 where F2 is undefined) into a
:class:`Relation` and a sentence such as "The hat is mostly to the left of the mug but somewhat
behind." The steps, each with the threshold that governs it (see :class:`Thresholds` and
``docs/language.md``):

1. degrees of truth ``a0(α)``, ``a2(α)`` of the four directions from each histogram
   (effective forces, :mod:`scenespeak.spatial.degrees`), ``a(α)`` their mean;
2. *surrounded* / *partly surrounded* first, when no direction fits and F0 covers most of the
   circle (only for intersecting objects);
3. the primary direction ``argmax a`` with its hedge (directly / — / mostly / loosely);
4. a compound direction ("front-left of") when two neighbouring directions are about as true;
5. the secondary direction ("but somewhat behind", "but slightly to the left") or "but extends
   to the rear relative to the can" when the bulk is in the primary direction but the shape
   reaches into the neighbour;
6. the vertical plane (:func:`vertical_relation`): "on top of", "above", "below", "under" — it
   takes precedence over the horizontal words when one object stands over the other.

Directions follow ``interfaces.md``: angle 0 = right, 90° = behind (farther from the camera),
180° = left, 270° = in front (nearer the camera).

>>> import numpy as np
>>> h = np.zeros(180); h[75] = 1.0               # all force at 150°: left, tilted behind
>>> describe_relation(h, h, argument="hat", referent="mug").sentence
'The hat is mostly to the left of the mug but somewhat behind.'
"""

from __future__ import annotations

import argparse
import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError, ScenespeakError
from scenespeak.geometry.polygons import as_polygon, intersection_area, is_convex, polygon_area
from scenespeak.spatial.degrees import DIRECTIONS, DirectionDegree, four_degrees, many_degrees

__all__ = [
    "COMPOUND_WORDS",
    "DIRECTIONS",
    "OBJECT_PATTERNS",
    "VERTICAL_WORDS",
    "VIEWER_PATTERNS",
    "PairHistograms",
    "Relation",
    "Thresholds",
    "describe_relation",
    "describe_viewer_relation",
    "layout_table",
    "pair_histograms",
    "relate",
    "relate_objects",
    "relation_of_pair",
    "relations_of_pair",
    "summarize_scene",
    "update_doc_table",
    "vertical_relation",
]

_ANGLE_DEG = {"right": 0.0, "behind": 90.0, "left": 180.0, "front": 270.0}


# --------------------------------------------------------------------------------------------
# Thresholds
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Thresholds:
    """Every threshold of the rule base: value, the test that pins it, and why.

    Degrees of truth are in [0, 1]; a single force spike ``δ`` degrees off a direction scores
    ``1 − δ/90`` for it and ``δ/90`` for the neighbour it leans to, which is how the values
    below read as angles.

    Attributes
    ----------
    directly : float
        0.93 — hedge "directly" at or above (a spike within 6.3° of the axis).
        Pinned by ``test_hedge_bands_on_spikes`` and ``test_layout_directly``. Why: people say
        "directly" only when no deviation is visible.
    plain : float
        0.80 — no hedge at or above (within 18°). Pinned by ``test_hedge_bands_on_spikes`` and
        the seed's "The mug is to the left of the can." layout. Why: a deviation below ~20° is
        not worth a word.
    mostly : float
        0.55 — "mostly" at or above, "loosely" below (within ~40°). Pinned by
        ``test_hedge_bands_on_spikes`` and ``test_layout_loosely``. Why: past ~40° the
        neighbouring direction is nearly as true and "mostly" overstates.
    compound_min : float
        0.35 — both neighbours at least this true for a compound "front-left". Pinned by
        ``test_compound_band_on_spikes``. Why: below it one of the two is not really meant.
    compound_gap : float
        0.15 — and their degrees differ by less than this (spikes within ±6.75° of the
        diagonal). Pinned by ``test_compound_band_on_spikes`` and the seed's "The can is
        front-left of the hat." Why: only near the diagonal is neither direction the main one.
    secondary_min : float
        0.15 — no secondary direction below (a lean under ~13°). Pinned by
        ``test_hedge_bands_on_spikes``. Why: a smaller lean is already covered by "directly"
        or no hedge.
    somewhat : float
        0.30 — "but somewhat S" at or above, "but slightly S" below. Pinned by
        ``test_secondary_bands_on_spikes``. Why: a lean of ~27° and more is clearly visible.
    extends_deviation_deg : float
        15 — "extends to" needs F2's deviation from the primary under this. Pinned by
        ``test_layout_extends``. Why: the near parts (F2) must say "plainly P".
    extends_share : float
        0.20 — ... and at least this share of F0's mass in the neighbour's sector (within 45°
        of S). Pinned by ``test_layout_extends`` and ``test_extends_rule_on_synthetic``. Why: a
        fifth of the shape reaching into S is a visible part of the object, not a corner.
    fits : float
        0.5 — a direction "fits" at or above; "surrounded" needs every direction below. Pinned
        by ``test_layout_surrounded`` and ``test_surround_rule_on_synthetic``. Why: at 0.5 a
        direction is as true as false.
    fits_partly : float
        0.65 — "partly surrounded" needs every direction below this. Pinned by
        ``test_layout_partly_surrounded`` and ``test_layout_overlap_but_direction``. Why: an
        object mostly inside another whose best direction earns only "loosely" is better
        described by the overlap; from "mostly" (~0.55 + margin) on, the direction says more.
    surround_full : float
        0.95 — smoothed F0 coverage for "surrounded". Pinned by ``test_layout_surrounded``.
        Why: allow a few empty degrees from hull noise.
    surround_part : float
        0.5 — coverage for "partly surrounded". Pinned by ``test_layout_partly_surrounded``.
        Why: disjoint convex objects cover at most a half circle, so more needs an overlap.
    coverage_level : float
        0.1 — a direction counts as covered when the smoothed F0 is at least this fraction
        of its maximum. Pinned by ``test_coverage_on_synthetic``. Why: ignores the thin tails
        every overlap produces.
    coverage_smooth_deg : float
        10 — half-width (degrees) of the circular moving average applied to F0 before the
        coverage. Pinned by ``test_coverage_on_synthetic``. Why: hull noise leaves isolated
        empty bins.
    vertical_overlap : float
        0.1 — the footprints must overlap by at least this fraction of the smaller one for a
        vertical relation. Pinned by ``test_vertical_needs_overlap``. Why: objects side by side
        at different heights are described horizontally.
    contact_tolerance : float
        0.05 m — a gap between A's bottom and B's top (5th and 95th percentiles of the points'
        heights) within ± this (or within ``contact_fraction`` of the thinner object's height,
        whichever is larger) is contact: "on top of" / "under". Pinned by
        ``test_vertical_rule``. Why: keypoints seldom sit on the very rim or the very bottom,
        the percentiles trim a little more, and stereo heights are good to a few centimetres.
    contact_fraction : float
        0.25 — see ``contact_tolerance``. Pinned by ``test_vertical_rule``.
    """

    directly: float = 0.93
    plain: float = 0.80
    mostly: float = 0.55
    compound_min: float = 0.35
    compound_gap: float = 0.15
    secondary_min: float = 0.15
    somewhat: float = 0.30
    extends_deviation_deg: float = 15.0
    extends_share: float = 0.20
    fits: float = 0.5
    fits_partly: float = 0.65
    surround_full: float = 0.95
    surround_part: float = 0.5
    coverage_level: float = 0.1
    coverage_smooth_deg: float = 10.0
    vertical_overlap: float = 0.1
    contact_tolerance: float = 0.05
    contact_fraction: float = 0.25


DEFAULT_THRESHOLDS = Thresholds()

# --------------------------------------------------------------------------------------------
# Pattern tables: every phrase is written out whole, so no combination can glue into
# "to the behind".
# --------------------------------------------------------------------------------------------
#: Sentence patterns for a relation between two objects.
OBJECT_PATTERNS: dict[str, str] = {
    "direction": "The {argument} is {hedge}{primary} the {referent}.",
    "direction+secondary": (
        "The {argument} is {hedge}{primary} the {referent} but {secondary_hedge} {secondary}."
    ),
    "direction+extends": (
        "The {argument} is {hedge}{primary} the {referent} but extends {extends} "
        "relative to the {referent}."
    ),
    "compound": "The {argument} is {compound} the {referent}.",
    "surrounded": "The {argument} is surrounded by the {referent}.",
    "partly surrounded": "The {argument} is partly surrounded by the {referent}.",
    "surrounds": "The {argument} surrounds the {referent}.",
    "partly surrounds": "The {argument} partly surrounds the {referent}.",
    "vertical": "The {argument} is {vertical} the {referent}.",
}
#: Sentence patterns with the viewer (camera / robot) as the referent.
VIEWER_PATTERNS: dict[str, str] = {
    "direction": "The {argument} is {hedge}{primary}.",
    "direction+secondary": "The {argument} is {hedge}{primary}, {secondary_hedge} {secondary}.",
    "direction+extends": "The {argument} is {hedge}{primary} but extends {extends}.",
    "compound": "The {argument} is {compound}.",
    "surrounded": "The {argument} is right where I am.",
    "partly surrounded": "The {argument} is partly where I am.",
    "surrounds": "The {argument} is all around me.",
    "partly surrounds": "The {argument} is partly around me.",
    "vertical": "The {argument} is {vertical} me.",
}
_PHRASES: dict[str, dict[str, dict[str, str]]] = {
    "object": {
        "primary": {
            "left": "to the left of",
            "right": "to the right of",
            "front": "in front of",
            "behind": "behind",
        },
        "secondary": {
            "left": "to the left",
            "right": "to the right",
            "front": "to the front",
            "behind": "behind",
        },
        "extends": {
            "left": "to the left",
            "right": "to the right",
            "front": "to the front",
            "behind": "to the rear",
        },
    },
    "viewer": {
        "primary": {
            "left": "to my left",
            "right": "to my right",
            "front": "in front of me",
            "behind": "behind me",
        },
        "secondary": {
            "left": "to the left",
            "right": "to the right",
            "front": "farther ahead",
            "behind": "nearer",
        },
        "extends": {
            "left": "to the left",
            "right": "to the right",
            "front": "farther ahead",
            "behind": "towards me",
        },
    },
}
#: Compound words, keyed by (front/behind, left/right), for each frame.
COMPOUND_WORDS: dict[str, dict[tuple[str, str], str]] = {
    "object": {
        ("front", "left"): "front-left of",
        ("front", "right"): "front-right of",
        ("behind", "left"): "rear-left of",
        ("behind", "right"): "rear-right of",
    },
    "viewer": {
        ("front", "left"): "in front of me and to the left",
        ("front", "right"): "in front of me and to the right",
        ("behind", "left"): "behind me and to the left",
        ("behind", "right"): "behind me and to the right",
    },
}
#: The vertical relations, and the converse of each (A on top of B ⇔ B under A).
VERTICAL_WORDS: dict[str, str] = {
    "on top of": "under",
    "above": "below",
    "under": "on top of",
    "below": "above",
}
_HEDGE_WORDS = {"directly": "directly ", "mostly": "mostly ", "loosely": "loosely ", None: ""}


# --------------------------------------------------------------------------------------------
# The relation
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Relation:
    """Where the argument is relative to the referent, in words and in the numbers behind them.

    Attributes
    ----------
    argument, referent : str
        Labels ("What is the relation of *argument* to *referent*?"). For viewer relations the
        referent is ``"me"``.
    primary : str
        ``"left"``, ``"right"``, ``"front"``, ``"behind"`` or ``"surrounded"`` (also for "partly
        surrounded"; see ``kind``). For a compound, the front/behind part. In viewer relations
        the directions are the viewer's: ``"front"`` is farther from the camera.
    secondary : str or None
        One of the four directions, or None. For a compound, the left/right part.
    hedge : str or None
        ``"directly"``, ``"mostly"``, ``"loosely"`` or None (no hedge).
    secondary_hedge : str or None
        ``"somewhat"``, ``"slightly"``, ``"extends"`` or None.
    kind : str
        ``"direction"``, ``"compound"``, ``"surrounded"``, ``"partly surrounded"``,
        ``"surrounds"`` or ``"partly surrounds"`` (the argument is the larger, enclosing object;
        ``primary`` is then ``"surrounded"`` too): which horizontal rule produced the words.
    sentence : str
        The sentence to say. When ``vertical`` is set it is the vertical sentence ("The mug is
        on top of the can."), otherwise ``horizontal_sentence``.
    horizontal_sentence : str
        The sentence of the horizontal rule set alone.
    confidence : float
        Self-assessment in [0, 1]: high when the winning degree is high and F0 and F2 agree.
    degrees0, degrees2, degrees : dict of str to float
        Degrees of truth of the four directions from F0, from F2 (or F02) and their mean.
    deviation0, deviation2 : dict of str to float
        Signed mean deviation (radians, counter-clockwise positive) of each histogram's
        effective forces from each direction.
    deviation : float
        F2's deviation from the primary direction (radians); its sign picks the secondary side.
    coverage : float
        Fraction of directions covered by the smoothed F0 (the surround measure).
    extends_share : float
        Share of F0's mass within 45° of the secondary direction (the "extends" measure), 0
        when there is no secondary.
    overlap : float or None
        area(A ∩ B) / area(A) when known (``relate`` computes it), else None.
    referent_overlap : float or None
        area(A ∩ B) / area(B) when known, else None.
    vertical : str or None
        ``"on top of"``, ``"above"``, ``"below"``, ``"under"`` or None.
    hybrid : bool
        True when ``f2`` was the hybrid F02 (touching or intersecting objects).
    frame : str
        ``"object"`` or ``"viewer"`` (the camera is the referent).
    """

    argument: str
    referent: str
    primary: str
    secondary: str | None
    hedge: str | None
    sentence: str
    confidence: float
    secondary_hedge: str | None = None
    kind: str = "direction"
    horizontal_sentence: str = ""
    degrees0: dict[str, float] = field(default_factory=dict)
    degrees2: dict[str, float] = field(default_factory=dict)
    degrees: dict[str, float] = field(default_factory=dict)
    deviation0: dict[str, float] = field(default_factory=dict)
    deviation2: dict[str, float] = field(default_factory=dict)
    deviation: float = 0.0
    coverage: float = 0.0
    extends_share: float = 0.0
    overlap: float | None = None
    referent_overlap: float | None = None
    vertical: str | None = None
    hybrid: bool = False
    frame: str = "object"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready values; angles in degrees (``deviation_deg``, ``deviation0_deg``, ...).

        Examples
        --------
        >>> h = np.zeros(180); h[90] = 1.0
        >>> d = describe_relation(h, h, argument="mug", referent="can").to_dict()
        >>> d["primary"], d["secondary"], d["sentence"]
        ('left', None, 'The mug is directly to the left of the can.')
        """
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in ("deviation0", "deviation2"):
                out[f"{f.name}_deg"] = {k: math.degrees(v) for k, v in value.items()}
            elif f.name == "deviation":
                out["deviation_deg"] = math.degrees(value)
            elif isinstance(value, dict):
                out[f.name] = {k: float(v) for k, v in value.items()}
            elif isinstance(value, float):
                out[f.name] = float(value)
            else:
                out[f.name] = value
        return out


# --------------------------------------------------------------------------------------------
# Rules
# --------------------------------------------------------------------------------------------
def _as_histogram(h: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(h, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"must be a 1-D array of forces ({exc})") from None
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
class _Decision:
    kind: str
    primary: str
    secondary: str | None
    hedge: str | None
    secondary_hedge: str | None
    confidence: float
    deviation: float
    coverage: float
    extends_share: float


def _decide(
    deg0: Mapping[str, DirectionDegree],
    deg2: Mapping[str, DirectionDegree],
    f0: NDArray[np.float64],
    t: Thresholds,
    overlap: float | None,
    referent_overlap: float | None,
    coverage: float | None = None,
) -> _Decision:
    a0 = {d: deg0[d].degree for d in DIRECTIONS}
    a2 = {d: deg2[d].degree for d in DIRECTIONS}
    a = {d: 0.5 * (a0[d] + a2[d]) for d in DIRECTIONS}
    if coverage is None:
        coverage = _coverage(f0, t)
    best = max(a.values())
    primary = max(DIRECTIONS, key=lambda d: a[d])  # ties: first in DIRECTIONS order
    deviation = deg2[primary].deviation

    # 1. Surrounded: only possible for intersecting objects, and only when no direction fits.
    if overlap is None or overlap > 0.0:
        kind = None
        if coverage >= t.surround_full and best < t.fits:
            kind = "surrounded"
        elif coverage >= t.surround_part and best < t.fits_partly:
            kind = "partly surrounded"
        # The histograms of "A inside B" and "B inside A" are mirror images; the areas decide
        # which object encloses the other.
        if kind is not None and overlap is not None and referent_overlap is not None:
            if referent_overlap > overlap:
                kind = "surrounds" if kind == "surrounded" else "partly surrounds"
        if kind is not None:
            conf = coverage * (1.0 - best)
            return _Decision(kind, "surrounded", None, None, None, conf, deviation, coverage, 0.0)

    ccw, cw = _neighbours(primary)
    near = ccw if a[ccw] > a[cw] or (a[ccw] == a[cw] and deviation >= 0) else cw

    # 2. Compound: the primary and its stronger neighbour both clearly true and about equal.
    if min(a[primary], a[near]) >= t.compound_min and a[primary] - a[near] < t.compound_gap:
        fb, lr = (primary, near) if primary in ("front", "behind") else (near, primary)
        agree = 1.0 - 0.5 * (abs(a0[fb] - a2[fb]) + abs(a0[lr] - a2[lr]))
        conf = 0.5 * (a[fb] + a[lr]) * agree
        return _Decision("compound", fb, lr, None, None, conf, deviation, coverage, 0.0)

    # 3. Hedge of the primary.
    if a[primary] >= t.directly:
        hedge: str | None = "directly"
    elif a[primary] >= t.plain:
        hedge = None
    elif a[primary] >= t.mostly:
        hedge = "mostly"
    else:
        hedge = "loosely"
    conf = a[primary] * (1.0 - abs(a0[primary] - a2[primary]))

    # 4. Secondary: "extends to" when F2 says plainly P but F0's shape reaches into S.
    secondary: str | None
    sec_hedge: str | None = None
    share = 0.0
    if abs(math.degrees(deviation)) < t.extends_deviation_deg:
        shares = {d: _sector_share(f0, d) for d in (ccw, cw)}
        reach, other = (ccw, cw) if shares[ccw] >= shares[cw] else (cw, ccw)
        # Only a one-sided reach counts: a symmetric spread (adjacent objects) is no extension.
        if shares[reach] - shares[other] >= t.extends_share:
            return _Decision(
                "direction",
                primary,
                reach,
                hedge,
                "extends",
                conf,
                deviation,
                coverage,
                shares[reach],
            )
    if deviation > 0:
        secondary = ccw
    elif deviation < 0:
        secondary = cw
    else:
        secondary = near if a[ccw] != a[cw] else None
    if secondary is not None:
        if a[secondary] < t.secondary_min:
            secondary = None
        else:
            sec_hedge = "somewhat" if a[secondary] >= t.somewhat else "slightly"
            share = _sector_share(f0, secondary)
    if hedge == "directly" and secondary is not None:
        hedge = None  # "directly ... but slightly" would contradict itself
    return _Decision(
        "direction", primary, secondary, hedge, sec_hedge, conf, deviation, coverage, share
    )


def _render(
    decision: _Decision, argument: str, referent: str, frame: str, vertical: str | None = None
) -> str:
    patterns = OBJECT_PATTERNS if frame == "object" else VIEWER_PATTERNS
    phrases = _PHRASES[frame]
    if vertical is not None:
        return patterns["vertical"].format(argument=argument, referent=referent, vertical=vertical)
    if decision.kind in ("surrounded", "partly surrounded", "surrounds", "partly surrounds"):
        return patterns[decision.kind].format(argument=argument, referent=referent)
    if decision.kind == "compound":
        assert decision.secondary is not None
        word = COMPOUND_WORDS[frame][(decision.primary, decision.secondary)]
        return patterns["compound"].format(argument=argument, referent=referent, compound=word)
    values = {
        "argument": argument,
        "referent": referent,
        "hedge": _HEDGE_WORDS[decision.hedge],
        "primary": phrases["primary"][decision.primary],
    }
    if decision.secondary is None:
        return patterns["direction"].format(**values)
    if decision.secondary_hedge == "extends":
        return patterns["direction+extends"].format(
            **values, extends=phrases["extends"][decision.secondary]
        )
    return patterns["direction+secondary"].format(
        **values,
        secondary_hedge=decision.secondary_hedge,
        secondary=phrases["secondary"][decision.secondary],
    )


def _label(name: object, what: str) -> str:
    if not isinstance(name, str) or not name.strip():
        raise InputError(what, f"must be a non-empty label, got {name!r}")
    return name.strip()


def describe_relation(
    f0: ArrayLike,
    f2: ArrayLike,
    argument: str = "A",
    referent: str = "B",
    *,
    overlap: float | None = None,
    referent_overlap: float | None = None,
    vertical: str | None = None,
    hybrid: bool = False,
    thresholds: Thresholds | None = None,
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
    thresholds : Thresholds, optional
        The rule base's thresholds; defaults documented in :class:`Thresholds`.

    Returns
    -------
    Relation

    Raises
    ------
    InputError
        For histograms of the wrong shape, with negative or non-finite values, or of different
        lengths; for an unknown ``vertical`` word or empty labels.

    Examples
    --------
    >>> h = np.zeros(180); h[80] = 1.0               # 160°: left, leaning 20° behind
    >>> rel = describe_relation(h, h, argument="hat", referent="mug")
    >>> rel.primary, rel.secondary, rel.hedge, rel.secondary_hedge
    ('left', 'behind', 'mostly', 'slightly')
    """
    t = thresholds or DEFAULT_THRESHOLDS
    argument = _label(argument, "argument")
    referent = _label(referent, "referent")
    h0 = _as_histogram(f0, "f0")
    h2 = _as_histogram(f2, "f2")
    if h0.size != h2.size:
        raise InputError("f2", f"has {h2.size} bins but f0 has {h0.size}; use one `directions`")
    if vertical is not None and vertical not in VERTICAL_WORDS:
        raise InputError("vertical", f"must be one of {sorted(VERTICAL_WORDS)} or None")
    return _relation_from(
        h0,
        h2,
        argument,
        referent,
        t,
        overlap=overlap,
        referent_overlap=referent_overlap,
        vertical=vertical,
        hybrid=hybrid,
        frame="object",
    )


def _relation_from(
    h0: NDArray[np.float64],
    h2: NDArray[np.float64],
    argument: str,
    referent: str,
    t: Thresholds,
    *,
    overlap: float | None,
    referent_overlap: float | None,
    vertical: str | None,
    hybrid: bool,
    frame: str,
    degrees: tuple[dict[str, DirectionDegree], dict[str, DirectionDegree]] | None = None,
    coverage: float | None = None,
) -> Relation:
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


# --------------------------------------------------------------------------------------------
# The vertical plane
# --------------------------------------------------------------------------------------------
def _heights(h: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(h, dtype=np.float64).ravel()
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"must be a 1-D array of heights in metres ({exc})") from None
    if a.size == 0:
        raise InputError(name, "is empty; give the heights of the object's points along up")
    if not np.all(np.isfinite(a)):
        raise InputError(name, "has non-finite heights (NaN or inf)")
    return a


def vertical_relation(
    a_heights: ArrayLike,
    b_heights: ArrayLike,
    *,
    horizontal_overlap: float,
    thresholds: Thresholds | None = None,
) -> str | None:
    """The vertical relation of A to B: "on top of", "above", "under", "below" or None.

    The rule: each object's vertical extent is the 5th–95th percentile of its points' heights
    along up (robust to a stray keypoint). With ``gap = bottom(A) − top(B)`` and the contact
    tolerance ``tol = max(contact_tolerance, contact_fraction · thinner object's extent)``:

    - no vertical relation when the footprints overlap by less than ``vertical_overlap`` of
      the smaller one (side by side: the horizontal words say it);
    - A "on top of" B when ``|gap| <= tol`` and A's median height is above B's; "above" when
      ``gap > tol``;
    - symmetrically "under" (B on top of A) and "below";
    - None when the extents overlap by more than ``tol`` (e.g. the mug inside a can).

    Parameters
    ----------
    a_heights, b_heights : array_like
        Heights (metres, larger = higher) of the objects' points along up.
    horizontal_overlap : float
        area(A ∩ B) / min(area(A), area(B)) of the footprints on the horizontal plane.
    thresholds : Thresholds, optional

    Examples
    --------
    >>> mug = np.linspace(0.12, 0.22, 20)           # a mug standing on a 12 cm can
    >>> can = np.linspace(0.0, 0.12, 30)
    >>> vertical_relation(mug, can, horizontal_overlap=1.0)
    'on top of'
    >>> vertical_relation(can, mug, horizontal_overlap=1.0)
    'under'
    >>> vertical_relation(mug + 0.3, can, horizontal_overlap=1.0)
    'above'
    >>> vertical_relation(mug, can, horizontal_overlap=0.0) is None
    True
    """
    t = thresholds or DEFAULT_THRESHOLDS
    a = _heights(a_heights, "a_heights")
    b = _heights(b_heights, "b_heights")
    if not math.isfinite(horizontal_overlap) or horizontal_overlap < 0:
        raise InputError("horizontal_overlap", f"must be a fraction >= 0, got {horizontal_overlap}")
    if horizontal_overlap < t.vertical_overlap:
        return None
    a_lo, a_hi = np.percentile(a, [5.0, 95.0])
    b_lo, b_hi = np.percentile(b, [5.0, 95.0])
    tol = max(t.contact_tolerance, t.contact_fraction * min(a_hi - a_lo, b_hi - b_lo))
    a_mid, b_mid = float(np.median(a)), float(np.median(b))
    gap_ab = float(a_lo - b_hi)
    gap_ba = float(b_lo - a_hi)
    if a_mid > b_mid and gap_ab >= -tol:
        return "on top of" if gap_ab <= tol else "above"
    if b_mid > a_mid and gap_ba >= -tol:
        return "under" if gap_ba <= tol else "below"
    return None


# --------------------------------------------------------------------------------------------
# Polygons → relation
# --------------------------------------------------------------------------------------------
def _histograms(
    a: NDArray[np.float64], b: NDArray[np.float64], directions: int, intersecting: bool
) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
    from scenespeak.spatial import forces

    if not intersecting:
        try:
            # One sweep gives both exponents (about half the time of two calls).
            f0, f2 = forces.force_histograms(a, b, r=(0.0, 2.0), directions=directions)
            if np.all(np.isfinite(f2)):
                return np.asarray(f0, np.float64), np.asarray(f2, np.float64), False
        except (ScenespeakError, ValueError, ArithmeticError):
            pass  # touching objects: F2 undefined, fall through to the hybrid F02
    f0 = np.asarray(forces.force_histogram(a, b, r=0.0, directions=directions), dtype=np.float64)
    f02 = forces.hybrid_histogram(a, b, directions=directions)
    return f0, np.asarray(f02, dtype=np.float64), True


@dataclass(frozen=True, eq=False)
class PairHistograms:
    """The force histograms of one pair of polygons and how much their footprints overlap.

    What :func:`relate` decides from, returned by :func:`pair_histograms` so that a caller
    that must keep the histograms (the pipeline's JSON) computes them once.

    Attributes
    ----------
    f0, f2 : (directions,) float64
        F0 and F2 of the argument relative to the referent (bin ``k`` at ``2πk/directions``);
        ``f2`` is the hybrid F02 where F2 is undefined (``hybrid``).
    hybrid : bool
        True when the polygons touch or intersect and ``f2`` is the hybrid F02.
    intersection : float
        area(A ∩ B).
    area_a, area_b : float
        Areas of the argument and of the referent.
    """

    f0: NDArray[np.float64]
    f2: NDArray[np.float64]
    hybrid: bool
    intersection: float
    area_a: float
    area_b: float

    @property
    def intersecting(self) -> bool:
        """Whether the interiors overlap (beyond rounding)."""
        return self.intersection > 1e-12 * min(self.area_a, self.area_b)

    @property
    def overlap(self) -> float:
        """area(A ∩ B) / area(A), 0 for disjoint polygons (``describe_relation``'s ``overlap``)."""
        return self.intersection / self.area_a if self.intersecting else 0.0

    @property
    def referent_overlap(self) -> float:
        """area(A ∩ B) / area(B), 0 for disjoint polygons."""
        return self.intersection / self.area_b if self.intersecting else 0.0

    @property
    def horizontal_overlap(self) -> float:
        """area(A ∩ B) / min(area(A), area(B)) (``vertical_relation``'s ``horizontal_overlap``)."""
        return self.intersection / max(min(self.area_a, self.area_b), 1e-300)

    def reversed(self) -> PairHistograms:
        """The same pair seen the other way round: F(B, A)(θ) = F(A, B)(θ + π).

        Examples
        --------
        >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
        >>> p = pair_histograms(sq, sq + [3.0, 0.0], directions=8)
        >>> int(np.argmax(p.f0)), int(np.argmax(p.reversed().f0))   # 180° (left), then 0°
        (4, 0)
        """
        half = self.f0.size // 2
        return PairHistograms(
            np.concatenate([self.f0[-half:], self.f0[:-half]]) if half else self.f0.copy(),
            np.concatenate([self.f2[-half:], self.f2[:-half]]) if half else self.f2.copy(),
            self.hybrid,
            self.intersection,
            self.area_b,
            self.area_a,
        )


def pair_histograms(a: ArrayLike, b: ArrayLike, *, directions: int = 180) -> PairHistograms:
    """F0 and F2 (or the hybrid F02) of polygon ``a`` relative to polygon ``b``, and their overlap.

    Disjoint polygons get F0 and F2 from one sweep of
    :func:`scenespeak.spatial.forces.force_histograms`; where F2 is undefined (the polygons touch or
    intersect) ``f2`` is :func:`scenespeak.spatial.forces.hybrid_histogram` and ``hybrid`` is True.
    :func:`relate` describes the pair from this; ``result.reversed()`` gives the pair the
    other way round without computing anything again.

    Parameters
    ----------
    a, b : array_like, shape (N, 2)
        Vertices of the argument and the referent (the horizontal plane's 2-D frame, metres).
    directions : int
        Histogram bins (a multiple of 4, >= 8).

    Returns
    -------
    PairHistograms

    Raises
    ------
    InputError
        For polygons that are not ``(N >= 3, 2)`` finite vertex arrays with an area, or a bad
        ``directions``.

    Examples
    --------
    >>> hat = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> p = pair_histograms(hat, hat + [3.0, 0.0])
    >>> p.f0.shape, p.hybrid, int(np.argmax(p.f2))           # bin 90 = 180°: to the left
    ((180,), False, 90)
    """
    pa = as_polygon(a, "argument polygon")
    pb = as_polygon(b, "referent polygon")
    if directions < 8 or directions % 4:
        raise InputError("directions", f"must be a multiple of 4 and >= 8, got {directions}")
    inter = intersection_area(pa, pb)
    area_a, area_b = abs(polygon_area(pa)), abs(polygon_area(pb))
    f0, f2, hybrid = _histograms(pa, pb, directions, inter > 1e-12 * min(area_a, area_b))
    return PairHistograms(
        _as_histogram(f0, "f0"), _as_histogram(f2, "f2"), hybrid, inter, area_a, area_b
    )


def relation_of_pair(
    pair: PairHistograms,
    *,
    argument: str = "A",
    referent: str = "B",
    a_heights: ArrayLike | None = None,
    b_heights: ArrayLike | None = None,
    thresholds: Thresholds | None = None,
) -> Relation:
    """Describe a pair from its :class:`PairHistograms` (the second half of :func:`relate`).

    The overlaps decide "surrounded" / "surrounds"; when both objects' heights are given, the
    vertical relation (:func:`vertical_relation`) takes precedence in ``sentence``.

    Examples
    --------
    >>> hat = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> p = pair_histograms(hat, hat + [3.0, 0.0])
    >>> relation_of_pair(p.reversed(), argument="mug", referent="hat").sentence
    'The mug is directly to the right of the hat.'
    """
    t = thresholds or DEFAULT_THRESHOLDS
    argument = _label(argument, "argument")
    referent = _label(referent, "referent")
    if (a_heights is None) != (b_heights is None):
        raise InputError("a_heights/b_heights", "give the heights of both objects, or neither")
    return _describe_pair(pair, argument, referent, a_heights, b_heights, t)


def _describe_pair(
    pair: PairHistograms,
    argument: str,
    referent: str,
    a_heights: ArrayLike | None,
    b_heights: ArrayLike | None,
    t: Thresholds,
    degrees: tuple[dict[str, DirectionDegree], dict[str, DirectionDegree]] | None = None,
    heights_checked: bool = False,
    coverage: float | None = None,
) -> Relation:
    """The rule base on one ordered pair (labels checked; heights too if ``heights_checked``:
    then a pair whose footprints hardly overlap skips :func:`vertical_relation`, which would
    only check the heights again and return None). ``coverage`` is ``_coverage(pair.f0)``
    when known."""
    vertical = None
    skip = heights_checked and pair.horizontal_overlap < t.vertical_overlap
    if a_heights is not None and b_heights is not None and not skip:
        vertical = vertical_relation(
            a_heights, b_heights, horizontal_overlap=pair.horizontal_overlap, thresholds=t
        )
    return _relation_from(
        pair.f0,
        pair.f2,
        argument,
        referent,
        t,
        overlap=pair.overlap,
        referent_overlap=pair.referent_overlap,
        vertical=vertical,
        hybrid=pair.hybrid,
        frame="object",
        degrees=degrees,
        coverage=coverage,
    )


_OPPOSITE = {"right": "left", "behind": "front", "left": "right", "front": "behind"}


def relations_of_pair(
    pair: PairHistograms,
    *,
    argument: str = "A",
    referent: str = "B",
    a_heights: ArrayLike | None = None,
    b_heights: ArrayLike | None = None,
    thresholds: Thresholds | None = None,
) -> tuple[Relation, Relation]:
    """Both relations of a pair: the argument's to the referent's, and back.

    The same as ``relation_of_pair(pair, ...)`` and ``relation_of_pair(pair.reversed(), ...)``
    with the labels and heights swapped, but the degrees of truth are computed once: F(B, A)
    is F(A, B) turned by 180°, so B's degree for "left" is A's for "right" (bit for bit: the
    reversed histogram is a rotation of the same bins).

    Examples
    --------
    >>> hat = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> ab, ba = relations_of_pair(pair_histograms(hat, hat + [3.0, 0.0]), argument="hat",
    ...                            referent="mug")
    >>> ab.primary, ba.primary, ba.sentence
    ('left', 'right', 'The mug is directly to the right of the hat.')
    """
    t = thresholds or DEFAULT_THRESHOLDS
    argument = _label(argument, "argument")
    referent = _label(referent, "referent")
    if (a_heights is None) != (b_heights is None):
        raise InputError("a_heights/b_heights", "give the heights of both objects, or neither")
    if pair.f0.size % 4 or pair.f0.size < 8 or pair.f2.size != pair.f0.size:
        raise InputError("pair", "histograms must have one length, a multiple of 4 (>= 8)")
    ((deg0, deg2),) = _pair_degrees([pair])
    ab, ba, _ = _both_ways(pair, argument, referent, a_heights, b_heights, t, deg0, deg2)
    return ab, ba


def _pair_degrees(
    pairs: Sequence[PairHistograms],
) -> list[tuple[dict[str, DirectionDegree], dict[str, DirectionDegree]]]:
    """``(four_degrees(p.f0), four_degrees(p.f2))`` of every pair: one batch, the same values.

    All pairs must have histograms of one length (a multiple of 4).
    """
    if not pairs:
        return []
    nbins = pairs[0].f0.size
    hist = np.stack([h for p in pairs for h in (p.f0, p.f2)])
    rows = np.repeat(np.arange(len(hist)), 4)
    found = many_degrees(hist[rows], np.tile(np.arange(4) * (nbins // 4), len(hist)))
    values = np.column_stack(found).tolist()  # Python floats, row by row
    out = []
    for k in range(len(pairs)):
        deg = [
            {name: DirectionDegree(*values[8 * k + 4 * f + i]) for i, name in enumerate(DIRECTIONS)}
            for f in (0, 1)
        ]
        out.append((deg[0], deg[1]))
    return out


def _both_ways(
    pair: PairHistograms,
    argument: str,
    referent: str,
    a_heights: ArrayLike | None,
    b_heights: ArrayLike | None,
    t: Thresholds,
    deg0: dict[str, DirectionDegree],
    deg2: dict[str, DirectionDegree],
    heights_checked: bool = False,
) -> tuple[Relation, Relation, PairHistograms]:
    """The rule base on a pair and on its reverse (B's degree for "left" is A's for "right").

    Returns the two relations and ``pair.reversed()``.
    """
    back = pair.reversed()
    reversed_degrees = (
        {d: deg0[_OPPOSITE[d]] for d in DIRECTIONS},
        {d: deg2[_OPPOSITE[d]] for d in DIRECTIONS},
    )
    # The coverage of F0 turned by 180° is the same: the circular moving average turns with
    # it (each smoothed bin is the same dot product of the same numbers), the count is equal.
    cov = _coverage(pair.f0, t)
    ab = _describe_pair(
        pair, argument, referent, a_heights, b_heights, t, (deg0, deg2), heights_checked, cov
    )
    ba = _describe_pair(
        back, referent, argument, b_heights, a_heights, t, reversed_degrees, heights_checked, cov
    )
    return ab, ba, back


def relate_objects(
    hulls: Sequence[ArrayLike],
    *,
    names: Sequence[str],
    heights: Sequence[ArrayLike] | None = None,
    directions: int = 180,
    thresholds: Thresholds | None = None,
) -> list[tuple[Relation, PairHistograms]]:
    """Every ordered pair of a scene's objects: the relation and the histograms behind it.

    The same relations and histograms as, for every unordered pair ``i < j``,
    ``pair = pair_histograms(hulls[i], hulls[j])``, ``relations_of_pair(pair, ...)`` and
    ``pair.reversed()``, but each polygon is validated and prepared once (not once per pair),
    disjoint hulls skip the clipping, F0 and F2 (or F0 and F02) come from one sweep, and the
    degrees of truth of all pairs are computed together. The results are the same floats.

    Parameters
    ----------
    hulls : sequence of array_like, shape (N, 2)
        The objects' footprints on the horizontal plane (the 2-D frame of ``interfaces.md``,
        metres).
    names : sequence of str
        Their labels, one per hull.
    heights : sequence of array_like, optional
        Each object's heights (metres, larger = higher) along up, for the vertical relations;
        one per hull, or None for no vertical relations.
    directions : int
        Histogram bins (a multiple of 4, >= 8).
    thresholds : Thresholds, optional

    Returns
    -------
    list of (Relation, PairHistograms)
        One entry per ordered pair ``(i, j)``, ``i != j``, in the order ``(0, 1), (0, 2), ...,
        (1, 0), (1, 2), ...``: the relation of object ``i`` (argument) to object ``j``
        (referent) and the histograms of ``i`` relative to ``j``.

    Raises
    ------
    InputError
        For a hull that is not an ``(N >= 3, 2)`` finite vertex array with an area, labels
        that are empty or do not match the hulls, heights of the wrong count, or a bad
        ``directions``.

    Examples
    --------
    >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> out = relate_objects([sq, sq + [3.0, 0.0]], names=["hat", "mug"])
    >>> [rel.sentence for rel, _ in out]
    ['The hat is directly to the left of the mug.', 'The mug is directly to the right of the hat.']
    """
    from scenespeak.spatial import forces

    t = thresholds or DEFAULT_THRESHOLDS
    labels = [_label(name, "names") for name in names]
    if len(labels) != len(hulls):
        raise InputError("names", f"give one label per hull: {len(labels)} for {len(hulls)}")
    if heights is not None and len(heights) != len(hulls):
        raise InputError("heights", f"give one array per hull: {len(heights)} for {len(hulls)}")
    if isinstance(directions, bool) or not isinstance(directions, int | np.integer):
        raise InputError("directions", f"must be a multiple of 4 and >= 8, got {directions!r}")
    if directions < 8 or directions % 4:
        raise InputError("directions", f"must be a multiple of 4 and >= 8, got {directions}")
    directions = int(directions)
    polygons = [as_polygon(h, f"{label} hull") for h, label in zip(hulls, labels, strict=True)]
    checked = (
        None
        if heights is None
        else [_heights(h, f"{label} heights") for h, label in zip(heights, labels, strict=True)]
    )
    areas = [abs(polygon_area(p)) for p in polygons]
    convex = [is_convex(p) for p in polygons]
    regions: list[Any] = []
    for p, label in zip(polygons, labels, strict=True):
        try:
            regions.append(forces._polygon_region(p, label))
        except ScenespeakError:
            regions.append(None)  # its pairs take pair_histograms' path (and its error)
    n = len(polygons)
    index = [(i, j) for i in range(n) for j in range(i + 1, n)]
    inter = [
        intersection_area(polygons[i], polygons[j], a_convex=convex[i], b_convex=convex[j])
        for i, j in index
    ]
    intersecting = [
        x > 1e-12 * min(areas[i], areas[j]) for x, (i, j) in zip(inter, index, strict=True)
    ]
    # F0 and F2 of all pairs of prepared regions in one sweep (F02 where F2 is undefined).
    prepared = [
        k for k, (i, j) in enumerate(index) if regions[i] is not None and regions[j] is not None
    ]
    swept = forces._many_f0_and_f2(
        [(regions[index[k][0]], regions[index[k][1]], not intersecting[k]) for k in prepared],
        directions,
    )
    histograms = dict(zip(prepared, swept, strict=True))
    pairs: list[PairHistograms] = []
    for k, (i, j) in enumerate(index):
        if k in histograms:
            f0, f2, hybrid = histograms[k]
        else:
            f0, f2, hybrid = _histograms(polygons[i], polygons[j], directions, intersecting[k])
        pairs.append(PairHistograms(f0, f2, hybrid, inter[k], areas[i], areas[j]))
    # pair_histograms' checks (_as_histogram) of every f0 and f2, in one go.
    checked_hist = _as_histograms([h for p in pairs for h in (p.f0, p.f2)], ("f0", "f2"))
    pairs = [
        PairHistograms(
            checked_hist[2 * k],
            checked_hist[2 * k + 1],
            p.hybrid,
            p.intersection,
            p.area_a,
            p.area_b,
        )
        for k, p in enumerate(pairs)
    ]
    found: dict[tuple[int, int], tuple[Relation, PairHistograms]] = {}
    for (i, j), pair, (deg0, deg2) in zip(index, pairs, _pair_degrees(pairs), strict=True):
        hi = checked[i] if checked is not None else None
        hj = checked[j] if checked is not None else None
        ab, ba, back = _both_ways(pair, labels[i], labels[j], hi, hj, t, deg0, deg2, True)
        found[i, j] = (ab, pair)
        found[j, i] = (ba, back)
    return [found[i, j] for i in range(n) for j in range(n) if i != j]


def relate(
    a: ArrayLike,
    b: ArrayLike,
    *,
    argument: str = "A",
    referent: str = "B",
    directions: int = 180,
    a_heights: ArrayLike | None = None,
    b_heights: ArrayLike | None = None,
    thresholds: Thresholds | None = None,
) -> Relation:
    """Describe where polygon ``a`` is relative to polygon ``b``.

    Computes F0 and F2 with :mod:`scenespeak.spatial.forces` (the hybrid F02 when the polygons
    touch or intersect), the overlap of the footprints and, when both objects' heights are
    given, the vertical relation, which then takes precedence in ``sentence``.

    Parameters
    ----------
    a, b : array_like, shape (N, 2)
        Vertices of the argument and the referent in the horizontal plane's 2-D frame
        (x = camera right, y = depth; metres).
    argument, referent : str
        Labels.
    directions : int
        Histogram bins (a multiple of 4).
    a_heights, b_heights : array_like, optional
        Heights (metres, larger = higher) of each object's points along up.
    thresholds : Thresholds, optional

    Returns
    -------
    Relation

    Examples
    --------
    >>> hat = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> relate(hat, hat + [3.0, 0.0], argument="hat", referent="mug").sentence
    'The hat is directly to the left of the mug.'
    """
    argument = _label(argument, "argument")
    referent = _label(referent, "referent")
    if (a_heights is None) != (b_heights is None):
        raise InputError("a_heights/b_heights", "give the heights of both objects, or neither")
    return relation_of_pair(
        pair_histograms(a, b, directions=directions),
        argument=argument,
        referent=referent,
        a_heights=a_heights,
        b_heights=b_heights,
        thresholds=thresholds,
    )


def describe_viewer_relation(
    polygon: ArrayLike,
    label: str,
    *,
    directions: int = 180,
    viewer_size: float = 0.1,
    thresholds: Thresholds | None = None,
) -> Relation:
    """Describe where an object is relative to the camera: "The mug is in front of me, ...".

    The viewer is a square of side ``viewer_size`` (metres) centred on the camera, at the
    origin of the horizontal plane, looking along +y. Relative to the viewer an object at +y
    is "in front of me" (for objects relative to each other, +y is "behind"), so the histogram
    is mirrored in y before the same rule base runs; ``primary`` and ``secondary`` use the
    viewer's directions (``"front"`` = farther from the camera).

    Examples
    --------
    >>> mug = np.array([[-0.45, 1.0], [-0.25, 1.0], [-0.25, 1.2], [-0.45, 1.2]])
    >>> describe_viewer_relation(mug, "mug").sentence
    'The mug is in front of me, slightly to the left.'
    """
    t = thresholds or DEFAULT_THRESHOLDS
    p = as_polygon(polygon, f"{label} polygon")
    label = _label(label, "label")
    if not (math.isfinite(viewer_size) and viewer_size > 0):
        raise InputError("viewer_size", f"must be a positive size in metres, got {viewer_size}")
    s = 0.5 * viewer_size
    viewer = np.array([[-s, -s], [s, -s], [s, s], [-s, s]])
    inter = intersection_area(p, viewer)
    intersecting = inter > 0.0
    f0, f2, hybrid = _histograms(p, viewer, directions, intersecting)
    mirror = (-np.arange(directions)) % directions  # θ → −θ: +y becomes "front"
    overlap = inter / abs(polygon_area(p)) if intersecting else 0.0
    return _relation_from(
        _as_histogram(f0[mirror], "f0"),
        _as_histogram(f2[mirror], "f2"),
        label,
        "me",
        t,
        overlap=overlap,
        referent_overlap=inter / viewer_size**2 if intersecting else 0.0,
        vertical=None,
        hybrid=hybrid,
        frame="viewer",
    )


# --------------------------------------------------------------------------------------------
# Scene summary
# --------------------------------------------------------------------------------------------
def _join(names: Sequence[str]) -> str:
    names = [f"the {n}" for n in names]
    if len(names) == 1:
        return names[0]
    return ", ".join(names[:-1]) + " and " + names[-1]


def summarize_scene(
    relations: Sequence[Relation],
    *,
    centroids: Mapping[str, ArrayLike] | None = None,
) -> str:
    """A short paragraph about a scene, without all n(n−1) pairwise sentences.

    One overview sentence orders the objects from left to right (by how much each is to the
    right of the others, summed over its relations); then, for each object in that order, one
    sentence: its most informative relation — a vertical or surround relation first, otherwise
    the one to its nearest neighbour (by ``centroids`` when given, else the most confident) —
    skipping a pair already said in the other direction.

    Parameters
    ----------
    relations : sequence of Relation
        Pairwise relations, typically every ordered pair.
    centroids : mapping of label to (2,) array, optional
        Positions on the horizontal plane, to find each object's nearest neighbour.

    Examples
    --------
    >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> objs = {"can": sq, "hat": sq + [2.0, 0.0], "mug": sq + [4.0, 0.0]}
    >>> rels = [relate(objs[x], objs[y], argument=x, referent=y)
    ...         for x in objs for y in objs if x != y]
    >>> summarize_scene(rels)
    'From left to right: the can, the hat and the mug. The can is directly to the left of \
the hat. The mug is directly to the right of the hat.'
    """
    relations = [r for r in relations if r.frame == "object"]
    if not relations:
        return ""
    labels: list[str] = []
    for r in relations:
        for name in (r.argument, r.referent):
            if name not in labels:
                labels.append(name)
    score = {n: 0.0 for n in labels}
    for r in relations:
        lr = r.degrees.get("right", 0.0) - r.degrees.get("left", 0.0)
        score[r.argument] += lr
        score[r.referent] -= lr
    order = sorted(labels, key=lambda n: (score[n], labels.index(n)))
    sentences = [f"From left to right: {_join(order)}."]

    def rank(r: Relation) -> tuple[float, ...]:
        special = 2.0 if r.vertical is not None else 1.0 if r.kind != "direction" else 0.0
        if centroids is not None and r.argument in centroids and r.referent in centroids:
            d = np.asarray(centroids[r.argument], float) - np.asarray(centroids[r.referent], float)
            near = -float(np.hypot(*d[:2]))
        else:  # no positions: neighbours in the left-to-right order count as nearest
            near = -float(abs(order.index(r.argument) - order.index(r.referent)))
        return (special, near, r.confidence)

    said: set[frozenset[str]] = set()
    for name in order:
        own = [r for r in relations if r.argument == name and r.argument != r.referent]
        if not own:
            continue
        best = max(own, key=rank)
        pair = frozenset((best.argument, best.referent))
        if pair in said:  # already said the other way round
            continue
        said.add(pair)
        sentences.append(best.sentence)
    return " ".join(sentences)


# --------------------------------------------------------------------------------------------
# The README table
# --------------------------------------------------------------------------------------------
def _ascii(
    polys: Sequence[tuple[str, NDArray[np.float64]]], width: int = 30, max_rows: int = 10
) -> list[str]:
    """Draw polygons on a character grid, seen from above (top row = farthest).

    One row is two columns tall, so a character cell is square on screen; every object gets at
    least the cell of its centroid, so small ones never vanish.
    """
    from matplotlib.path import Path

    allp = np.vstack([p for _, p in polys])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    cell = max(span[0] / (width - 2), span[1] / (2.0 * (max_rows - 1)))  # x-size of a column
    cols = math.ceil(span[0] / cell) + 2
    rows = math.ceil(span[1] / (2.0 * cell)) + 1
    x0 = lo[0] + 0.5 * span[0] - 0.5 * cols * cell
    y1 = hi[1] - 0.5 * span[1] + 0.5 * rows * 2.0 * cell
    xs = x0 + (np.arange(cols) + 0.5) * cell
    ys = y1 - (np.arange(rows) + 0.5) * 2.0 * cell
    pts = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    grid = np.full((rows, cols), ".", dtype="<U1")
    hits = np.zeros((rows, cols), dtype=int)
    for ch, p in polys:
        inside = Path(p).contains_points(pts).reshape(rows, cols)
        c = p.mean(axis=0)
        col = min(cols - 1, max(0, int((c[0] - x0) // cell)))
        row = min(rows - 1, max(0, int((y1 - c[1]) // (2.0 * cell))))
        inside[row, col] = True
        grid[inside & (hits == 0)] = ch
        grid[inside & (hits > 0)] = "#"
        hits += inside
    return ["".join(r) for r in grid]


def layout_table() -> str:
    """The README table: every example layout as an ASCII picture with the sentence produced.

    Pictures are seen from above with the camera below them (up = behind, down = in front);
    the argument and the referent are drawn with the capital first letter of their labels,
    other objects of the same scene in lower case, ``#`` where objects overlap. Run
    ``python -m scenespeak.spatial.language --table`` to print it; ``docs/language.md`` holds a copy
    that ``tests/test_language.py`` keeps true.
    """
    from scenespeak.spatial.layouts import LAYOUTS

    out = [
        "Seen from above, the camera below each picture (up = behind = farther, down = in "
        "front); argument and referent in capitals, other objects of the scene in lower case, "
        "`#` where objects overlap.",
        "",
    ]
    for lay in LAYOUTS:
        a_ch, b_ch = lay.argument[0].upper(), lay.referent[0].upper()
        if a_ch == b_ch:
            a_ch, b_ch = "A", "B"
        rel = relate(
            lay.a,
            lay.b,
            argument=lay.argument,
            referent=lay.referent,
            a_heights=lay.a_heights,
            b_heights=lay.b_heights,
        )
        extra = [(name[0].lower(), poly) for name, poly in lay.others]
        pic = _ascii([*extra, (a_ch, lay.a), (b_ch, lay.b)])
        out.append(f"**{lay.name}** — {lay.note}")
        out.append("")
        out.append("```text")
        mid = len(pic) // 2
        for i, row in enumerate(pic):
            out.append(row + ("   → " + rel.sentence if i == mid else ""))
        out.append("```")
        out.append("")
    return "\n".join(out)


_TABLE_START = "<!-- layout-table:start"
_TABLE_END = "<!-- layout-table:end -->"


def update_doc_table(text: str) -> str:
    """Replace the generated layout table between the markers of ``docs/language.md``."""
    i = text.find(_TABLE_START)
    j = text.find(_TABLE_END)
    if i < 0 or j < i:
        raise InputError("docs", f"has no '{_TABLE_START} ... {_TABLE_END}' markers")
    i = text.index("\n", i) + 1
    return text[:i] + layout_table() + "\n" + text[j:]


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m scenespeak.spatial.language --table``: print the layout table (Markdown).

    ``--update-doc docs/language.md`` rewrites the table inside that file instead.
    """
    parser = argparse.ArgumentParser(prog="python -m scenespeak.spatial.language")
    parser.add_argument("--table", action="store_true", help="print the layout table")
    parser.add_argument("--update-doc", metavar="MD", help="rewrite the table in this file")
    args = parser.parse_args(argv)
    import sys

    if args.update_doc:
        from pathlib import Path

        path = Path(args.update_doc)
        path.write_text(update_doc_table(path.read_text(encoding="utf-8")), encoding="utf-8")
        return 0
    if args.table:
        sys.stdout.write(layout_table() + "\n")
        return 0
    parser.print_help()
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
