"""The result of every RGB-D / masks / boxes input form and the steps they share at the end.

:class:`RGBDDescription` (objects, skipped, relations, summary, up; ``to_dict`` is the JSON
of ``scenespeak describe --format json``), and naming the instances, relating them and
summarising (:func:`name_objects`, :func:`finish`). Split out of
:mod:`scenespeak.pipeline_rgbd`, which re-exports every public name.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.contract import SpatialObject
from scenespeak.errors import ImageError
from scenespeak.perception.masks import InstanceMasks, instances_from_array
from scenespeak.perception.objects import Skipped
from scenespeak.perception.rgbd import MeasuredObject, SupportPlane
from scenespeak.pipeline import PairRelation

__all__ = ["MasksIn", "RGBDDescription", "as_instances", "finish", "name_objects"]

MasksIn = InstanceMasks | NDArray[np.integer[Any]]


@dataclass(frozen=True, eq=False)
class RGBDDescription:
    """Objects and relations of a scene seen through any perception (RGB-D, masks, boxes).

    Attributes
    ----------
    frame : {"horizontal", "image"}
        Where the hulls and relations live.
    objects : tuple of MeasuredObject
        Described objects (``.object`` is the :class:`SpatialObject`; ``.name`` distinct).
    skipped : tuple of Skipped
        Objects that could not be described, with the reason.
    relations : tuple of PairRelation
        Every ordered pair, with the histograms, named by the objects' names.
    summary : str
        A short paragraph ("" when switched off or without relations).
    up : (3,) float64 or None
        World up in the camera frame (None in the image plane).
    up_source : str
        ``"given"`` (intrinsics, calibration or argument), ``"estimated"`` (support plane),
        ``"default"`` (no plane found: ``[0, -1, 0]``) or ``"none"`` (image plane).
    up_note : str
        Why up is what it is, when it was not given.
    plane : SupportPlane or None
        The support plane found (when up was estimated or boxes needed it).
    timings : dict of str to float
        Seconds per stage.
    sources : dict of str to str
        The input files, when known.
    """

    frame: str
    objects: tuple[MeasuredObject, ...]
    skipped: tuple[Skipped, ...]
    relations: tuple[PairRelation, ...]
    summary: str = ""
    up: NDArray[np.float64] | None = None
    up_source: str = "given"
    up_note: str = ""
    plane: SupportPlane | None = None
    timings: Mapping[str, float] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    @property
    def spatial_objects(self) -> tuple[SpatialObject, ...]:
        """The objects as the spatial half sees them."""
        return tuple(o.object for o in self.objects)

    def object(self, name: str) -> MeasuredObject | None:
        """The object with this name (or, if no name matches, the first with this label)."""
        for o in self.objects:
            if o.name == name:
                return o
        return next((o for o in self.objects if o.label == name), None)

    def relation(self, argument: str, referent: str) -> PairRelation | None:
        """The relation of ``argument`` to ``referent`` (names), or None."""
        for rel in self.relations:
            if rel.argument == argument and rel.referent == referent:
                return rel
        return None

    def _object_dict(self, m: MeasuredObject) -> dict[str, Any]:
        o = m.object
        d: dict[str, Any] = {
            "label": o.label,
            "name": o.name,
            "points": int(m.kept_pixels),
            "centroid": None if o.centroid is None else [float(v) for v in o.centroid],
            "hull": [[float(x), float(y)] for x, y in o.hull],
            "source": m.source,
            "pixels": int(m.pixels),
            "kept_pixels": int(m.kept_pixels),
            "notes": list(m.notes),
            "plane_centroid": [float(v) for v in o.footprint_centroid],
        }
        if o.heights is not None and len(o.heights):
            d["height_range"] = [float(o.heights.min()), float(o.heights.max())]
        return d

    def to_dict(self) -> dict[str, Any]:
        """The JSON of ``describe --format json`` (``interfaces.md``) with ``frame`` on top.

        Objects: ``label``, ``name``, ``points`` (kept pixels), ``centroid`` (camera frame,
        metres; null in the image plane), ``hull`` (in ``frame``), ``source``, ``pixels``,
        ``kept_pixels``, ``notes``, ``plane_centroid``, ``height_range``. Relations and
        skipped as for a stereo pair; extras ``summary``, ``up``, ``up_source``, ``up_note``,
        ``timings_ms``.
        """
        return {
            "frame": self.frame,
            "objects": [self._object_dict(m) for m in self.objects],
            "relations": [rel.to_dict() for rel in self.relations],
            "skipped": [{"label": s.label, "reason": s.reason} for s in self.skipped],
            "summary": self.summary,
            "up": None if self.up is None else [float(v) for v in self.up],
            "up_source": self.up_source,
            "up_note": self.up_note,
            "timings_ms": {k: round(v * 1000.0, 3) for k, v in self.timings.items()},
        }

    def to_text(self) -> str:
        """The sentences for people: every ordered pair, then what was not described."""
        lines = [rel.sentence for rel in self.relations]
        if not self.objects:
            lines.append("No object could be described in this scene.")
        elif len(self.objects) == 1:
            lines.append(f"Only the {self.objects[0].name} was described: nothing to relate.")
        for s in self.skipped:
            lines.append(f"Not described: the {s.label} ({s.reason}).")
        if self.up_note:
            lines.append(f"Note: {self.up_note}")
        return "\n".join(lines)


def as_instances(
    masks: MasksIn,
    labels: Mapping[int, str] | None,
    size: tuple[int, int] | None,
    sources: Mapping[str, str],
) -> InstanceMasks:
    if isinstance(masks, InstanceMasks):
        if size is not None and masks.size != tuple(size):
            w, h = masks.size
            raise ImageError(
                masks.source,
                f"is {w}x{h} but the colour image is {size[0]}x{size[1]}: "
                "masks must be of its size",
            )
        return masks
    return instances_from_array(
        np.asarray(masks),
        labels,
        size=size,
        source=sources.get("masks", "masks"),
        labels_source=sources.get("labels", "labels"),
    )


def _relate(objects: Sequence[MeasuredObject], directions: int, frame: str) -> list[PairRelation]:
    """Every ordered pair of the objects through the force histograms and the rule base."""
    from scenespeak.spatial.language import relate_objects

    if len(objects) < 2:
        return []
    heights = [o.object.heights for o in objects]
    found = relate_objects(
        [o.object.hull for o in objects],
        names=[o.name for o in objects],
        heights=None if any(h is None for h in heights) else heights,  # type: ignore[arg-type]
        directions=directions,
    )
    rels = [PairRelation(_in_frame(rel, frame), hist.f0, hist.f2) for rel, hist in found]
    order = {o.name: k for k, o in enumerate(objects)}
    rels.sort(key=lambda r: (order[r.argument], order[r.referent]))
    return rels


def _in_frame(rel: Any, frame: str) -> Any:
    """The image plane's words for a relation computed on image-plane hulls."""
    if frame != "image":
        return rel
    from scenespeak.spatial.language.picture import in_picture

    return in_picture(rel)


