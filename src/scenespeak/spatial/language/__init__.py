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

Directions follow ``docs/interfaces.md``: angle 0 = right, 90° = behind (farther from the camera),
180° = left, 270° = in front (nearer the camera).

>>> import numpy as np
>>> h = np.zeros(180); h[75] = 1.0               # all force at 150°: left, tilted behind
>>> describe_relation(h, h, argument="hat", referent="mug").sentence
'The hat is mostly to the left of the mug but somewhat behind.'

The package's modules, one concern each:

- :mod:`~.thresholds` — :class:`Thresholds`, every value of the rule base with its source;
- :mod:`~.words` — the sentence patterns and phrases, and how a decision is rendered;
- :mod:`~.relation` — :class:`Relation`, the result;
- :mod:`~.rules` — histograms → a decision (:func:`describe_relation`);
- :mod:`~.vertical` — :func:`vertical_relation` from the points' heights;
- :mod:`~.pairs` — polygons → :class:`PairHistograms` → both relations of a pair;
- :mod:`~.scenepairs` — every pair of a scene's polygons: overlaps and histograms, as arrays;
- :mod:`~.batch` — the rule base on arrays of pairs (what :mod:`~.rules` does for one pair);
- :mod:`~.relate` — :func:`relate` (one pair) and :func:`relate_objects` (every pair, as a
  :class:`~.related.RelatedPairs`: made on first read);
- :mod:`~.viewer` — :func:`describe_viewer_relation` (the camera as the referent);
- :mod:`~.summary` — :func:`summarize_scene`;
- :mod:`~.table` — the README's layout table (``python -m scenespeak.spatial.language --table``).
"""

from __future__ import annotations

from scenespeak.spatial.degrees import DIRECTIONS
from scenespeak.spatial.language.pairs import (
    PairHistograms,
    pair_histograms,
    relation_of_pair,
    relations_of_pair,
)
from scenespeak.spatial.language.relate import relate, relate_objects
from scenespeak.spatial.language.related import RelatedPairs
from scenespeak.spatial.language.relation import Relation
from scenespeak.spatial.language.rules import RelationFacts, describe_relation
from scenespeak.spatial.language.summary import summarize_scene
from scenespeak.spatial.language.table import layout_table, main, update_doc_table
from scenespeak.spatial.language.thresholds import DEFAULT_THRESHOLDS, Thresholds
from scenespeak.spatial.language.vertical import vertical_relation
from scenespeak.spatial.language.viewer import describe_viewer_relation
from scenespeak.spatial.language.words import (
    COMPOUND_WORDS,
    OBJECT_PATTERNS,
    VERTICAL_WORDS,
    VIEWER_PATTERNS,
)

__all__ = [
    "COMPOUND_WORDS",
    "DEFAULT_THRESHOLDS",
    "DIRECTIONS",
    "OBJECT_PATTERNS",
    "VERTICAL_WORDS",
    "VIEWER_PATTERNS",
    "PairHistograms",
    "RelatedPairs",
    "Relation",
    "RelationFacts",
    "Thresholds",
    "describe_relation",
    "describe_viewer_relation",
    "layout_table",
    "main",
    "pair_histograms",
    "relate",
    "relate_objects",
    "relation_of_pair",
    "relations_of_pair",
    "summarize_scene",
    "update_doc_table",
    "vertical_relation",
]
