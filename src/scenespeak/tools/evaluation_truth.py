"""Ground truth and predictions as the evaluation reads them (part of
:mod:`scenespeak.tools.evaluation`, which re-exports every name here).

``truth.json`` (``docs/evaluation.md``): objects with ``label``, ``centroid`` (the centre of the
object's volume, metres, left camera frame) and optionally ``name`` (instances of one label),
``distractor`` and ``distance``; relations with ``argument``, ``referent``, ``primary``,
``ambiguous`` and ``reasons``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from scenespeak.errors import InputError

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
class TruthObject:
    """One object of the ground truth: its label and the centre of its volume (metres)."""

    label: str
    centroid: tuple[float, float, float]
    name: str = ""
    distractor: bool = False
    distance: float = float("nan")

    @property
    def key(self) -> str:
        """The name relations use (instances of one label differ: "mug", "mug 2")."""
        return self.name or self.label

    @property
    def metres(self) -> float:
        """Distance from the left camera."""
        return self.distance if math.isfinite(self.distance) else math.hypot(*self.centroid)


@dataclass(frozen=True)
class TruthRelation:
    """The true primary direction of ``argument`` relative to ``referent``.

    ``ambiguous`` marks pairs whose true direction lies near a diagonal, where either
    neighbouring direction is a fair answer; they are counted apart.
    """

    argument: str
    referent: str
    primary: str
    ambiguous: bool = False
    tags: tuple[str, ...] = ()  # centroid_rule.TAGS: "elongated", "close", "partly hidden"
    overlap: bool = False  # the footprints overlap (truth reason "overlap")
    #: The second truth, independent of the centroid rule: the direction most point pairs of
    #: the true footprints agree on, and whether it is clear (``centroid_rule.point_pairs_truth``).
    pairs_primary: str = ""
    pairs_clear: bool = False


@dataclass(frozen=True)
class SceneTruth:
    """Everything the evaluation needs from one ``truth.json``."""

    name: str
    objects: tuple[TruthObject, ...]
    relations: tuple[TruthRelation, ...]
    pitch_deg: float = 0.0


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


def _vec3(value: Any, where: str) -> tuple[float, float, float]:
    try:
        arr = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise InputError(where, f"expected three numbers [X, Y, Z], got {value!r:.60}") from None
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise InputError(where, f"expected three finite numbers [X, Y, Z], got {value!r:.60}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def load_scene_truth(scene_dir: str | PathLike[str]) -> SceneTruth:
    """Read ``scene_dir/truth.json`` (format: ``docs/evaluation.md``).

    Raises
    ------
    InputError
        If the file is missing, not JSON, or lacks ``objects`` with ``label`` and ``centroid``.
    """
    from scenespeak.safeio import load_json, read_text

    path = Path(scene_dir) / "truth.json"
    if not path.exists() and not path.is_symlink():
        raise InputError(path, "missing: every labelled scene needs a truth.json")
    text = read_text(path, what="truth.json file")
    try:
        data = load_json(text, path)
    except InputError as exc:
        raise InputError(path, f"cannot be read as JSON ({exc.problem})") from None
    if not isinstance(data, Mapping) or not isinstance(data.get("objects"), list):
        raise InputError(path, 'expected {"objects": [...], "relations": [...]}')
    try:
        objects = tuple(
            TruthObject(
                str(o["label"]),
                _vec3(o["centroid"], f"{path}: {o['label']}"),
                name=str(o.get("name", o["label"])),
                distractor=bool(o.get("distractor", False)),
                distance=float(o.get("distance", float("nan"))),
            )
            for o in data["objects"]
        )
        by_label = {str(o.get("name", o["label"])): o for o in data["objects"]}
        pairs = _point_pairs(by_label, data.get("relations", []))
        relations = tuple(
            TruthRelation(
                str(r["argument"]),
                str(r["referent"]),
                str(r["primary"]),
                bool(r.get("ambiguous", False)),
                _tags(by_label, r),
                "overlap" in r.get("reasons", ()),
                *pairs[k],
            )
            for k, r in enumerate(data.get("relations", []))
        )
        rig = data.get("rig", {})
        pitch = float(rig.get("pitch_deg", 0.0)) if isinstance(rig, Mapping) else 0.0
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(path, f"an object or relation lacks the field {exc}") from exc
    except InputError as exc:
        if exc.source is not None and str(path) in exc.source:
            raise
        raise InputError(path, exc.problem if exc.source is None else str(exc)) from None
    return SceneTruth(Path(scene_dir).name, objects, relations, pitch)


def _tags(objects: Mapping[str, Any], rel: Mapping[str, Any]) -> tuple[str, ...]:
    from scenespeak.tools.centroid_rule import pair_tags

    a, b = objects.get(str(rel["argument"])), objects.get(str(rel["referent"]))
    return () if a is None or b is None else pair_tags(a, b, rel.get("reasons", ()))


def _point_pairs(
    objects: Mapping[str, Any], relations: list[Mapping[str, Any]]
) -> list[tuple[str, bool]]:
    """Per relation, ``centroid_rule.point_pairs_truth`` (one computation per unordered pair:
    the reverse relation has the opposite direction and the same share)."""
    from scenespeak.tools.centroid_rule import OPPOSITE, point_pairs_truth

    done: dict[tuple[str, str], tuple[str, bool]] = {}
    out = []
    for r in relations:
        arg, ref = str(r["argument"]), str(r["referent"])
        if (ref, arg) in done:
            direction, clear = done[(ref, arg)]
            out.append((OPPOSITE.get(direction, ""), clear))
            continue
        a, b = objects.get(arg), objects.get(ref)
        reasons = r.get("reasons", ())
        got = ("", False) if a is None or b is None else point_pairs_truth(a, b, reasons)
        done[(arg, ref)] = got
        out.append(got)
    return out


def predicted_from_description(description: Any, name: str, seconds: float = 0.0) -> PredictedScene:
    """Reduce a :class:`~scenespeak.pipeline.SceneDescription` (or its ``to_dict()``)."""
    from scenespeak.tools.centroid_rule import centroid_primary

    d = description if isinstance(description, Mapping) else description.to_dict()
    objects = {
        str(o.get("name", o["label"])): _vec3(o["centroid"], str(o["label"])) for o in d["objects"]
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
