"""The rule base vectorised over pairs gives what the per-pair path gives (issue 16).

``relate_objects`` decides every ordered pair of a scene on arrays
(``language.batch.decide_pairs``, ``coverages``, ``sector_shares``,
``degrees.four_direction_degrees``); ``pair_histograms`` + ``relations_of_pair`` (one pair at
a time, the rule base in Python) stay the reference. The relations are compared field by
field and bit for bit (so the words are the same and the degrees agree far within 1e-9), on
random scenes with disjoint, overlapping, touching, nested and stacked objects, unknown
objects, and every layout of the README table placed among them (which between them use every
kind, hedge, secondary hedge and vertical word: checked below, so that the comparison cannot
pass on easy scenes alone).
"""

from __future__ import annotations

import collections
import copy
import dataclasses
import gc
import importlib
import math
import pickle
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scenespeak.errors import InputError
from scenespeak.spatial import language
from scenespeak.spatial.degrees import (
    DIRECTIONS,
    DirectionDegree,
    four_degrees,
    four_direction_degrees,
)
from scenespeak.spatial.language import batch, rules
from scenespeak.spatial.language.thresholds import DEFAULT_THRESHOLDS, Thresholds
from scenespeak.spatial.layouts import LAYOUTS, disc, rect

relate_module = importlib.import_module("scenespeak.spatial.language.relate")
seeds = st.integers(min_value=0, max_value=2**32 - 1)


@pytest.fixture(autouse=True, scope="module")
def _one_force_kernel() -> Iterator[None]:
    """Both paths on the same force kernel. By default (``SCENESPEAK_NUMBA=auto``) a process
    switches from the NumPy reference to the compiled sweep once its work pays for loading
    Numba, which could happen between the two paths of a comparison (the kernels agree to
    1e-9, not bit for bit). The policy is read at every sweep."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SCENESPEAK_NUMBA", "never")
        yield


# -- scenes --------------------------------------------------------------------------------


def _convex(rng: np.random.Generator, centre: np.ndarray, size: float) -> np.ndarray:
    """A convex polygon of 3-24 vertices round ``centre`` (either orientation)."""
    m = int(rng.integers(3, 25))
    ang = np.sort(rng.uniform(0.0, 2.0 * np.pi, m))
    ang[0] = 0.0
    ang[1:] = np.maximum.accumulate(ang[1:])
    ang = np.unique(np.round(ang, 6))
    if ang.size < 3:
        ang = np.array([0.0, 2.1, 4.2])
    stretch = rng.uniform(0.4, 1.0, 2) * size
    poly = np.column_stack([np.cos(ang) * stretch[0], np.sin(ang) * stretch[1]]) + centre
    return poly[::-1].copy() if rng.random() < 0.3 else poly


def _star(rng: np.random.Generator, centre: np.ndarray, size: float) -> np.ndarray:
    """A star-shaped (non-convex) polygon of 5-20 vertices."""
    m = int(rng.integers(5, 21))
    ang = (np.arange(m) + rng.uniform(0.0, 0.8, m)) * (2.0 * np.pi / m)
    rad = rng.uniform(0.35, 1.0, m) * size
    return np.column_stack([centre[0] + rad * np.cos(ang), centre[1] + rad * np.sin(ang)])


def _object(rng: np.random.Generator, spread: float) -> np.ndarray:
    centre = rng.uniform(-spread, spread, 2) + np.array([0.0, 1.0])
    size = float(rng.uniform(0.03, 0.25))
    kind = rng.random()
    if kind < 0.15:
        return _star(rng, centre, size)
    if kind < 0.25:  # axis-aligned, on a grid: symmetric histograms, exact ties
        x, y = np.round(centre, 1)
        return rect(x, y, x + 0.1, y + 0.1)
    return _convex(rng, centre, size)


def _nested(rng: np.random.Generator, outer: np.ndarray) -> np.ndarray:
    """A smaller copy inside (or poking out of) ``outer``."""
    c = outer.mean(axis=0)
    shrunk = (outer - c) * rng.uniform(0.2, 0.6) + c
    return shrunk + rng.normal(size=2) * rng.choice([0.0, 0.02, 0.08])


def _touching(rng: np.random.Generator, fixed: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """``moved`` translated along a random direction until it touches ``fixed``."""
    d = rng.normal(size=2)
    d /= np.hypot(*d)
    return moved + ((fixed @ d).max() - (moved @ d).min()) * d


def scene(rng: np.random.Generator) -> tuple[list[np.ndarray], list[str], list[np.ndarray]]:
    """2-10 polygons with names (some "unknown object k") and heights along up."""
    spread = float(rng.choice([0.3, 1.0]))
    hulls = [_object(rng, spread) for _ in range(int(rng.integers(2, 11)))]
    if rng.random() < 0.5:
        hulls.append(_nested(rng, hulls[0]))
    if rng.random() < 0.4:
        hulls.append(_touching(rng, hulls[1], hulls[-1]))
    names = [
        f"unknown object {k}" if rng.random() < 0.3 else f"thing {k}" for k in range(len(hulls))
    ]
    heights = []
    for _ in hulls:
        base = float(rng.choice([0.0, 0.0, 0.12, 0.5]))
        heights.append(base + rng.uniform(0.0, 0.12, int(rng.integers(3, 30))))
    return hulls, names, heights


def layout_scene(index: int) -> tuple[list[np.ndarray], list[str], list[np.ndarray] | None]:
    """The README table's layout ``index`` with its other objects and two far objects."""
    lay = LAYOUTS[index]
    hulls = [
        lay.a,
        lay.b,
        *(h for _, h in lay.others),
        disc(0.6, 1.4, 0.05),
        rect(-1, 2, -0.8, 2.3),
    ]
    names = [lay.argument, lay.referent, *(k for k, _ in lay.others), "unknown object 1", "tray"]
    heights = None
    if lay.a_heights is not None and lay.b_heights is not None:
        heights = [lay.a_heights, lay.b_heights] + [np.linspace(0.0, 0.1, 5)] * (len(hulls) - 2)
    return hulls, names, heights


