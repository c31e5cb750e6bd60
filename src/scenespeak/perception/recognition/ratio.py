"""The ratio test (Lowe 2004, sec. 7.1) and the correspondences that pass it.

A query's nearest descriptor is accepted when it is nearer than ``ratio`` times the nearest
descriptor of *another object*: that one is a false match, and its distance estimates how
dense false matches are round the query. Two refinements (issue 10, session 10):

- **The stand-in.** When all ``k`` fetched neighbours belong to the nearest's object, the
  ``k``-th distance stands in (a lower bound). When those ``k`` come from ``k`` *different*
  views, they are the same surface point's copies (one per view: an object learnt from many
  views), not a crowd of the object's own look-alikes; only then is the query searched again
  ``deep_k`` deep, and the second neighbour is the nearest other object's, or the first
  descriptor from a view already seen (a different point of that view: a false match), or the
  deepest distance. Otherwise the ``k``-th distance stands in as before (a query of clutter in a
  database of few objects has all ``k`` neighbours on the largest object, several per view).
- **Synthesised views** (:mod:`~scenespeak.perception.recognition.cylinder_views`). A query's
  nearest *learnt* descriptor is tested against learnt descriptors only, over the first ``k``
  learnt neighbours: exactly the test without synthesised views, with the same candidates
  (enough neighbours are fetched that ``k`` are learnt where synthesised ones are as dense as
  overall; a query with fewer is searched again). A query that fails may then pass on its
  nearest *synthesised* descriptor, tested against every descriptor of another object,
  synthesised ones included. So one object's synthesised views never fail or change another
  object's matches, and its own synthesised matches meet all the competition.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.features import Features
from scenespeak.perception.recognition.options import LabelOptions

if TYPE_CHECKING:
    from scenespeak.perception.recognition.label import _Loaded

__all__ = ["Candidates", "ratio_candidates"]


@dataclass(frozen=True)
class Candidates:
    """The correspondences that passed the ratio test: query ``q_idx[i]`` ↔ training
    descriptor ``t_idx[i]`` in view ``view[i]``; ``first_obj`` is each query's object."""

    q_idx: NDArray[np.intp]
    t_idx: NDArray[np.int64]
    view: NDArray[np.int32]
    first_obj: NDArray[np.int32]
    passed: NDArray[np.bool_]
    nearest: NDArray[np.int64]  # per query: its nearest training descriptor (-1: none)
    #: per query: passed only on a synthesised descriptor (empty: no synthesised view)
    synthesised_only: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, bool))


@dataclass(frozen=True)
class _Test:
    """A block of queries' test: passed, object, squared limit, and undecided (to search
    deeper)."""

    passed: NDArray[np.bool_]
    first_obj: NDArray[np.int32]
    limit: NDArray[np.float32]
    undecided: NDArray[np.bool_]


def _first(mask: NDArray[np.bool_]) -> tuple[NDArray[np.bool_], NDArray[np.intp]]:
    """Per row: whether ``mask`` holds a True, and the column of the first one."""
    return np.asarray(mask.any(axis=1), bool), np.argmax(mask, axis=1).astype(np.intp)


def _objects(db: _Loaded, ids: NDArray[np.int64]) -> NDArray[np.int32]:
    return np.where(ids >= 0, db.object_of[np.maximum(ids, 0)], -1).astype(np.int32)


def _learnt_only(
    dist: NDArray[np.float32], ids: NDArray[np.int64], learnt: NDArray[np.bool_]
) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """The learnt neighbours of each row first (in distance order), the rest -1 / inf."""
    order = np.argsort(~learnt, axis=1, kind="stable")
    keep = np.take_along_axis(learnt, order, axis=1)
    d = np.where(keep, np.take_along_axis(dist, order, axis=1), np.inf).astype(np.float32)
    return d, np.where(keep, np.take_along_axis(ids, order, axis=1), -1)


