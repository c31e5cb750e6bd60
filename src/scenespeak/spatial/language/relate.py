"""Relating polygons: one pair (:func:`relate`) or every ordered pair of a scene."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError, ScenespeakError
from scenespeak.geometry.polygons import as_polygon, intersection_area, is_convex, polygon_area
from scenespeak.spatial.language.pairs import (
    PairHistograms,
    _both_ways,
    _histograms,
    _pair_degrees,
    pair_histograms,
    relation_of_pair,
)
from scenespeak.spatial.language.relation import Relation
from scenespeak.spatial.language.rules import _as_histograms
from scenespeak.spatial.language.thresholds import DEFAULT_THRESHOLDS, Thresholds
from scenespeak.spatial.language.vertical import _heights
from scenespeak.spatial.language.words import _label

__all__ = ["relate", "relate_objects"]


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
        The objects' footprints on the horizontal plane (the 2-D frame of ``docs/interfaces.md``,
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
    t = thresholds or DEFAULT_THRESHOLDS
    labels = _scene_labels(hulls, names, heights)
    directions = _checked_directions(directions)
    polygons = [as_polygon(h, f"{label} hull") for h, label in zip(hulls, labels, strict=True)]
    checked = (
        None
        if heights is None
        else [_heights(h, f"{label} heights") for h, label in zip(heights, labels, strict=True)]
    )
    n = len(polygons)
    index = [(i, j) for i in range(n) for j in range(i + 1, n)]
    pairs = _scene_pairs(polygons, labels, index, directions)
    found: dict[tuple[int, int], tuple[Relation, PairHistograms]] = {}
    for (i, j), pair, (deg0, deg2) in zip(index, pairs, _pair_degrees(pairs), strict=True):
        hi = checked[i] if checked is not None else None
        hj = checked[j] if checked is not None else None
        names, hs = (labels[i], labels[j]), (hi, hj)
        ab, ba, back = _both_ways(pair, names, hs, t, (deg0, deg2), True)
        found[i, j] = (ab, pair)
        found[j, i] = (ba, back)
    return [found[i, j] for i in range(n) for j in range(n) if i != j]


def _scene_labels(
    hulls: Sequence[ArrayLike], names: Sequence[str], heights: Sequence[ArrayLike] | None
) -> list[str]:
    """The checked labels, one per hull (and as many height arrays, if any)."""
    labels = [_label(name, "names") for name in names]
    if len(labels) != len(hulls):
        raise InputError("names", f"give one label per hull: {len(labels)} for {len(hulls)}")
    if heights is not None and len(heights) != len(hulls):
        raise InputError("heights", f"give one array per hull: {len(heights)} for {len(hulls)}")
    return labels


def _checked_directions(directions: object) -> int:
    """``directions`` as an int, or the error: a multiple of 4 and >= 8."""
    if isinstance(directions, bool) or not isinstance(directions, int | np.integer):
        raise InputError("directions", f"must be a multiple of 4 and >= 8, got {directions!r}")
    if directions < 8 or directions % 4:
        raise InputError("directions", f"must be a multiple of 4 and >= 8, got {directions}")
    return int(directions)


def _prepared_regions(polygons: Sequence[NDArray[np.float64]], labels: Sequence[str]) -> list[Any]:
    """Each polygon prepared once for the force sweep, or None where preparing fails (its
    pairs then take :func:`pair_histograms`' path, and its error)."""
    from scenespeak.spatial import forces

    regions: list[Any] = []
    for p, label in zip(polygons, labels, strict=True):
        try:
            regions.append(forces.prepare(p, label))
        except ScenespeakError:
            regions.append(None)
    return regions


def _scene_pairs(
    polygons: Sequence[NDArray[np.float64]],
    labels: Sequence[str],
    index: Sequence[tuple[int, int]],
    directions: int,
) -> list[PairHistograms]:
    """:class:`PairHistograms` of every pair ``(i, j)`` of ``index``: the same floats as
    ``pair_histograms(polygons[i], polygons[j])``, with one force sweep for all pairs."""

    areas = [abs(polygon_area(p)) for p in polygons]
    convex = [is_convex(p) for p in polygons]
    regions = _prepared_regions(polygons, labels)
    inter = [
        intersection_area(polygons[i], polygons[j], a_convex=convex[i], b_convex=convex[j])
        for i, j in index
    ]
    intersecting = [
        x > 1e-12 * min(areas[i], areas[j]) for x, (i, j) in zip(inter, index, strict=True)
    ]
    histograms = _swept(regions, index, intersecting, directions)
    raw: list[NDArray[np.float64]] = []
    hybrids: list[bool] = []
    for k, (i, j) in enumerate(index):
        if k in histograms:
            f0, f2, hybrid = histograms[k]
        else:
            f0, f2, hybrid = _histograms(polygons[i], polygons[j], directions, intersecting[k])
        raw += [f0, f2]
        hybrids.append(hybrid)
    # pair_histograms' checks (_as_histogram) of every f0 and f2, in one go.
    checked = _as_histograms(raw, ("f0", "f2"))
    return [
        PairHistograms(checked[2 * k], checked[2 * k + 1], hybrids[k], inter[k], areas[i], areas[j])
        for k, (i, j) in enumerate(index)
    ]


def _swept(
    regions: Sequence[Any],
    index: Sequence[tuple[int, int]],
    intersecting: Sequence[bool],
    directions: int,
) -> dict[int, tuple[NDArray[np.float64], NDArray[np.float64], bool]]:
    """F0 and F2 (F02 where F2 is undefined) of every pair ``k`` whose two regions are
    prepared, in one sweep: ``{k: (f0, f2, hybrid)}``."""
    from scenespeak.spatial import forces

    prepared = [
        k for k, (i, j) in enumerate(index) if regions[i] is not None and regions[j] is not None
    ]
    # Regions that failed to prepare are None: only the others go to the sweep.
    usable = [r for r in regions if r is not None]
    slot = {id(r): g for g, r in enumerate(usable)}
    swept = forces.f0_f2_pairs(
        usable,
        [(slot[id(regions[index[k][0]])], slot[id(regions[index[k][1]])]) for k in prepared],
        directions,
        try_f2=[not intersecting[k] for k in prepared],
    )
    return {k: (swept.f0[q], swept.f2[q], bool(swept.hybrid[q])) for q, k in enumerate(prepared)}


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