def reference(
    hulls: list[np.ndarray],
    names: list[str],
    heights: list[np.ndarray] | None,
    directions: int = 180,
    thresholds: Thresholds | None = None,
) -> list[tuple[language.Relation, language.PairHistograms]]:
    """Every ordered pair through the per-pair functions, in relate_objects' order."""
    found = {}
    for i in range(len(hulls)):
        for j in range(i + 1, len(hulls)):
            pair = language.pair_histograms(hulls[i], hulls[j], directions=directions)
            ab, ba = language.relations_of_pair(
                pair,
                argument=names[i],
                referent=names[j],
                a_heights=None if heights is None else heights[i],
                b_heights=None if heights is None else heights[j],
                thresholds=thresholds,
            )
            found[i, j], found[j, i] = (ab, pair), (ba, pair.reversed())
    n = len(hulls)
    return [found[i, j] for i in range(n) for j in range(n) if i != j]


def assert_same(got: list, expected: list) -> None:
    assert len(got) == len(expected)
    for (rel, hist), (ref_rel, ref_hist) in zip(got, expected, strict=True):
        assert rel == ref_rel, (rel.sentence, ref_rel.sentence)  # every field, bit for bit
        assert rel.sentence == ref_rel.sentence
        for d in DIRECTIONS:
            assert abs(rel.degrees[d] - ref_rel.degrees[d]) <= 1e-9
        np.testing.assert_array_equal(hist.f0, ref_hist.f0)
        np.testing.assert_array_equal(hist.f2, ref_hist.f2)
        assert hist.hybrid == ref_hist.hybrid
        assert hist.intersection == ref_hist.intersection
        assert (hist.area_a, hist.area_b) == (ref_hist.area_a, ref_hist.area_b)


# -- relate_objects against the per-pair path ----------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(seeds)
def test_relate_objects_is_the_per_pair_path_on_random_scenes(seed: int) -> None:
    rng = np.random.default_rng(seed)
    hulls, names, heights = scene(rng)
    use = heights if rng.random() < 0.7 else None
    assert_same(
        language.relate_objects(hulls, names=names, heights=use), reference(hulls, names, use)
    )


