"""Relating polygons: one pair (:func:`relate`) or every ordered pair of a scene."""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError
from scenespeak.geometry.polygons import as_polygon
from scenespeak.spatial.degrees import DIRECTIONS, four_direction_degrees
from scenespeak.spatial.language.batch import (
    HEDGES,
    KINDS,
    SECONDARY_HEDGES,
    PairDecisions,
    coverages,
    decide_pairs,
    sector_shares,
    sentence_templates,
)
from scenespeak.spatial.language.pairs import (
    PairHistograms,
    _PairHistogramsFill,
    pair_histograms,
    relation_of_pair,
)
from scenespeak.spatial.language.related import RelatedPairs, _collector_paused
from scenespeak.spatial.language.relation import Relation, _RelationFill
from scenespeak.spatial.language.scenepairs import ScenePairs, scene_pairs
from scenespeak.spatial.language.thresholds import DEFAULT_THRESHOLDS, Thresholds
from scenespeak.spatial.language.vertical import _extent, _heights, _vertical_rule
from scenespeak.spatial.language.words import _label

__all__ = ["relate", "relate_objects"]


def relate_objects(
    hulls: Sequence[ArrayLike],
    *,
    names: Sequence[str],
    heights: Sequence[ArrayLike] | None = None,
    directions: int = 180,
    thresholds: Thresholds | None = None,
) -> RelatedPairs:
    """Every ordered pair of a scene's objects: the relation and the histograms behind it.

    The same relations and histograms as, for every unordered pair ``i < j``,
    ``pair = pair_histograms(hulls[i], hulls[j])``, ``relations_of_pair(pair, ...)`` and
    ``pair.reversed()`` (the same floats), but computed for all pairs at once: each polygon is
    validated and prepared once, only hulls whose boxes meet are clipped, F0 and F2 (or F0
    and F02) come from one sweep (:func:`~.scenepairs.scene_pairs`), and the degrees of truth
    and the rule base run on arrays of all ordered pairs (:mod:`~.batch`); the result objects
    are made from those arrays when the result is first read (:class:`~.related.RelatedPairs`).
    Memory is linear in the pairs. ``benchmarks/bench_relate.py`` times it on 10 to 100
    objects (9,900 ordered pairs) next to the per-pair path.

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
    RelatedPairs
        A sequence that behaves as the list of ``(Relation, PairHistograms)``, one entry per
        ordered pair ``(i, j)``, ``i != j``, in the order ``(0, 1), (0, 2), ..., (1, 0),
        (1, 2), ...``: the relation of object ``i`` (argument) to object ``j`` (referent) and
        the histograms of ``i`` relative to ``j``.

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
    extents = (
        None
        if heights is None
        else [
            _extent(_heights(h, f"{label} heights"))
            for h, label in zip(heights, labels, strict=True)
        ]
    )
    if len(polygons) < 2:
        return RelatedPairs(list, 0)
    with _collector_paused():
        return _ordered_relations(scene_pairs(polygons, labels, directions), labels, extents, t)


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


#: Column ``k`` of the reversed pair's degrees is column ``_TURNED[k]`` of the pair's: B's
#: degree for "left" is A's for "right" (F(B, A) is F(A, B) turned by half a turn).
_TURNED = [DIRECTIONS.index(d) for d in ("left", "front", "right", "behind")]


def _ordered_relations(
    scene: ScenePairs,
    labels: Sequence[str],
    extents: Sequence[tuple[float, float, float]] | None,
    t: Thresholds,
) -> RelatedPairs:
    """Both relations of every pair of ``scene``, in :func:`relate_objects`' order.

    Rows ``0..P-1`` are the pairs ``(first, second)``, rows ``P..2P-1`` the same pairs the
    other way round; every step of the rule base runs on all rows at once
    (:func:`~.batch.decide_pairs`); each pair becomes its two :class:`Relation` when the
    result is first read (:func:`_build`).
    """
    p = len(scene.first)
    back0, back2 = _half_turned(scene.f0), _half_turned(scene.f2)
    # The degrees of the reversed pair are the pair's, turned (as relations_of_pair does).
    deg0, dev0 = four_direction_degrees(scene.f0)
    deg2, dev2 = four_direction_degrees(scene.f2)
    argument = np.concatenate([scene.first, scene.second])
    referent = np.concatenate([scene.second, scene.first])
    inter = np.concatenate([scene.intersection, scene.intersection])
    area_a, area_b = scene.area[argument], scene.area[referent]
    smaller = np.minimum(area_a, area_b)
    intersecting = inter > 1e-12 * smaller
    overlap = np.where(intersecting, inter / area_a, 0.0)
    referent_overlap = np.where(intersecting, inter / area_b, 0.0)
    # The coverage of F0 turned by half a turn is the same (see pairs._both_ways).
    coverage = coverages(scene.f0, t)
    decisions = decide_pairs(
        (_turned(deg0), _turned(deg2)),
        _turned(dev2),
        np.concatenate([sector_shares(scene.f0), sector_shares(back0)]),
        (overlap, referent_overlap),
        np.tile(coverage, 2),
        t,
    )
    vertical = _verticals(argument, referent, inter / np.maximum(smaller, 1e-300), extents, t)
    confidence = decisions.confidence
    if extents is not None:  # without heights no row has a vertical relation
        has_vertical = np.array([v is not None for v in vertical], dtype=bool).reshape(-1)
        confidence = np.where(
            has_vertical, np.maximum(confidence, np.minimum(1.0, 2.0 * overlap)), confidence
        )
    confidence = np.minimum(np.maximum(confidence, 0.0), 1.0)
    table = np.empty(len(labels), dtype=object)
    table[:] = labels  # the label strings themselves, gathered without a Python loop
    n = len(labels)
    place = np.concatenate(
        [scene.first * (n - 1) + scene.second - 1, scene.second * (n - 1) + scene.first]
    )
    order = np.empty(2 * p, dtype=np.intp)
    order[place] = np.arange(2 * p)
    rows = _Rows(
        names=(table, argument, referent),
        decisions=decisions,
        order=order,
        vertical=vertical,
        hybrid=scene.hybrid.tolist(),
        own=(confidence, decisions.deviation, decisions.extends_share),
        degrees=(deg0, deg2, 0.5 * (deg0 + deg2), dev0, dev2),
        pair=(coverage, overlap[:p], referent_overlap[:p]),
        areas=(scene.intersection, area_a[:p], area_b[:p]),
        histograms=(scene.f0, back0, scene.f2, back2),
    )
    return RelatedPairs(functools.partial(_build, rows), 2 * p)


def _half_turned(h: NDArray[np.float64]) -> NDArray[np.float64]:
    """The pairs' histograms turned by half a turn: the reversed pairs'
    (``PairHistograms.reversed``)."""
    p, nbins = h.shape
    half = nbins // 2
    out = np.empty((p, nbins))
    out[:, :half] = h[:, nbins - half :]
    out[:, half:] = h[:, : nbins - half]
    return out


def _turned(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(2P, 4)``: the pairs' values of the four directions, then the reversed pairs' (B's
    "left" is A's "right")."""
    return np.concatenate([x, x[:, _TURNED]])


