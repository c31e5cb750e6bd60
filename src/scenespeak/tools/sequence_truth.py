"""The truth of a rendered sequence: every frame's objects and the events a script makes.

Part of :mod:`scenespeak.tools.sequences` (which re-exports the public names): per frame each
object's truth id, centroid, how much of it is inside the image and visible; the events
(appeared, hidden, out of view, back in view, moved relative to another) derived from them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.calibration import ground_basis
from scenespeak.tools.render import (
    Camera,
)
from scenespeak.tools.scenes import (
    SUPERSAMPLE,
    Placement,
    footprint_relation,
)

__all__ = ["HIDDEN_VISIBLE", "OUT_OF_VIEW_INSIDE", "FrameTruth", "SequenceTruth"]


@dataclass(frozen=True)
class _Shot:
    """One frame of a script: where each object is (None = absent) and the camera's pan."""

    placements: tuple[Placement | None, ...]
    pan_deg: float = 0.0


#: An object is "hidden" once less than this share of its silhouette is visible.
HIDDEN_VISIBLE = 0.25
#: An object is "out of view" once less than this share of its silhouette is inside the image.
OUT_OF_VIEW_INSIDE = 0.3


@dataclass(frozen=True)
class FrameTruth:
    """The truth of one frame (``truth.json["frames"][k]``)."""

    index: int
    pan_deg: float
    objects: tuple[dict[str, Any], ...]

    def object(self, truth_id: int) -> dict[str, Any] | None:
        """The object with this truth id, if present in the frame."""
        for o in self.objects:
            if o["id"] == truth_id:
                return o
        return None


@dataclass(frozen=True)
class SequenceTruth:
    """A generated sequence: its folder, frames and scripted events."""

    root: Path
    script: str
    seed: int
    frames: tuple[FrameTruth, ...]
    events: tuple[dict[str, Any], ...]
    labels: dict[int, str] = field(default_factory=dict)

    @property
    def calib(self) -> Path:
        return self.root / "calib.json"

    def pair(self, k: int) -> tuple[Path, Path]:
        """Left and right image of frame ``k``."""
        d = self.root / f"{k:04d}"
        return d / "left.png", d / "right.png"


# --------------------------------------------------------------------------------------------
# truth


def _silhouette_area(cam: Camera, pl: Placement) -> tuple[float, float]:
    """Area (final pixels) of the object's convex silhouette, and the share inside the image."""
    xyz = cam.to_camera(pl.corners_world())
    if (xyz[:, 2] < 0.05).any():
        return 1.0, 0.0
    uv = cam.project(pl.corners_world(), SUPERSAMPLE).astype(np.float32)
    hull = cv2.convexHull(uv).reshape(-1, 2)
    area = float(cv2.contourArea(hull))
    w, h = cam.image_size
    box = np.array([[0, 0], [w, 0], [w, h], [0, h]], np.float32)
    inter, _ = cv2.intersectConvexConvex(hull, box)
    return max(area, 1e-9), float(inter) / max(area, 1e-9)


def _frame_truth(
    k: int, shot: _Shot, cam: Camera, seg: NDArray[np.int32], labels: Sequence[str]
) -> FrameTruth:
    up = cam.rotation @ np.array([0.0, 0.0, 1.0])
    basis = ground_basis(up)
    objects = []
    for i, pl in enumerate(shot.placements):
        if pl is None:
            continue
        c = cam.to_camera(pl.centroid_world()[None])[0]
        fpw = pl.footprint_world()
        fp = cam.to_camera(np.c_[fpw, np.zeros(len(fpw))]) @ basis.T
        area, inside = _silhouette_area(cam, pl)
        pixels = int((seg == i).sum()) / SUPERSAMPLE**2
        objects.append(
            {
                "id": i + 1,
                "label": labels[i],
                "centroid": [round(float(v), 6) for v in c],
                "footprint": [[round(float(a), 6), round(float(b), 6)] for a, b in fp],
                "visible_fraction": round(min(1.0, pixels / area), 4),
                "in_view": round(inside, 4),
            }
        )
    return FrameTruth(k, shot.pan_deg, tuple(objects))


def _seen(o: dict[str, Any]) -> bool:
    return o["in_view"] >= OUT_OF_VIEW_INSIDE and o["visible_fraction"] >= HIDDEN_VISIBLE


def _relation_events(frames: Sequence[FrameTruth]) -> list[dict[str, Any]]:
    """A pair's unambiguous truth relation changed while both objects were seen.

    The event is said of the object that moved more since the pair's last unambiguous
    relation (the argument), relative to the other (the referent).
    """
    events = []
    last: dict[tuple[int, int], tuple[str, dict[int, NDArray[np.float64]]]] = {}
    for fr in frames:
        seen = [o for o in fr.objects if _seen(o)]
        where = {o["id"]: np.asarray(o["footprint"]).mean(axis=0) for o in seen}
        for a in seen:
            for b in seen:
                if a["id"] >= b["id"]:
                    continue
                fa, fb = np.asarray(a["footprint"]), np.asarray(b["footprint"])
                primary, _, ambiguous = footprint_relation(fa, fb)
                if ambiguous:
                    continue
                key = (a["id"], b["id"])
                if key in last and last[key][0] != primary:
                    then = last[key][1]
                    da = float(np.linalg.norm(where[a["id"]] - then[a["id"]]))
                    db = float(np.linalg.norm(where[b["id"]] - then[b["id"]]))
                    arg, ref = (a, b) if da >= db else (b, a)
                    rel = footprint_relation(
                        np.asarray(arg["footprint"]), np.asarray(ref["footprint"])
                    )[0]
                    events.append(
                        {
                            "kind": "moved",
                            "object": arg["id"],
                            "referent": ref["id"],
                            "relation": rel,
                            "frame": fr.index,
                        }
                    )
                last[key] = (primary, {a["id"]: where[a["id"]], b["id"]: where[b["id"]]})
    return events


def _object_events(frames: Sequence[FrameTruth]) -> list[dict[str, Any]]:
    """Appearances, hidings and departures from the view."""
    events: list[dict[str, Any]] = []
    state: dict[int, str] = {}
    for fr in frames:
        for o in fr.objects:
            i = o["id"]
            if o["in_view"] < OUT_OF_VIEW_INSIDE:
                now = "out of view"
            elif o["visible_fraction"] < HIDDEN_VISIBLE:
                now = "hidden"
            else:
                now = "seen"
            before = state.get(i)
            if before is None and fr.index > 0 and now == "seen":
                events.append({"kind": "appeared", "object": i, "frame": fr.index})
            elif before == "seen" and now == "out of view":
                events.append({"kind": "out of view", "object": i, "frame": fr.index})
            elif before == "seen" and now == "hidden":
                ev = {"kind": "hidden", "object": i, "frame": fr.index}
                ev["referent"] = _occluder(fr, o)
                events.append(ev)
            if before is not None or now == "seen":
                state[i] = now
    return events


def _occluder(fr: FrameTruth, hidden: dict[str, Any]) -> int | None:
    """The nearest other object in front of ``hidden`` (by the footprints' x overlap)."""
    hx = np.asarray(hidden["footprint"])[:, 0]
    best, best_d = None, np.inf
    for o in fr.objects:
        if o["id"] == hidden["id"] or o["centroid"][2] >= hidden["centroid"][2]:
            continue
        ox = np.asarray(o["footprint"])[:, 0]
        if ox.min() < hx.max() and hx.min() < ox.max() and o["centroid"][2] < best_d:
            best, best_d = o["id"], o["centroid"][2]
    return best