@pytest.mark.parametrize("index", range(len(LAYOUTS)))
def test_relate_objects_is_the_per_pair_path_on_every_layout(index: int) -> None:
    hulls, names, heights = layout_scene(index)
    got = language.relate_objects(hulls, names=names, heights=heights)
    assert_same(got, reference(hulls, names, heights))


def test_the_layouts_use_every_word() -> None:
    """The layouts above reach every kind, hedge, secondary hedge and vertical word."""
    seen: dict[str, set[object]] = {"kind": set(), "hedge": set(), "sec": set(), "vert": set()}
    for index in range(len(LAYOUTS)):
        hulls, names, heights = layout_scene(index)
        for rel, _ in language.relate_objects(hulls, names=names, heights=heights):
            seen["kind"].add(rel.kind)
            seen["hedge"].add(rel.hedge)
            seen["sec"].add(rel.secondary_hedge)
            seen["vert"].add(rel.vertical)
    assert seen["kind"] == set(batch.KINDS)
    assert seen["hedge"] == {*batch.HEDGES, None}
    assert seen["sec"] == {*batch.SECONDARY_HEDGES, None}
    assert {"on top of", "under", "above", "below"} <= seen["vert"]


@pytest.mark.parametrize("directions", [8, 36, 360])
def test_relate_objects_on_other_directions_and_thresholds(directions: int) -> None:
    # Thresholds far from the defaults: a smoothing window wider than the histogram, and
    # hedges that fire often (8 bins: no smoothing at all).
    t = Thresholds(directly=0.7, plain=0.6, mostly=0.3, coverage_smooth_deg=200.0)
    for index in (0, 3, 7, 16, 19):
        hulls, names, heights = layout_scene(index)
        for thresholds in (None, t):
            got = language.relate_objects(
                hulls, names=names, heights=heights, directions=directions, thresholds=thresholds
            )
            try:
                expected = reference(hulls, names, heights, directions, thresholds)
            except InputError:
                # At 8 directions no line meets some small pairs: pair_histograms refuses
                # them, relate_objects (as before issue 16) keeps their all-zero histograms.
                assert directions == 8
                assert any(not hist.f0.any() for _, hist in got)
                continue
            assert_same(got, expected)


def test_labels_with_percent_signs_and_braces_are_said_as_given() -> None:
    """The sentences are filled through ``%`` patterns (``relate._printf``): labels that hold
    ``%s``, ``%`` or braces are said as given, as ``str.format`` says them, and a pattern
    that names the referent twice ("but extends ... relative to the {referent}") is filled
    twice."""
    index = next(
        k
        for k in range(len(LAYOUTS))
        if any(
            rel.secondary_hedge == "extends"
            for rel, _ in language.relate_objects(
                layout_scene(k)[0], names=layout_scene(k)[1], heights=layout_scene(k)[2]
            )
        )
    )
    hulls, _, heights = layout_scene(index)
    names = [f"thing %s {{0}} {k}%" for k in range(len(hulls))]
    got = language.relate_objects(hulls, names=names, heights=heights)
    assert_same(got, reference(hulls, names, heights))
    extends = [rel for rel, _ in got if rel.secondary_hedge == "extends"]
    assert extends and all(rel.horizontal_sentence.count(rel.referent) == 2 for rel in extends)
    assert relate_module._printf("The {referent} is under the {argument}.") is None


