"""A short paragraph about a scene, without all n(n−1) pairwise sentences."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from scenespeak.spatial.language.relation import Relation

__all__ = ["summarize_scene"]


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
    >>> from scenespeak.spatial.language import relate
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