def _repeats(views: NDArray[np.int32], mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Per row: whether two of the entries under ``mask`` lie in one view."""
    unique_off = -1 - np.arange(views.shape[1])[None, :]
    s = np.sort(np.where(mask, views, unique_off), axis=1)
    return np.asarray((s[:, 1:] == s[:, :-1]).any(axis=1), bool)


def _first_repeat(
    dist: NDArray[np.float32], views: NDArray[np.int32], same: NDArray[np.bool_]
) -> NDArray[np.float32]:
    """Per row: the distance of the first entry under ``same`` whose view an earlier one had
    (inf: none)."""
    out = np.full(len(dist), np.inf, np.float32)
    for r in range(len(dist)):
        seen: set[int] = set()
        for d, v in zip(dist[r][same[r]].tolist(), views[r][same[r]].tolist(), strict=True):
            if v in seen:
                out[r] = d
                break
            seen.add(v)
    return out


def _learnt_test(
    db: _Loaded, dist: NDArray[np.float32], ids: NDArray[np.int64], r2: float, k: int
) -> _Test:
    """The test on learnt neighbours only (``dist``, ``ids``: nearest first, -1 / inf when
    missing) over the first ``k`` of them, as without synthesised views: the nearest other
    object's among them, else the ``k``-th distance (inf when fewer were fetched). When the
    ``k`` are all of one object and in ``k`` different views, the lists wider than ``k``
    (the deeper search) give the nearest other object's or the first descriptor from a view
    already seen. Undecided (to search deeper): fewer than ``k`` learnt neighbours fetched
    (synthesised ones took their places), or such copies that fail."""
    rows = np.arange(len(dist))
    ok = ids >= 0
    obj = _objects(db, ids)
    obj1 = obj[:, 0]
    other = ok & (obj != obj1[:, None])
    head = min(k, ids.shape[1])
    has2, j2 = _first(other[:, :head])
    same = ok & (obj == obj1[:, None])
    views = db.view_of[np.maximum(ids, 0)]
    full = ok[:, head - 1] & (head == k)
    copies = full & ~has2 & ~_repeats(views[:, :head], same[:, :head])
    d2 = np.where(has2, dist[rows, j2], dist[:, head - 1])
    if ids.shape[1] > k:  # the deeper search, for one point's copies
        far, jf = _first(other)
        beyond = np.minimum(np.where(far, dist[rows, jf], np.inf), _first_repeat(dist, views, same))
        deepest = np.max(np.where(ok, dist, -np.inf), axis=1)
        d2 = np.where(copies, np.where(np.isfinite(beyond), beyond, deepest), d2)
    limit = (r2 * d2).astype(np.float32)
    passed = ok[:, 0] & (dist[:, 0] < limit)
    undecided = ok[:, 0] & (~full | (copies & ~passed)) & (ids.shape[1] <= k)
    return _Test(passed, obj1, limit, undecided)


def _synthesised_test(
    db: _Loaded,
    dist: NDArray[np.float32],
    ids: NDArray[np.int64],
    syn: NDArray[np.bool_],
    r2: float,
) -> _Test:
    """Each row's nearest synthesised neighbour against its nearest neighbour of another
    object, synthesised or learnt (none fetched: the deepest distance)."""
    rows = np.arange(len(dist))
    ok = ids >= 0
    obj = _objects(db, ids)
    has1, j1 = _first(syn)
    obj1 = np.where(has1, obj[rows, j1], -1).astype(np.int32)
    has2, j2 = _first(ok & (obj != obj1[:, None]))
    deepest = np.max(np.where(ok, dist, -np.inf), axis=1)
    limit = (r2 * np.where(has2, dist[rows, j2], deepest)).astype(np.float32)
    passed = has1 & (dist[rows, j1] < limit)
    return _Test(passed, obj1, limit, np.zeros(len(dist), bool))


def _candidates_of(
    db: _Loaded, t: _Test, dist: NDArray[np.float32], ids: NDArray[np.int64]
) -> tuple[NDArray[np.intp], NDArray[np.int64]]:
    """Per query that passed ``t``: its neighbours of its object within its limit, the
    nearest per view (query rows and training descriptors)."""
    cand = t.passed[:, None] & (_objects(db, ids) == t.first_obj[:, None]) & (ids >= 0)
    cand &= dist < t.limit[:, None]
    rows, cols = np.nonzero(cand)  # row-major: nearest first within each query
    t_all = ids[rows, cols]
    v_all = db.view_of[t_all].astype(np.int64)
    key = rows.astype(np.int64) * (int(db.view_of.max()) + 1) + v_all
    _, first = np.unique(key, return_index=True)
    return rows[first].astype(np.intp), t_all[first]


def ratio_candidates(db: _Loaded, features: Features, o: LabelOptions) -> Candidates:
    """The ratio test (module docstring) of every query, and the candidates.

    For a query that passed, every fetched neighbour of the same object that passes the ratio
    test too (its copies in the object's other views: the same surface point seen from another
    side or distance), the nearest per view. Each training view is then checked with all the
    queries that match into it, not only those whose single nearest neighbour lies in it.
    """
    syn = db.synthetic
    n_syn = int(syn.sum()) if syn is not None else 0
    n_learnt = db.index.ntotal - n_syn
    kk = max(2, min(o.k, n_learnt))
    # enough neighbours that k of them are learnt where synthesised ones are as dense as overall
    fetch = min(db.index.ntotal, math.ceil(kk * db.index.ntotal / max(n_learnt, 1)))
    r2 = o.ratio * o.ratio
    dist, ids = db.index.search(features.descriptors, fetch)
    is_syn = (ids >= 0) & (syn[np.maximum(ids, 0)] if syn is not None else False)
    ld, li = _learnt_only(dist, ids, (ids >= 0) & ~is_syn)
    t = _learnt_test(db, ld[:, :kk], li[:, :kk], r2, kk)
    decided = _Test(t.passed & ~t.undecided, t.first_obj, t.limit, t.undecided)
    q_idx, t_idx = _candidates_of(db, decided, ld[:, :kk], li[:, :kk])
    again = np.flatnonzero(t.undecided)
    deep = min(max(o.deep_k, fetch), db.index.ntotal)
    if deep > fetch and len(again):
        da, ia = db.index.search(features.descriptors[again], deep)
        learnt = ia >= 0
        if syn is not None:
            learnt &= ~syn[np.maximum(ia, 0)]
        da, ia = _learnt_only(da, ia, learnt)
        ta = _learnt_test(db, da, ia, r2, kk)
        t.passed[again], t.first_obj[again], t.limit[again] = ta.passed, ta.first_obj, ta.limit
        # candidates among the first k learnt neighbours, as above, and beyond them only for
        # one point's copies in more than k views (no view repeated among the first k)
        obj = _objects(db, ia[:, :kk])
        same = (ia[:, :kk] >= 0) & (obj == obj[:, :1])
        copies = ~_repeats(db.view_of[np.maximum(ia[:, :kk], 0)], same)
        ia = np.where(copies[:, None] | (np.arange(ia.shape[1]) < kk)[None, :], ia, -1)
        qa, tb = _candidates_of(db, ta, da, ia)
        q_idx = np.concatenate([q_idx, again[qa].astype(np.intp)])
        t_idx = np.concatenate([t_idx, tb])
    only = np.zeros(0, bool)
    if n_syn:  # the synthesised test, for the queries the learnt one failed
        s = _synthesised_test(db, dist, ids, is_syn, r2)
        s = _Test(s.passed & ~t.passed, s.first_obj, s.limit, s.undecided)
        only = s.passed.copy()
        qs, ts = _candidates_of(db, s, dist, ids)
        q_idx, t_idx = np.concatenate([q_idx, qs]), np.concatenate([t_idx, ts])
        t = _Test(
            t.passed | s.passed,
            np.where(s.passed, s.first_obj, t.first_obj).astype(np.int32),
            np.where(s.passed, s.limit, t.limit).astype(np.float32),
            t.undecided,
        )
    return Candidates(q_idx, t_idx, db.view_of[t_idx], t.first_obj, t.passed, ids[:, 0], only)