def _words(decisions: PairDecisions) -> tuple[list[str | None], ...]:
    """The words of every row: kind, primary, secondary, hedge, secondary hedge."""
    # Index -1 (no word) picks the None at the end of each table.
    tables = [
        (KINDS, decisions.kind),
        ((*DIRECTIONS, "surrounded"), decisions.primary),
        ((*DIRECTIONS, None), decisions.secondary),
        ((*HEDGES, None), decisions.hedge),
        ((*SECONDARY_HEDGES, None), decisions.secondary_hedge),
    ]
    return tuple(np.array(table, dtype=object)[codes].tolist() for table, codes in tables)


def _verticals(
    argument: NDArray[np.intp],
    referent: NDArray[np.intp],
    horizontal_overlap: NDArray[np.float64],
    extents: Sequence[tuple[float, float, float]] | None,
    t: Thresholds,
) -> list[str | None]:
    """The vertical relation of every row (:func:`vertical_relation`; None without heights
    or where the footprints overlap by less than ``vertical_overlap``)."""
    found: list[str | None] = [None] * len(argument)
    if extents is None:
        return found
    for r in np.flatnonzero(horizontal_overlap >= t.vertical_overlap).tolist():
        found[r] = _vertical_rule(extents[argument[r]], extents[referent[r]], t)
    return found


