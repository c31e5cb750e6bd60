"""Polygons → force histograms of a pair → its relations (both ways round)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError, ScenespeakError
from scenespeak.geometry.polygons import as_polygon, intersection_area, polygon_area
from scenespeak.spatial.degrees import DIRECTIONS, DirectionDegree, many_degrees
from scenespeak.spatial.language.relation import Relation, _twin
from scenespeak.spatial.language.rules import (
    _as_histogram,
    _check_something,
    _coverage,
    _Facts,
    _relation_from,
)
from scenespeak.spatial.language.thresholds import DEFAULT_THRESHOLDS, Thresholds
from scenespeak.spatial.language.vertical import vertical_relation
from scenespeak.spatial.language.words import _label

__all__ = ["PairHistograms", "pair_histograms", "relation_of_pair", "relations_of_pair"]


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


@dataclass(frozen=True, eq=False, slots=True)
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


#: :class:`PairHistograms`' mutable twin (:func:`~.relation._twin`), for
#: :func:`~.relate.relate_objects`' fast fill.
_PairHistogramsFill = _twin(PairHistograms)


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
    from scenespeak.spatial.forces import guards

    directions = guards.check_directions(directions)
    if directions < 8 or directions % 4:
        raise InputError("directions", f"must be a multiple of 4 and >= 8, got {directions}")
    # Coordinates far from unit size are computed at unit size and scaled back (F0 ~ k^3,
    # F2 and F02 ~ k, areas ~ k^2), so 1e-160 or 1e150 never give NaN or all-zero forces.
    a_arr, b_arr, k = guards.normalise_pair(
        guards.as_vertices(a, "argument polygon"), guards.as_vertices(b, "referent polygon")
    )
    pa = as_polygon(a_arr, "argument polygon")
    pb = as_polygon(b_arr, "referent polygon")
    inter = intersection_area(pa, pb)
    area_a, area_b = abs(polygon_area(pa)), abs(polygon_area(pb))
    f0, f2, hybrid = _histograms(pa, pb, directions, inter > 1e-12 * min(area_a, area_b))
    if k != 1.0:
        f0 = guards.rescaled(f0, k, [0.0])
        f2 = guards.rescaled(f2, k, [2.0])
        inter, area_a, area_b = inter * k * k, area_a * k * k, area_b * k * k
        if not np.isfinite([inter, area_a, area_b]).all():
            raise InputError("argument/referent", f"areas of objects of size {k:.3g} overflow")
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
    for h, name in ((pair.f0, "f0"), (pair.f2, "f2")):  # as describe_relation: no force,
        _check_something(_as_histogram(h, name), name)  # no sentence
    return _describe_pair(pair, (argument, referent), (a_heights, b_heights), t)


def _describe_pair(
    pair: PairHistograms,
    names: tuple[str, str],
    heights: tuple[ArrayLike | None, ArrayLike | None],
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
    a_heights, b_heights = heights
    skip = heights_checked and pair.horizontal_overlap < t.vertical_overlap
    if a_heights is not None and b_heights is not None and not skip:
        vertical = vertical_relation(
            a_heights, b_heights, horizontal_overlap=pair.horizontal_overlap, thresholds=t
        )
    facts = _Facts(pair.overlap, pair.referent_overlap, vertical, pair.hybrid, "object")
    return _relation_from(pair.f0, pair.f2, names, t, facts, degrees=degrees, coverage=coverage)


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
    ab, ba, _ = _both_ways(pair, (argument, referent), (a_heights, b_heights), t, (deg0, deg2))
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
    names: tuple[str, str],
    heights: tuple[ArrayLike | None, ArrayLike | None],
    t: Thresholds,
    degrees: tuple[dict[str, DirectionDegree], dict[str, DirectionDegree]],
    heights_checked: bool = False,
) -> tuple[Relation, Relation, PairHistograms]:
    """The rule base on a pair and on its reverse (B's degree for "left" is A's for "right").

    Returns the two relations and ``pair.reversed()``.
    """
    deg0, deg2 = degrees
    back = pair.reversed()
    reversed_degrees = (
        {d: deg0[_OPPOSITE[d]] for d in DIRECTIONS},
        {d: deg2[_OPPOSITE[d]] for d in DIRECTIONS},
    )
    # The coverage of F0 turned by 180° is the same: the circular moving average turns with
    # it (each smoothed bin is the same dot product of the same numbers), the count is equal.
    cov = _coverage(pair.f0, t)
    ab = _describe_pair(pair, names, heights, t, degrees, heights_checked, cov)
    back_names = (names[1], names[0])
    back_heights = (heights[1], heights[0])
    ba = _describe_pair(back, back_names, back_heights, t, reversed_degrees, heights_checked, cov)
    return ab, ba, back
