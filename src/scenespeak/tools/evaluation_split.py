"""Leave-part-out evaluation: learn only some of a dataset's objects, so the others become
distractors (part of :mod:`scenespeak.tools.evaluation`).

A set's own distractors are few and always the same three; a database that learns only part of
the objects turns every other object of every scene into a distractor that *looks like* a
learnt one would (same shapes, sizes and kinds of texture), which is the hard case for "no known
object reported where it is not". :func:`choose_learnt` picks the labels (an explicit list, or a
seeded random part of them and its complement), :func:`with_unlearnt` marks the others as
distractors in a scene's truth, and :func:`false_known_kinds` says *where* each false known
object was put:

- ``unlearnt`` — on an object that is not in the database (a split's or the set's distractor):
  a wrong name on an unknown object;
- ``duplicate`` — on a true instance of its own label that another described object already
  matched: one object reported twice;
- ``neighbour`` — on a learnt object of another label: a name on a neighbour's segment;
- ``background`` — within :data:`~scenespeak.tools.evaluation_match.MATCH_GATE_M` of no true
  object: a name on the floor, the wall or nothing.

Examples
--------
>>> choose_learnt(["cup", "jar", "mug", "tea"], fraction=0.5, seed=1)
('cup', 'jar')
>>> choose_learnt(["cup", "jar", "mug", "tea"], fraction=0.5, seed=1, other=True)
('mug', 'tea')
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenespeak.errors import InputError
from scenespeak.tools.evaluation_match import MATCH_GATE_M, is_known, unmatched

__all__ = ["FALSE_KNOWN_KINDS", "LearnSplit", "choose_learnt", "false_known_kinds", "with_unlearnt"]

#: Where a false known object can be put (see the module's docstring), in the order counted.
FALSE_KNOWN_KINDS = ("unlearnt", "duplicate", "neighbour", "background")


@dataclass(frozen=True)
class LearnSplit:
    """Which of a dataset's objects the database learns (``scenespeak evaluate --learn ...``).

    Attributes
    ----------
    learn : tuple of str
        An explicit list of labels to learn (then ``fraction`` must be None).
    fraction : float or None
        Learn this share of the labels (``round(fraction * n)``, at least 1, at most n - 1),
        drawn with ``seed``.
    seed : int
        Seed of the draw (``numpy.random.default_rng(seed).permutation`` of the sorted labels).
    other : bool
        Learn the complement instead: the labels the draw (or ``learn``) leaves out.
    """

    learn: tuple[str, ...] = ()
    fraction: float | None = None
    seed: int = 0
    other: bool = False

    def __post_init__(self) -> None:
        if self.fraction is not None and self.learn:
            raise InputError("--learn", "give a list of labels or a fraction, not both")
        if self.fraction is not None and not 0.0 < self.fraction < 1.0:
            raise InputError("--learn-only", f"must be between 0 and 1, got {self.fraction}")
        if self.other and not (self.learn or self.fraction is not None):
            raise InputError("--other-part", "needs --learn or --learn-only")

    @property
    def active(self) -> bool:
        """Whether the database learns only part of the objects."""
        return bool(self.learn) or self.fraction is not None

    def labels(self, available: Sequence[str]) -> tuple[str, ...]:
        """The labels to learn out of ``available`` (all of them when not :attr:`active`)."""
        if not self.active:
            return tuple(sorted(available))
        return choose_learnt(
            available,
            learn=self.learn or None,
            fraction=self.fraction,
            seed=self.seed,
            other=self.other,
        )

    def to_dict(self) -> dict[str, Any]:
        """The split as ``evaluate --json`` reports it (``split``)."""
        return {
            "learn": list(self.learn),
            "fraction": self.fraction,
            "seed": self.seed,
            "other": self.other,
        }


def choose_learnt(
    labels: Sequence[str],
    *,
    learn: Collection[str] | None = None,
    fraction: float | None = None,
    seed: int = 0,
    other: bool = False,
) -> tuple[str, ...]:
    """The labels a leave-part-out database learns, sorted.

    Parameters
    ----------
    labels : sequence of str
        Every label the dataset can learn (its ``objects/`` folders).
    learn : collection of str, optional
        Learn exactly these (each must be in ``labels``).
    fraction : float, optional
        Otherwise learn ``round(fraction * len(labels))`` of them (at least 1 and at most all
        but one), the first of a permutation of the sorted labels drawn with ``seed``.
    seed : int
        The draw's seed.
    other : bool
        Return the complement (the other part).

    Raises
    ------
    InputError
        A label of ``learn`` that the dataset does not have, neither ``learn`` nor
        ``fraction``, or a part that would be empty.

    Examples
    --------
    >>> choose_learnt(["b", "a", "c"], learn=["c"], other=True)
    ('a', 'b')
    """
    pool = sorted(set(labels))
    if learn is not None:
        missing = sorted(set(learn) - set(pool))
        if missing:
            raise InputError(
                "--learn", f"the dataset has no object {', '.join(missing)} ({', '.join(pool)})"
            )
        part = set(learn)
    elif fraction is not None:
        if len(pool) < 2:
            raise InputError("--learn-only", f"needs at least 2 objects, the dataset has {pool}")
        k = min(max(round(fraction * len(pool)), 1), len(pool) - 1)
        order = np.random.default_rng(seed).permutation(len(pool))
        part = {pool[int(i)] for i in order[:k]}
    else:
        raise InputError("learnt labels", "give the labels to learn or a fraction of them")
    chosen = tuple(x for x in pool if (x in part) != other)
    if not chosen:
        raise InputError("--learn", "learns no object (every label left out)")
    return chosen


def with_unlearnt(truth: Any, learnt: Collection[str]) -> Any:
    """The scene's truth with every object whose label is not in ``learnt`` a distractor.

    Examples
    --------
    >>> from scenespeak.tools.evaluation import SceneTruth, TruthObject
    >>> t = SceneTruth("s", (TruthObject("mug", (0, 0, 1)), TruthObject("hat", (1, 0, 1))), ())
    >>> [o.distractor for o in with_unlearnt(t, {"mug"}).objects]
    [False, True]
    """
    objects = tuple(
        o if o.distractor or o.label in learnt else dataclasses.replace(o, distractor=True)
        for o in truth.objects
    )
    return dataclasses.replace(truth, objects=objects)


def false_known_kinds(
    pred: Any, truth: Any, matched: Mapping[str, str]
) -> tuple[tuple[str, str, str], ...]:
    """``(described name, kind, nearest true object or "")`` per false known object.

    ``kind`` is one of :data:`FALSE_KNOWN_KINDS`, decided by the nearest true object within
    :data:`~scenespeak.tools.evaluation_match.MATCH_GATE_M` of the described centroid.

    Examples
    --------
    >>> from scenespeak.tools.evaluation import PredictedScene, SceneTruth, TruthObject
    >>> t = SceneTruth("s", (TruthObject("mug", (0, 0, 1.0)),
    ...     TruthObject("hat", (0.5, 0, 1.0), distractor=True)), ())
    >>> p = PredictedScene("s", {"mug": (0, 0, 1.0), "mug 2": (0.02, 0, 1.0),
    ...     "cup": (0.48, 0, 1.0), "tea": (0, 0, 2.0)}, {}, labels={"mug 2": "mug"})
    >>> false_known_kinds(p, t, {"mug": "mug"})
    (('mug 2', 'duplicate', 'mug'), ('cup', 'unlearnt', 'hat'), ('tea', 'background', ''))
    """
    out = []
    for name in unmatched(pred, matched):
        label = pred.label_of(name)
        if not is_known(label):
            continue
        here = pred.objects[name]
        near = [(math.dist(here, o.centroid), o) for o in truth.objects]
        near = [(d, o) for d, o in near if d <= MATCH_GATE_M]
        if not near:
            out.append((name, "background", ""))
            continue
        _d, o = min(near, key=lambda dn: dn[0])
        kind = "unlearnt" if o.distractor else "duplicate" if o.label == label else "neighbour"
        out.append((name, kind, o.key))
    return tuple(out)
