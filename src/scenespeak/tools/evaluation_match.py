"""Matching described objects to the ground truth's, instance by instance (private helpers of
:mod:`scenespeak.tools.evaluation`).

Several instances of one label and distractors (objects never learnt) make "the mug" of the
description ambiguous: :func:`match_objects` pairs described and true objects per label by least
total centroid distance, within :data:`MATCH_GATE_M`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = [
    "MATCH_GATE_M",
    "is_known",
    "match_objects",
    "object_detail",
    "tally_relations",
    "translate_relations",
    "unmatched",
]

#: A described object farther than this (metres) from every true instance of its label is
#: reported where it is not: a false object (and the true one, if any, is missed).
MATCH_GATE_M = 0.25


def is_known(label: str) -> bool:
    """Whether a described label names a learnt object (not "unknown object N")."""
    return not label.startswith("unknown")


def match_objects(pred: Any, truth: Any) -> dict[str, str]:
    """Described object name -> true object name: per label, the assignment of least total
    centroid distance (Hungarian) among pairs at most :data:`MATCH_GATE_M` apart.

    Examples
    --------
    >>> from scenespeak.tools.evaluation import PredictedScene, SceneTruth, TruthObject
    >>> t = SceneTruth("s", (TruthObject("mug", (0, 0, 1.0)), TruthObject("mug", (0.5, 0, 1.0),
    ...     name="mug 2")), ())
    >>> p = PredictedScene("s", {"a": (0.48, 0, 1.0), "b": (0.02, 0, 1.0)}, {},
    ...     labels={"a": "mug", "b": "mug"})
    >>> match_objects(p, t)
    {'b': 'mug', 'a': 'mug 2'}
    """
    from scipy.optimize import linear_sum_assignment

    out: dict[str, str] = {}
    known = [o for o in truth.objects if not o.distractor]
    for label in sorted({o.label for o in known}):
        tru = [o for o in known if o.label == label]
        prd = [n for n in pred.objects if pred.label_of(n) == label]
        if not prd:
            continue
        cost = np.array([[math.dist(pred.objects[n], t.centroid) for t in tru] for n in prd])
        rows, cols = linear_sum_assignment(np.where(cost <= MATCH_GATE_M, cost, 1e6))
        for r, c in zip(rows, cols, strict=True):
            if cost[r, c] <= MATCH_GATE_M:
                out[prd[r]] = tru[c].key
    return dict(sorted(out.items(), key=lambda kv: [t.key for t in known].index(kv[1])))


def object_detail(
    pred: Any, known: Sequence[Any], to_pred: Mapping[str, str]
) -> tuple[tuple[str, float, bool, float], ...]:
    """(label, distance, found, centroid error or NaN) per true learnt object."""
    out = []
    for o in known:
        p = to_pred.get(o.key)
        err = float("nan") if p is None else float(math.dist(pred.objects[p], o.centroid))
        out.append((o.label, round(o.metres, 4), p is not None, err))
    return tuple(out)


def translate_relations(pred: Any, matched: Mapping[str, str]) -> dict[tuple[str, str], str]:
    """The described relations between matched objects, keyed by the true names."""
    return {
        (matched[a], matched[b]): prim
        for (a, b), prim in pred.relations.items()
        if a in matched and b in matched
    }


def tally_relations(
    said: Mapping[tuple[str, str], str], relations: Sequence[Any]
) -> tuple[list[int], list[int], int]:
    """([right, described] clear, [right, described] ambiguous, "surrounded" said of apart
    footprints) over the true relations that were described."""
    clear = [0, 0]
    ambiguous = [0, 0]
    apart = 0
    for rel in relations:
        key = (rel.argument, rel.referent)
        if key not in said:
            continue
        apart += int(said[key] == "surrounded" and not rel.overlap)
        tally = ambiguous if rel.ambiguous else clear
        tally[1] += 1
        tally[0] += int(said[key] == rel.primary)
    return clear, ambiguous, apart


def unmatched(pred: Any, matched: Mapping[str, str]) -> list[str]:
    """Described objects that match no true object."""
    return [n for n in pred.objects if n not in matched]