def test_results_are_ordinary_relations() -> None:
    """The relations and histograms made by the mutable twins (``__class__`` assignment)
    behave like ``Relation(...)`` and ``PairHistograms(...)``: their type, slots, equality,
    pickling, copying, ``replace`` and frozenness."""
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    (rel, hist), _ = language.relate_objects([sq, sq + np.array([3.0, 0.2])], names=["hat", "mug"])
    assert type(rel) is language.Relation and type(hist) is language.PairHistograms
    fields = [f.name for f in dataclasses.fields(language.Relation)]
    assert list(language.Relation.__slots__) == fields
    assert not hasattr(rel, "__dict__") and not hasattr(hist, "__dict__")
    made = language.Relation(**{f: getattr(rel, f) for f in fields})
    assert rel == made and made == rel and repr(rel) == repr(made)
    assert rel != dataclasses.replace(made, confidence=rel.confidence + 1.0)
    for twin in (pickle.loads(pickle.dumps(rel)), copy.copy(rel), copy.deepcopy(rel)):
        assert type(twin) is language.Relation and twin == rel
        assert twin.to_dict() == rel.to_dict()
    assert dataclasses.replace(rel, argument="cap").argument == "cap"
    with pytest.raises(dataclasses.FrozenInstanceError):
        rel.argument = "cap"  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        hist.hybrid = True  # type: ignore[misc]
    back = pickle.loads(pickle.dumps(hist))
    assert type(back) is language.PairHistograms and back.hybrid == hist.hybrid
    assert back.f0.tobytes() == hist.f0.tobytes() and back.area_b == hist.area_b
    assert [f.name for f in dataclasses.fields(hist)] == list(language.PairHistograms.__slots__)
    assert rel.to_dict()["sentence"] == rel.sentence


def _generic_to_dict(rel: language.Relation) -> dict[str, object]:
    """``Relation.to_dict`` as it was written before it went field by field: one loop over
    the fields (the reference)."""
    out: dict[str, object] = {}
    for f in dataclasses.fields(rel):
        value = getattr(rel, f.name)
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


def test_to_dict_is_the_generic_loop() -> None:
    """The same keys in the same order, the same values of the same types, and new dicts,
    for the relations of a scene and for fields of other types (NumPy floats, ints, a dict
    subclass)."""
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    got = language.relate_objects([sq, sq + np.array([3.0, 0.2]), sq + 0.5], names=list("abc"))
    odd = language.Relation(
        "a", "b", "left", None, "mostly", "s", np.float64(0.5), coverage=1, hybrid=True,
        degrees=collections.OrderedDict(left=np.float64(0.25), right=1),
        deviation0={"left": 1.0}, deviation=np.float64(0.125), overlap=np.float64(0.5),
    )  # fmt: skip
    for rel in [rel for rel, _ in got] + [odd]:
        want, have = _generic_to_dict(rel), rel.to_dict()
        assert list(have) == list(want) and have == want
        assert [type(v) for v in have.values()] == [type(v) for v in want.values()]
        for key, value in have.items():
            if isinstance(value, dict):
                assert value is not getattr(rel, key, None)
                assert [type(v) for v in value.values()] == [
                    type(v)
                    for v in want[key].values()  # type: ignore[attr-defined]
                ]


@pytest.mark.parametrize("enabled", [True, False])
def test_the_collector_is_restored(enabled: bool) -> None:
    was = gc.isenabled()
    try:
        (gc.enable if enabled else gc.disable)()
        sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
        found = language.relate_objects([sq, sq + 3, sq - 3], names=["a", "b", "c"])
        assert gc.isenabled() is enabled
        assert len(list(found)) == 6  # the results made on the first read: restored too
        assert gc.isenabled() is enabled
        with pytest.raises(RuntimeError), relate_module._collector_paused():
            raise RuntimeError
        assert gc.isenabled() is enabled
    finally:
        (gc.enable if was else gc.disable)()


def test_the_results_behave_as_the_list() -> None:
    """``relate_objects`` returns a sequence made on first read that behaves as the list of
    its pairs: items, slices, iteration, comparison, ``in``, ``+``, ``*``, ``repr``, pickling
    and copying, unhashable; ``len`` makes nothing; the objects are made once."""
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    hulls, names = [sq, sq + np.array([3.0, 0.2]), sq + np.array([0.5, 2.0])], list("abc")
    found = language.relate_objects(hulls, names=names)
    assert isinstance(found, language.RelatedPairs)
    assert len(found) == 6 and found._items is None  # nothing made yet
    as_list = reference(hulls, names, None)
    assert_same(list(found), as_list)
    same = found._items
    assert same is not None and list(found) == same and found[0] is same[0]
    assert found[-1] is same[-1] and found[1:4] == same[1:4] and found[::-1] == same[::-1]
    assert list(reversed(found)) == same[::-1]
    assert found == same and same == found and not (found != same)
    assert found == language.RelatedPairs(lambda: list(same), 6)  # the same items
    assert found != language.relate_objects(hulls[:2], names=names[:2]) and found != same[:5]
    assert same[2] in found and found.index(same[2]) == 2 and found.count(same[2]) == 1
    assert (found + same[:1])[-1] is same[0] and (same[:1] + found)[1] is same[0]
    assert found * 2 == same * 2 and 2 * found == same * 2
    assert repr(found) == repr(same) and bool(found)
    assert type(copy.copy(found)) is list and copy.copy(found) == same
    for copied in (pickle.loads(pickle.dumps(found)), copy.deepcopy(found)):
        assert type(copied) is list and [rel for rel, _ in copied] == [rel for rel, _ in same]
        assert [h.f2.tobytes() for _, h in copied] == [h.f2.tobytes() for _, h in same]
    with pytest.raises(TypeError, match="unhashable"):
        hash(found)
    with pytest.raises(IndexError):
        found[6]
    empty = language.relate_objects([sq], names=["a"])
    assert len(empty) == 0 and list(empty) == [] and empty == [] and not empty


