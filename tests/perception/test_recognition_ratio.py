"""The ratio test's second neighbour (issue 10, session 10): the nearest descriptor of *another*
object, searched deeper when the first ``k`` are all of one object, and synthesised views
(``cylinder_views``) that never fail another object's learnt matches.

The databases here are hand-made descriptor sets (no images), so each case is exact: the
distances are chosen round the ratio 0.8 (squared 0.64).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from scenespeak.perception.features import Features
from scenespeak.perception.recognition.index import ExactIndex
from scenespeak.perception.recognition.label import _Loaded, _ratio_candidates
from scenespeak.perception.recognition.options import LabelOptions


def _loaded(
    desc: NDArray[np.uint8], objects: list[int], synthetic: list[bool] | None = None
) -> _Loaded:
    """One view per descriptor; ``objects[i]`` is descriptor i's object."""
    n = len(desc)
    square = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], np.float32)
    kwargs = {} if synthetic is None else {"synthetic": np.array(synthetic, bool)}
    return _Loaded(
        1,
        ExactIndex(desc),
        np.array(objects, np.int32),
        np.arange(n, dtype=np.int32),
        np.zeros((n, 2), np.float32),
        np.ones(n, np.float32),
        np.zeros(n, np.float32),
        {o: f"object {o}" for o in set(objects)},
        {v: square for v in range(n)},
        **kwargs,
    )


def _query(desc: NDArray[np.uint8]) -> Features:
    n = len(desc)
    return Features(
        np.zeros((n, 2)),
        np.ones(n, np.float32),
        np.zeros(n, np.float32),
        np.ones(n, np.float32),
        np.zeros(n, np.int32),
        np.asarray(desc, np.uint8),
    )


def _at(base: NDArray[np.int64], column: int, step: int) -> NDArray[np.uint8]:
    """``base`` moved by ``step`` along one column (squared distance ``step²``)."""
    out = base.copy()
    out[column] += step
    return out.astype(np.uint8)


BASE = np.full(128, 100, np.int64)


def _copies(count: int, step: int) -> list[NDArray[np.uint8]]:
    """``count`` descriptors all ``step`` from BASE (each along its own column): the same
    surface point in many views, none nearer the query than the others."""
    return [_at(BASE, c, step) for c in range(count)]


@pytest.mark.parametrize(("other", "passes"), [(60, True), (21, False)])
def test_an_object_seen_in_many_views_passes_when_no_other_object_is_near(
    other: int, passes: bool
) -> None:
    # 20 views of one object hold the query's point at distance 20 (squared 400), another
    # object lies at ``other``. The 16th neighbour is one of the copies (400), so against it
    # the test fails (400 < 0.64 * 400 is false); the true second neighbour, another
    # object at 60 (3600), passes it, and one at 21 (441) fails it.
    desc = np.array([*_copies(20, 20), _at(BASE, 127, other)], np.uint8)
    db = _loaded(desc, [0] * 20 + [1])
    c = _ratio_candidates(db, _query(BASE[None].astype(np.uint8)), LabelOptions())
    assert bool(c.passed[0]) is passes
    if passes:
        assert int(c.first_obj[0]) == 0
        assert len(c.q_idx) == 20  # a candidate in each of the object's views


def test_without_the_deeper_search_the_kth_distance_stands_in() -> None:
    desc = np.array([*_copies(20, 20), _at(BASE, 127, 60)], np.uint8)
    db = _loaded(desc, [0] * 20 + [1])
    c = _ratio_candidates(db, _query(BASE[None].astype(np.uint8)), LabelOptions(deep_k=0))
    assert not bool(c.passed[0])


