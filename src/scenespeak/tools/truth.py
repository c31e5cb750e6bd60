"""The ground truth of a labelled scene: one family of records and one ``truth.json`` reader.

The scene generator writes ``truth.json`` (``docs/scenes.md``); hand-labelled scenes need only
part of it (``docs/evaluation.md``): objects with ``label`` and ``centroid`` (the centre of the
object's volume, metres, left camera frame) and optionally ``name`` (instances of one label),
``distractor``, ``distance``, ``footprint``, ``visible_fraction``, ``index``, ``shape``,
``size``, ``on``; relations with ``argument``, ``referent``, ``primary`` and optionally
``ambiguous``, ``angle_deg``, ``reasons``; the rig (``pitch_deg``, ``up``, ...) and the
instance image's ``labels.legend``. :func:`load_truth` reads either into a
:class:`SceneTruth`; the generator (:mod:`scenespeak.tools.scenes`) and the evaluation
(:mod:`scenespeak.tools.evaluation`) both use it.

>>> t = SceneTruth("s", (TruthObject("mug", (0.1, 0.0, 1.0)),), ())
>>> t.object("mug").key, round(t.object("mug").metres, 3)
('mug', 1.005)
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

__all__ = ["SceneTruth", "TruthObject", "TruthRelation", "load_truth", "vec3"]


@dataclass(frozen=True)
class TruthObject:
    """One object of the ground truth.

    Attributes
    ----------
    label : str
        The object's label.
    centroid : (X, Y, Z)
        The centre of its volume, metres, left camera frame.
    name : str
        The name relations use when instances of one label differ ("mug 2"); empty: the label.
    distractor : bool
        Not a learnt object (its label is not in the database).
    distance : float
        Metres from the left camera (NaN: not given, :attr:`metres` computes it).
    footprint : tuple of (x, y)
        Its outline in the horizontal plane (generated scenes).
    visible_fraction : float
        Share of its silhouette not hidden by another object.
    index : int
        Its value in the instance image ``left_labels.png``.
    shape, size, on
        The generator's shape, its size (metres) and the object it stands on, if any.
    """

    label: str
    centroid: tuple[float, float, float]
    name: str = ""
    distractor: bool = False
    distance: float = float("nan")
    footprint: tuple[tuple[float, float], ...] = ()
    visible_fraction: float = 1.0
    index: int = 0
    shape: str = ""
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    on: str | None = None

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
    neighbouring direction is a fair answer; they are counted apart. ``tags`` are
    ``centroid_rule.TAGS`` ("elongated", "close", "partly hidden"); ``overlap``: the
    footprints overlap (the reason "overlap").
    """

    argument: str
    referent: str
    primary: str
    ambiguous: bool = False
    tags: tuple[str, ...] = ()
    overlap: bool = False
    angle_deg: float = float("nan")
    reasons: tuple[str, ...] = ()
    #: The second truth, independent of the centroid rule: the direction most point pairs of
    #: the true footprints agree on, and whether it is clear (``centroid_rule.point_pairs_truth``).
    pairs_primary: str = ""
    pairs_clear: bool = False


@dataclass(frozen=True)
class SceneTruth:
    """The ground truth of one scene, mirroring ``truth.json``.

    Attributes
    ----------
    name : str
        The scene's name (its folder's).
    objects, relations : tuples of TruthObject, TruthRelation
    pitch_deg : float
        The rig's pitch (0 = level).
    scene_dir : Path or None
        The scene's folder (when read from one).
    rig : dict
        ``truth.json``'s ``rig`` as written.
    legend : dict of int to str
        Instance image value → label.
    """

    name: str
    objects: tuple[TruthObject, ...]
    relations: tuple[TruthRelation, ...]
    pitch_deg: float = 0.0
    scene_dir: Path | None = None
    rig: dict[str, Any] = field(default_factory=dict)
    legend: dict[int, str] = field(default_factory=dict)

    def _file(self, name: str) -> Path:
        if self.scene_dir is None:
            raise InputError(self.name, "this ground truth was not read from a scene folder")
        return self.scene_dir / name

    @property
    def left(self) -> Path:
        return self._file("left.png")

    @property
    def right(self) -> Path:
        return self._file("right.png")

    @property
    def calib(self) -> Path:
        return self._file("calib.json")

    def object(self, label: str) -> TruthObject:
        """The object called ``label``."""
        for o in self.objects:
            if o.label == label:
                return o
        raise KeyError(label)