def test_the_results_are_made_once_for_every_reader() -> None:
    """Several threads reading a fresh result first get the same objects; the maker runs
    once (the collector paused while it runs) and is then dropped."""
    import threading

    calls = []

    def make() -> list:
        calls.append(gc.isenabled())
        return [(object(), k) for k in range(50)]  # type: ignore[misc]

    lazy = language.RelatedPairs(make, 50)  # type: ignore[arg-type]
    seen: list[object] = []
    threads = [threading.Thread(target=lambda: seen.append(lazy[7])) for _ in range(8)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert calls == [False] and lazy._make is None
    assert len(seen) == 8 and all(item is seen[0] for item in seen)


# -- the pieces against the functions they replace ---------------------------------------------


def _sparse_histograms(rng: np.random.Generator, rows: int, nbins: int) -> np.ndarray:
    h = rng.exponential(size=(rows, nbins)) * 10.0 ** rng.integers(-6, 6, size=(rows, 1))
    h[rng.random(h.shape) < rng.random()] = 0.0
    for r in range(rows):  # some rows only an arc, as objects apart give
        if rng.random() < 0.5:
            start, width = int(rng.integers(nbins)), int(rng.integers(1, nbins // 2 + 1))
            keep = (np.arange(nbins) - start) % nbins < width
            h[r, ~keep] = 0.0
    return h


@settings(max_examples=40, deadline=None)
@given(seeds, st.sampled_from([8, 12, 36, 180, 256, 360, 512, 520]))
def test_four_direction_degrees_match_four_degrees(seed: int, nbins: int) -> None:
    rng = np.random.default_rng(seed)
    h = _sparse_histograms(rng, int(rng.integers(1, 40)), nbins)
    degree, deviation = four_direction_degrees(h)
    for r in range(len(h)):
        ref = four_degrees(h[r])
        assert degree[r].tolist() == [ref[d].degree for d in DIRECTIONS]
        assert deviation[r].tolist() == [ref[d].deviation for d in DIRECTIONS]
    # Rows of a bigger array (as f0_f2_pairs' views of the sweep): the same floats.
    strided = np.stack([h, h[::-1]], axis=1)[:, 0]
    assert not strided.flags.c_contiguous or len(h) == 1
    again = four_direction_degrees(strided)
    assert again[0].tobytes() == degree.tobytes() and again[1].tobytes() == deviation.tobytes()


@settings(max_examples=40, deadline=None)
@given(seeds, st.sampled_from([8, 36, 180, 360]))
def test_coverages_and_sector_shares_match_the_rules(seed: int, nbins: int) -> None:
    rng = np.random.default_rng(seed)
    h = _sparse_histograms(rng, int(rng.integers(1, 30)), nbins)
    h[0] = 0.0  # an all-zero row
    if len(h) > 1:  # plateaus: smoothed bins exactly at the coverage level
        h[1] = np.where(np.arange(nbins) % 3 == 0, 1.0, 0.1)
    for t in (DEFAULT_THRESHOLDS, Thresholds(coverage_smooth_deg=0.0, coverage_level=0.1)):
        got = batch.coverages(h, t)
        assert got.tolist() == [rules._coverage(row, t) for row in h]
    shares = batch.sector_shares(h)
    for r in range(len(h)):
        assert shares[r].tolist() == [rules._sector_share(h[r], d) for d in DIRECTIONS]


@settings(max_examples=40, deadline=None)
@given(seeds, st.sampled_from([8, 36, 180, 360]))
def test_compiled_coverages_match_the_rules(seed: int, nbins: int) -> None:
    """The compiled window counts (used where Numba is loaded) give the reference's
    coverages, plateaus at the level and rows the guard sends to the reference included."""
    from scenespeak.spatial.forces import _jit

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SCENESPEAK_NUMBA", "always")
        if not _jit.available() or _jit._numba() is None:
            pytest.skip("Numba is not installed")
        assert batch._compiled_counts() is not None
        rng = np.random.default_rng(seed)
        h = _sparse_histograms(rng, int(rng.integers(1, 30)), nbins)
        h[0] = 0.0
        if len(h) > 1:
            h[1] = np.where(np.arange(nbins) % 3 == 0, 1.0, 0.1)
        if len(h) > 2:
            h[2] = 1.0  # every window equal: all covered
        for t in (DEFAULT_THRESHOLDS, Thresholds(coverage_smooth_deg=30.0, coverage_level=0.5)):
            got = batch.coverages(h, t)
            assert got.tolist() == [rules._coverage(row, t) for row in h]
        mp.setenv("SCENESPEAK_NUMBA", "never")
        assert batch._compiled_counts() is None


@settings(max_examples=40, deadline=None)
@given(seeds, st.sampled_from([8, 12, 36, 180, 360, 512]))
def test_compiled_cancellation_is_bit_identical(seed: int, nbins: int) -> None:
    """The compiled cancellation (used where Numba is loaded) gives the NumPy path's floats,
    bit for bit: the cancelled masses, the favourable forces left, and so the degrees."""
    from scenespeak.spatial import degrees as deg
    from scenespeak.spatial.forces import _jit

    rng = np.random.default_rng(seed)
    h = _sparse_histograms(rng, int(rng.integers(1, 40)), nbins)
    n = nbins // 4
    fav = rng.choice([0.0, 0.5, 1.0], size=(2 * len(h), n)) * rng.uniform(0, 2, (2 * len(h), n))
    moment = rng.choice([0.0, -1.0, 1.0, 3.0], size=2 * len(h)) * rng.uniform(0, n, 2 * len(h))
    moment[0] = float(np.cumsum(fav[0] * deg._constants(nbins).dist)[n // 2])  # an exact bin
    dist = deg._constants(nbins).dist
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SCENESPEAK_NUMBA", "never")
        assert deg._compiled_cancel() is None
        want_fav = fav.copy()
        want = deg._cancelled(want_fav, moment, dist)
        want_deg = deg.four_direction_degrees(h)
        mp.setenv("SCENESPEAK_NUMBA", "always")
        if not _jit.available() or _jit._numba() is None:
            pytest.skip("Numba is not installed")
        assert deg._compiled_cancel() is not None
        got_fav = fav.copy()
        got = deg._cancelled(got_fav, moment, dist)
        got_deg = deg.four_direction_degrees(h)
    assert got.tobytes() == want.tobytes() and got_fav.tobytes() == want_fav.tobytes()
    assert all(a.tobytes() == b.tobytes() for a, b in zip(got_deg, want_deg, strict=True))


# Degrees drawn from the thresholds themselves and their neighbours, so that every comparison
# of the rule base meets equality and ties.
_EDGES = sorted(
    {0.0, 1.0, 0.5}
    | {v for f in dataclasses.fields(Thresholds) for v in [getattr(DEFAULT_THRESHOLDS, f.name)]}
    | {0.93 - 1e-12, 0.35 + 0.15, 0.2, 0.475, 0.45}
)
_EDGES = [v for v in _EDGES if 0.0 <= v <= 1.0]


@settings(max_examples=60, deadline=None)
@given(seeds)
def test_decide_pairs_matches_decide_on_edge_values(seed: int) -> None:
    rng = np.random.default_rng(seed)
    rows = 64
    a0 = rng.choice(_EDGES, size=(rows, 4))
    a2 = np.where(rng.random((rows, 4)) < 0.5, a0, rng.choice(_EDGES, size=(rows, 4)))
    dev2 = rng.choice([0.0, 0.1, -0.1, np.radians(15.0), -np.radians(15.0), 0.3], size=(rows, 4))
    dev0 = rng.normal(size=(rows, 4))
    shares = rng.choice([0.0, 0.1, 0.2, 0.3, 0.4, 0.5], size=(rows, 4))
    coverage = rng.choice([0.0, 0.4, 0.5, 0.9, 0.95, 1.0], size=rows)
    overlap = rng.choice([0.0, 0.0, 0.2, 0.5, 1.0], size=rows)
    referent_overlap = np.where(rng.random(rows) < 0.5, overlap, rng.choice([0.0, 0.3, 1.0], rows))
    got = batch.decide_pairs(
        (a0, a2), dev2, shares, (overlap, referent_overlap), coverage, DEFAULT_THRESHOLDS
    )
    for r in range(rows):
        deg0 = {
            d: DirectionDegree(a0[r, k], dev0[r, k], 1.0, 0.0) for k, d in enumerate(DIRECTIONS)
        }
        deg2 = {
            d: DirectionDegree(a2[r, k], dev2[r, k], 1.0, 0.0) for k, d in enumerate(DIRECTIONS)
        }
        f0 = np.zeros(180)  # the shares are read from ``shares``: see below
        expected = _decide_with_shares(
            deg0, deg2, f0, shares[r], coverage[r], overlap[r], referent_overlap[r]
        )
        words = (
            batch.KINDS[got.kind[r]],
            "surrounded" if got.primary[r] == 4 else DIRECTIONS[got.primary[r]],
            None if got.secondary[r] < 0 else DIRECTIONS[got.secondary[r]],
            None if got.hedge[r] < 0 else batch.HEDGES[got.hedge[r]],
            None if got.secondary_hedge[r] < 0 else batch.SECONDARY_HEDGES[got.secondary_hedge[r]],
        )
        assert words == (
            expected.kind,
            expected.primary,
            expected.secondary,
            expected.hedge,
            expected.secondary_hedge,
        )
        numbers = (got.confidence[r], got.deviation[r], got.coverage[r], got.extends_share[r])
        assert numbers == (
            expected.confidence,
            expected.deviation,
            expected.coverage,
            expected.extends_share,
        )


def _decide_with_shares(  # type: ignore[no-untyped-def]
    deg0, deg2, f0, shares, coverage, overlap, referent_overlap
):
    """``rules._decide`` with the sector shares given (instead of computed from ``f0``)."""
    table = dict(zip(DIRECTIONS, shares.tolist(), strict=True))
    original = rules._sector_share
    rules._sector_share = lambda _f0, direction: table[direction]  # type: ignore[assignment]
    try:
        return rules._decide(
            deg0,
            deg2,
            f0,
            DEFAULT_THRESHOLDS,
            float(overlap),
            float(referent_overlap),
            float(coverage),
        )
    finally:
        rules._sector_share = original  # type: ignore[assignment]


def test_scene_histogram_checks_match_as_histograms() -> None:
    from scenespeak.spatial.language import scenepairs

    rng = np.random.default_rng(5)
    f0, f2 = rng.exponential(size=(2, 6, 36))
    same = scenepairs._checked(f0, f2)
    np.testing.assert_array_equal(same[0], f0)
    np.testing.assert_array_equal(same[1], f2)
    f2[3, 4] = -1e-14  # rounding below 0: clipped, as _as_histogram does
    got = scenepairs._checked(f0, f2)
    np.testing.assert_array_equal(got[1][3], rules._as_histogram(f2[3], "f2"))
    assert got[1][3, 4] == 0.0 and got[1].min() >= 0.0
    for bad, problem in ((-1.0, "negative"), (np.nan, "non-finite")):
        f2[3, 4] = bad
        with pytest.raises(InputError, match=problem) as err:
            scenepairs._checked(f0, f2)
        assert err.value.source == "f2"