@dataclass(frozen=True)
class _Rows:
    """What :func:`_build` makes the results of: rows ``0..P-1`` are the pairs, ``P..2P-1``
    the same pairs the other way round (lists or arrays of ``2P``, or arrays of ``P`` shared
    by both rows of a pair, in the pairs' order)."""

    #: The labels (an object array of the strings), and the argument's and the referent's
    #: object of every row.
    names: tuple[NDArray[np.object_], NDArray[np.intp], NDArray[np.intp]]
    #: The rule base's decision of every row (its words: :func:`_words`).
    decisions: PairDecisions
    #: The row at each place of the output.
    order: NDArray[np.intp]
    #: The vertical word of every row, or None.
    vertical: list[str | None]
    #: Whether each pair's ``f2`` is the hybrid F02 (``P``).
    hybrid: list[bool]
    #: Confidence, deviation and extends share of every row (``2P``).
    own: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
    #: ``(P, 4)``: degrees from F0, from F2, their mean; deviations of F0 and of F2.
    degrees: tuple[NDArray[np.float64], ...]
    #: Coverage, overlap and referent overlap of each pair (``P``).
    pair: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
    #: Intersection and the two areas of each pair (``P``).
    areas: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
    #: ``(P, directions)``: F0, F0 half-turned, F2, F2 half-turned.
    histograms: tuple[NDArray[np.float64], ...]


def _build(rows: _Rows) -> list[tuple[Relation, PairHistograms]]:
    """Each row's :class:`Relation` and :class:`PairHistograms`, in the output order
    (``rows.order``); what :class:`~.related.RelatedPairs` makes on its first read.

    The objects are the ones ``Relation(...)`` and ``PairHistograms(...)`` make (the same
    fields, in the same order). A frozen dataclass' ``__init__`` sets each field through
    ``object.__setattr__``, which for 23 fields would cost more than the rule base itself;
    they are made column by column instead (``map`` over the columns) by the classes'
    mutable twins (:func:`~.relation._twin`: the same slots, an ``__init__`` that stores
    them directly), then turned into the frozen classes by ``__class__`` assignment. The
    two rows of a pair hold the same float objects (turned: B's left is A's right).
    """
    table, argument, referent = rows.names
    arguments, referents = table[argument].tolist(), table[referent].tolist()
    kinds, primaries, secondaries, hedges, sec_hedges = _words(rows.decisions)
    templates = sentence_templates(rows.decisions)
    horizontals, sentences = _sentences(arguments, referents, rows.vertical, templates)
    confidence, deviation, extends = (x.tolist() for x in rows.own)
    coverage, ov, rov = (x.tolist() for x in rows.pair)
    inter, aa, ab = (x.tolist() for x in rows.areas)
    hybrid = rows.hybrid + rows.hybrid
    rels = list(
        map(
            _RelationFill,
            arguments,
            referents,
            primaries,
            secondaries,
            hedges,
            sentences,
            confidence,
            sec_hedges,
            kinds,
            horizontals,
            *(_direction_dicts(x) for x in rows.degrees),
            deviation,
            coverage + coverage,
            extends,
            ov + rov,
            rov + ov,
            rows.vertical,
            hybrid,
            itertools.repeat("object"),
        )
    )
    f0, back0, f2, back2 = rows.histograms
    hists = list(
        map(
            _PairHistogramsFill,
            [*f0, *back0],
            [*f2, *back2],
            hybrid,
            inter + inter,
            aa + ab,
            ab + aa,
        )
    )
    # In the rows' order (the objects lie in memory in that order: a pass in the output's
    # order would jump between them, about twice as slow), then each pair to its place.
    for rel in rels:
        rel.__class__ = Relation
    for hist in hists:
        hist.__class__ = PairHistograms
    both = list(zip(rels, hists, strict=True))
    return [both[r] for r in rows.order.tolist()]