def vec3(value: Any, where: str) -> tuple[float, float, float]:
    """Three finite numbers as an (X, Y, Z) tuple; anything else refused, naming ``where``."""
    try:
        arr = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise InputError(where, f"expected three numbers [X, Y, Z], got {value!r:.60}") from None
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise InputError(where, f"expected three finite numbers [X, Y, Z], got {value!r:.60}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _size(value: Any) -> tuple[float, float, float]:
    x, y, z = value
    return float(x), float(y), float(z)


def load_truth(scene_dir: str | PathLike[str]) -> SceneTruth:
    """Read ``scene_dir/truth.json`` (bounded reading, ``scenespeak.safeio``).

    Raises
    ------
    InputError
        If the file is missing, not JSON, or lacks ``objects`` with ``label`` and ``centroid``
        (or a relation ``argument``, ``referent``, ``primary``).
    """
    path = Path(scene_dir) / "truth.json"
    data = _read(path)
    try:
        objects = tuple(_object(o, k, path) for k, o in enumerate(data["objects"]))
        by_name = {str(o.get("name", o["label"])): o for o in data["objects"]}
        raw = data.get("relations", [])
        pairs = _point_pairs(by_name, raw)
        relations = tuple(_relation(r, by_name, pairs[k]) for k, r in enumerate(raw))
        rig = data.get("rig", {})
        rig = dict(rig) if isinstance(rig, Mapping) else {}
        pitch = float(rig.get("pitch_deg", 0.0))
        legend = _legend(data)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(path, f"an object or relation lacks the field {exc}") from exc
    except InputError as exc:
        if exc.source is not None and str(path) in exc.source:
            raise
        raise InputError(path, exc.problem if exc.source is None else str(exc)) from None
    return SceneTruth(Path(scene_dir).name, objects, relations, pitch, Path(scene_dir), rig, legend)


def _read(path: Path) -> Mapping[str, Any]:
    """The JSON object of a ``truth.json`` with an ``objects`` list (bounded reading)."""
    from scenespeak.safeio import load_json, read_text

    if not path.exists() and not path.is_symlink():
        raise InputError(path, "missing: every labelled scene needs a truth.json")
    text = read_text(path, what="truth.json file")
    try:
        data = load_json(text, path)
    except InputError as exc:
        raise InputError(path, f"cannot be read as JSON ({exc.problem})") from None
    if not isinstance(data, Mapping) or not isinstance(data.get("objects"), list):
        raise InputError(path, 'expected {"objects": [...], "relations": [...]}')
    return data


def _legend(data: Mapping[str, Any]) -> dict[int, str]:
    """Instance image value → label, from ``labels.legend``."""
    labels = data.get("labels", {})
    legend = labels.get("legend", {}) if isinstance(labels, Mapping) else {}
    return {int(k): str(v) for k, v in legend.items()}


def _object(o: Mapping[str, Any], k: int, path: Path) -> TruthObject:
    centroid = vec3(o["centroid"], f"{path}: {o['label']}")
    return TruthObject(
        str(o["label"]),
        centroid,
        name=str(o.get("name", o["label"])),
        distractor=bool(o.get("distractor", False)),
        distance=float(o.get("distance", math.hypot(*centroid))),
        footprint=tuple((float(a), float(b)) for a, b in o.get("footprint", [])),
        visible_fraction=float(o.get("visible_fraction", 1.0)),
        index=int(o.get("index", k + 1)),
        shape=str(o.get("shape", "")),
        size=_size(o.get("size", (0, 0, 0))),
        on=o.get("on"),
    )


def _relation(
    r: Mapping[str, Any], objects: Mapping[str, Any], pairs: tuple[str, bool]
) -> TruthRelation:
    reasons = tuple(r.get("reasons", ()))
    return TruthRelation(
        str(r["argument"]),
        str(r["referent"]),
        str(r["primary"]),
        ambiguous=bool(r.get("ambiguous", False)),
        tags=_tags(objects, r),
        overlap="overlap" in reasons,
        angle_deg=float(r.get("angle_deg", float("nan"))),
        reasons=reasons,
        pairs_primary=pairs[0],
        pairs_clear=pairs[1],
    )


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