def test_another_objects_synthesised_view_does_not_fail_a_learnt_match() -> None:
    # Object 0's learnt descriptor at 20 (400); object 1's synthesised one at 22 (484) and its
    # learnt one at 40 (1600). Learnt against learnt: 400 < 0.64 * 1600 passes; had the
    # synthesised one been the second neighbour, 400 < 0.64 * 484 would fail.
    desc = np.array([_at(BASE, 0, 20), _at(BASE, 1, 22), _at(BASE, 2, 40)], np.uint8)
    q = _query(BASE[None].astype(np.uint8))
    db = _loaded(desc, [0, 1, 1], synthetic=[False, True, False])
    c = _ratio_candidates(db, q, LabelOptions())
    assert bool(c.passed[0]) and int(c.first_obj[0]) == 0
    # The same descriptors all learnt: the near one is a competitor.
    plain = _loaded(desc, [0, 1, 1], synthetic=[False, False, False])
    assert not bool(_ratio_candidates(plain, q, LabelOptions()).passed[0])


@pytest.mark.parametrize(("learnt", "passes"), [(40, True), (22, False)])
def test_a_synthesised_match_meets_every_other_object(learnt: int, passes: bool) -> None:
    # Object 1's synthesised descriptor is the nearest, at 20 (400); object 0's learnt one at
    # ``learnt``, object 2's just beyond it: the learnt test fails (two objects alike). The
    # synthesised match decides, against every other object: 400 < 0.64 * 1600 passes for
    # object 1, 400 < 0.64 * 484 does not.
    desc = np.array([_at(BASE, 0, 20), _at(BASE, 1, learnt), _at(BASE, 2, learnt + 1)], np.uint8)
    db = _loaded(desc, [1, 0, 2], synthetic=[True, False, False])
    c = _ratio_candidates(db, _query(BASE[None].astype(np.uint8)), LabelOptions())
    assert bool(c.passed[0]) is passes
    if passes:
        assert int(c.first_obj[0]) == 1


def test_the_inverted_files_cells_are_learnt_from_the_learnt_descriptors_alone() -> None:
    # Synthesised views added to a database do not move the cells the learnt descriptors fall
    # into (loading.index_of passes the learnt ones as ``train``): the same quantiser as
    # without them, so the same approximate neighbours are missed.
    from scenespeak.perception.recognition.ivf import IVFIndex

    rng = np.random.default_rng(3)
    learnt = rng.integers(0, 255, (3000, 128), dtype=np.uint8)
    synthesised = rng.integers(0, 120, (1500, 128), dtype=np.uint8)
    both = np.concatenate([learnt, synthesised])
    alone = IVFIndex(learnt, nlist=16)
    pooled = IVFIndex.from_chunks(
        lambda: iter([both]), len(both), nlist=16, train=(lambda: iter([learnt]), len(learnt))
    )
    untrained = IVFIndex(both, nlist=16)
    assert np.array_equal(pooled.centroids, alone.centroids)
    assert not np.array_equal(untrained.centroids, alone.centroids)
    assert pooled.ntotal == len(both)


def test_a_match_on_a_synthesised_view_verifies_but_is_no_vote() -> None:
    # Query 0 passes on object 1's synthesised descriptor only (as above); query 1 on object
    # 0's learnt one. Both are matches for the geometric check; only query 1's is a keypoint
    # vote for the unknown-object cues, whose thresholds were measured on learnt views' votes
    # (a short grey lead corroborated by votes named a never-learnt jar "soup" with them).
    from scenespeak.perception.recognition.label import label_features

    desc = np.array(
        [_at(BASE, 0, 20), _at(BASE, 1, 40), _at(BASE, 2, 41), _at(BASE, 3, 90)], np.uint8
    )
    db = _loaded(desc, [1, 0, 2, 0], synthetic=[True, False, False, False])
    far = _at(BASE, 3, 80)
    q = _query(np.array([BASE.astype(np.uint8), far], np.uint8))
    c = _ratio_candidates(db, q, LabelOptions())
    assert c.passed.tolist() == [True, True]
    assert c.synthesised_only.tolist() == [True, False]
    lab = label_features(db, q, LabelOptions())
    assert lab.matched.tolist() == [1, 0]
    assert lab.votes().tolist() == [-1, 0]