def _summary(rels: Sequence[PairRelation], objects: Sequence[MeasuredObject]) -> str:
    from scenespeak.spatial.language import summarize_scene

    if not rels:
        return ""
    return summarize_scene(
        [r.relation for r in rels],
        centroids={o.name: o.object.footprint_centroid for o in objects},
    )


def name_objects(
    measured: Sequence[MeasuredObject | Skipped],
) -> tuple[list[MeasuredObject], list[Skipped]]:
    """Split described and skipped objects; name the instances apart (spatial/naming)."""
    from scenespeak.spatial.naming import instance_names

    objs = [m for m in measured if isinstance(m, MeasuredObject)]
    skipped = [m for m in measured if isinstance(m, Skipped)]
    names = instance_names([m.object for m in objs])
    out = [
        m if m.name == n else replace(m, object=replace(m.object, name=n))
        for m, n in zip(objs, names, strict=True)
    ]
    return out, skipped


def finish(
    frame: str,
    measured: Sequence[MeasuredObject | Skipped],
    up: tuple[NDArray[np.float64] | None, str, str, SupportPlane | None],
    timings: dict[str, float],
    sources: Mapping[str, str],
    directions: int,
    summary: bool,
) -> RGBDDescription:
    t0 = time.perf_counter()
    objects, skipped = name_objects(measured)
    rels = _relate(objects, directions, frame)
    text = _summary(rels, objects) if summary else ""
    timings["relations"] = time.perf_counter() - t0
    vec, source, note, plane = up
    return RGBDDescription(
        frame=frame,
        objects=tuple(objects),
        skipped=tuple(skipped),
        relations=tuple(rels),
        summary=text,
        up=vec,
        up_source=source,
        up_note=note,
        plane=plane,
        timings=timings,
        sources=dict(sources),
    )