def _direction_dicts(x: NDArray[np.float64]) -> list[dict[str, float]]:
    """The ``{"right": ..., "behind": ..., "left": ..., "front": ...}`` of every row: the
    pairs' ``(P, 4)`` values, then the same floats turned for the pairs the other way round."""
    flat = x.ravel().tolist()
    columns = flat[0::4], flat[1::4], flat[2::4], flat[3::4]
    forward = [
        {"right": r, "behind": b, "left": lf, "front": f}
        for r, b, lf, f in zip(*columns, strict=True)
    ]
    return forward + [
        {"right": lf, "behind": f, "left": r, "front": b}
        for r, b, lf, f in zip(*columns, strict=True)
    ]


def _sentences(
    arguments: list[str],
    referents: list[str],
    verticals: list[str | None],
    templates: tuple[list[str], dict[str, str]],
) -> tuple[list[str], list[str]]:
    """Every row's horizontal sentence and the sentence it says (the vertical one where it
    has one): the templates filled with the row's labels, the strings that
    ``template.format(argument=..., referent=...)`` gives (through :func:`_printf`)."""
    horizontal_templates, vertical_templates = templates
    patterns = {t: _printf(t) for t in set(horizontal_templates)}
    rows = zip(horizontal_templates, arguments, referents, strict=True)
    if all(p is not None and p[1] == 2 for p in patterns.values()):
        # The usual case: every pattern names the argument, then the referent.
        texts = {t: p[0] for t, p in patterns.items() if p is not None}
        horizontal = [texts[t] % (a, r) for t, a, r in rows]
    else:
        horizontal = [_fill(t, patterns[t], a, r) for t, a, r in rows]
    if all(v is None for v in verticals):
        return horizontal, horizontal
    said = list(horizontal)
    for r, word in enumerate(verticals):
        if word is not None:
            said[r] = vertical_templates[word].format(argument=arguments[r], referent=referents[r])
    return horizontal, said


def _fill(template: str, pattern: tuple[str, int] | None, argument: str, referent: str) -> str:
    """``template.format(argument=argument, referent=referent)``, through its ``%`` pattern
    where it has one (:func:`_printf`)."""
    if pattern is None:
        return template.format(argument=argument, referent=referent)
    text, fields = pattern
    if fields == 2:
        return text % (argument, referent)
    return text % (argument, referent, referent)


def _printf(template: str) -> tuple[str, int] | None:
    """``template`` (with ``{argument}`` and ``{referent}``) as a ``%`` pattern and its number
    of fields: ``pattern % (argument, referent)`` (2) or ``% (argument, referent, referent)``
    (3) is the string ``template.format(...)`` gives, several times faster than ``format``
    with keywords. None for any other order of the fields (``format`` then fills it).

    Examples
    --------
    >>> _printf("The {argument} is 5% left of the {referent}.")
    ('The %s is 5%% left of the %s.', 2)
    >>> _printf("The {referent} is under the {argument}.") is None
    True
    """
    import string

    fields = tuple(name for _, name, _, _ in string.Formatter().parse(template) if name is not None)
    if fields not in (("argument", "referent"), ("argument", "referent", "referent")):
        return None
    if any(spec or conv for _, name, spec, conv in string.Formatter().parse(template) if name):
        return None
    parts = [
        text.replace("%", "%%") + ("%s" if name is not None else "")
        for text, name, _, _ in string.Formatter().parse(template)
    ]
    return "".join(parts), len(fields)


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
