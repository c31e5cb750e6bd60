"""What :func:`scenespeak.pipeline.describe_scene` gives: every stage's result, frozen.

:class:`SceneDescription` keeps the inputs and each stage's result (features, stereo, labels,
objects, relations, summary, timings); :meth:`SceneDescription.to_dict` is the JSON of
``docs/interfaces.md`` (plus extra fields), :meth:`SceneDescription.to_text` the sentences
for people. :class:`PairRelation` is one ordered pair's relation with the force histograms it
was decided from.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.objects import SceneObject, Skipped

__all__ = ["PairRelation", "SceneDescription"]


@dataclass(frozen=True, eq=False)
class PairRelation:
    """The relation of one ordered pair with the force histograms it was decided from.

    Attributes
    ----------
    relation : Relation
        The words and numbers of :mod:`scenespeak.spatial.language` (``primary``, ``secondary``,
        ``sentence``, ``hedge``, ``vertical``, ...; also readable directly on this object).
    f0, f2 : (directions,) float64
        F0 and F2 of the argument relative to the referent; ``f2`` is the hybrid F02 where F2 is
        undefined (touching or overlapping hulls, ``relation.hybrid``).
    """

    relation: Any
    f0: NDArray[np.float64]
    f2: NDArray[np.float64]

    def __getattr__(self, name: str) -> Any:
        # Only called for names that are not fields: read them from the Relation.
        if name.startswith("__") or name in ("relation", "f0", "f2"):
            raise AttributeError(name)
        return getattr(self.relation, name)

    def to_dict(self) -> dict[str, Any]:
        """The ``relations`` entry of ``docs/interfaces.md`` plus ``Relation.to_dict``'s extras."""
        rel = self.relation
        head: dict[str, Any] = {
            "argument": rel.argument,
            "referent": rel.referent,
            "primary": rel.primary,
            "secondary": rel.secondary,
            "sentence": rel.sentence,
            "f0": [float(v) for v in self.f0],
            "f2": [float(v) for v in self.f2],
        }
        head.update({k: v for k, v in rel.to_dict().items() if k not in head})
        return head


@dataclass(frozen=True, eq=False)
class SceneDescription:
    """Everything :func:`describe_scene` computed, stage by stage.

    Attributes
    ----------
    left, right : ndarray
        The input images (as given).
    rig : StereoRig
        The calibration.
    features_left, features_right : Features
        SIFT features of each image.
    points : Points3D
        Matched and triangulated keypoints (left camera frame).
    stereo : StereoResult
        The whole stereo stage (rectification, matches, the dense disparity map if computed).
    point_labels : tuple of (str or None)
        The object each stereo point was labelled with, None for unknown.
    labelling : Labelling or None
        The database's labelling of the left keypoints (with its detections).
    objects : tuple of SceneObject
        Described objects.
    skipped : tuple of Skipped
        Objects that could not be described, with the reason.
    relations : tuple of PairRelation
        Every ordered pair of described objects: the Relation and its histograms.
    summary : str
        A short paragraph about the scene ("" without objects or when switched off).
    timings : dict of str to float
        Seconds spent per stage: ``sift`` (the left image; the right one runs at the same time
        in a second thread), ``label``, ``stereo`` (in the second thread, while ``label`` runs),
        ``wait`` (for the stereo stage after labelling), ``objects``, ``relations``. The wall
        time is about ``sift + label + wait + objects + relations``.
    sources : dict of str to str
        The files the inputs came from, when known.
    """

    left: NDArray[np.generic]
    right: NDArray[np.generic]
    rig: Any
    features_left: Any
    features_right: Any
    points: Any
    stereo: Any
    point_labels: tuple[str | None, ...]
    labelling: Any
    objects: tuple[SceneObject, ...]
    skipped: tuple[Skipped, ...]
    relations: tuple[PairRelation, ...]
    summary: str = ""
    timings: Mapping[str, float] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    @property
    def up(self) -> NDArray[np.float64]:
        """The world's up direction in the left camera frame."""
        return np.asarray(self.rig.up, dtype=np.float64)

    @property
    def detections(self) -> tuple[Any, ...]:
        """Objects recognised in the left image (``Detection``), best first."""
        return () if self.labelling is None else tuple(self.labelling.detections)

    def object(self, label: str) -> SceneObject | None:
        """The described object with this label, if any."""
        for obj in self.objects:
            if obj.label == label:
                return obj
        return None

    def relation(self, argument: str, referent: str) -> PairRelation | None:
        """The relation of ``argument`` to ``referent``, or None."""
        for rel in self.relations:
            if rel.argument == argument and rel.referent == referent:
                return rel
        return None

    def to_dict(self) -> dict[str, Any]:
        """The JSON of ``scenespeak describe --format json`` (``docs/interfaces.md``), plus extras.

        ``objects`` (label, points, centroid, hull; extras: source, notes, plane_centroid,
        height_range), ``relations`` (argument, referent, primary, secondary, sentence, f0, f2;
        extras from :meth:`Relation.to_dict`), ``skipped`` (label, reason); extras ``summary``,
        ``up``, ``camera`` (``focal_px``, ``baseline_m``: the depth error Z²·σ/(f·B) of the
        dialogue's hedges), ``stereo_points``, ``timings_ms``.
        """
        objects = []
        for o in self.objects:
            objects.append(
                {
                    "label": o.label,
                    "name": o.key,
                    "confidence": round(float(o.confidence), 4),
                    "points": int(o.n_points),
                    "centroid": [float(v) for v in o.centroid],
                    "hull": [[float(x), float(y)] for x, y in o.hull],
                    "source": o.source,
                    "notes": list(o.notes),
                    "plane_centroid": [float(v) for v in o.plane_centroid],
                    "height_range": [float(o.heights.min()), float(o.heights.max())],
                }
            )
        relations = [rel.to_dict() for rel in self.relations]
        return {
            "objects": objects,
            "relations": relations,
            "skipped": [{"label": s.label, "reason": s.reason} for s in self.skipped],
            "summary": self.summary,
            "up": [float(v) for v in self.up],
            "camera": _camera(self.rig),
            "stereo_points": len(self.point_labels),
            "timings_ms": {k: round(v * 1000.0, 2) for k, v in self.timings.items()},
        }

    def to_text(self) -> str:
        """The sentences for people: every ordered pair, then what was not described."""
        lines = [rel.sentence for rel in self.relations]
        if not self.objects:
            lines.append("No object could be described in this scene.")
        elif len(self.objects) == 1:
            lines.append(f"Only the {self.objects[0].label} was described: nothing to relate.")
        for s in self.skipped:
            lines.append(f"Not described: the {s.label} ({s.reason}).")
        return "\n".join(lines)


def _camera(rig: Any) -> dict[str, float]:
    """Focal length (px) and baseline (m) of the rig, for the depth error of a scene's words."""
    try:
        return {"focal_px": float(rig.K_left[0][0]), "baseline_m": float(rig.baseline)}
    except (AttributeError, TypeError, IndexError):
        return {}
