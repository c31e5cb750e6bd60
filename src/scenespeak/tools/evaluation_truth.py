"""Predictions as the evaluation scores them (part of :mod:`scenespeak.tools.evaluation`,
which re-exports every name here); the ground truth is :mod:`scenespeak.tools.truth`'s one
family and reader (``load_scene_truth`` is :func:`scenespeak.tools.truth.load_truth`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from scenespeak.tools.truth import SceneTruth, TruthObject, TruthRelation, vec3
from scenespeak.tools.truth import load_truth as load_scene_truth

__all__ = [
    "PredictedScene",
    "SceneTruth",
    "TruthObject",
    "TruthRelation",
    "load_scene_truth",
    "predicted_from_description",
]


# --------------------------------------------------------------------------------------------
# Ground truth and predictions


@dataclass(frozen=True)
class PredictedScene:
    """What the chain said about one scene, reduced to what is scored.

    Attributes
    ----------
    name : str
        Scene name.
    objects : mapping
        ``label -> centroid (X, Y, Z)`` of every described object (one with a hull).
    relations : mapping
        ``(argument, referent) -> primary`` of every described ordered pair.
    seconds : float
        Wall-clock time the chain took on this scene.
    error : str or None
        Why the scene could not be processed at all (then nothing was described).
    """

    name: str
    objects: Mapping[str, tuple[float, float, float]]
    relations: Mapping[tuple[str, str], str]
    seconds: float = 0.0
    error: str | None = None
    #: ``(argument, referent) -> primary`` by the centroid-vector rule (``centroid_rule``).
    centroid_relations: Mapping[tuple[str, str], str] = field(default_factory=dict)
    #: ``name -> label`` where they differ (instances); labels "unknown..." are unknown objects.
    labels: Mapping[str, str] = field(default_factory=dict)

    def label_of(self, name: str) -> str:
        """The label of the described object ``name``."""
        return self.labels.get(name, name)


def predicted_from_description(description: Any, name: str, seconds: float = 0.0) -> PredictedScene:
    """Reduce a :class:`~scenespeak.pipeline.SceneDescription` (or its ``to_dict()``)."""
    from scenespeak.tools.centroid_rule import centroid_primary

    d = description if isinstance(description, Mapping) else description.to_dict()
    objects = {
        str(o.get("name", o["label"])): vec3(o["centroid"], str(o["label"])) for o in d["objects"]
    }
    labels = {str(o.get("name", o["label"])): str(o["label"]) for o in d["objects"]}
    relations = {
        (str(r["argument"]), str(r["referent"])): str(r["primary"]) for r in d["relations"]
    }
    centre = {str(o.get("name", o["label"])): o.get("plane_centroid") for o in d["objects"]}
    by_centroid = {
        key: centroid_primary(centre[key[0]], centre[key[1]])
        for key in relations
        if centre.get(key[0]) is not None and centre.get(key[1]) is not None
    }
    return PredictedScene(
        name, objects, relations, seconds, centroid_relations=by_centroid, labels=labels
    )


# --------------------------------------------------------------------------------------------
