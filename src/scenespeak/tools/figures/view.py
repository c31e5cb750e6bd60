"""What the figures need of a scene: read from a ``SceneDescription`` or its ``to_dict()``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.tools.figures._style import _is_unlabelled

# --------------------------------------------------------------------------------------------
# Adapting a scene description
# --------------------------------------------------------------------------------------------


@dataclass
class _SceneView:
    """What the figures need of a scene, whatever object it came from."""

    left: NDArray[Any] | None = None
    right: NDArray[Any] | None = None
    left_xy: NDArray[np.float64] | None = None
    right_xy: NDArray[np.float64] | None = None
    xyz: NDArray[np.float64] | None = None
    point_labels: list[Any] | None = None
    match_labels: list[Any] | None = None
    up: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, -1.0, 0.0]))
    hfov_deg: float | None = None
    hulls: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    plane_points: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    object_xyz: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    relations: list[dict[str, Any]] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)
    summary: str | None = None


def _get(obj: Any, *names: str) -> Any:
    """First attribute (or mapping key) of ``obj`` among ``names`` that is not None."""
    for name in names:
        val = obj.get(name) if isinstance(obj, Mapping) else getattr(obj, name, None)
        if val is not None:
            return val
    return None


def _scene_view(description: Any) -> _SceneView:
    """Collect the arrays the figures need from a SceneDescription or its ``to_dict()``."""
    v = _SceneView()
    v.left = _get(description, "left", "left_image")
    v.right = _get(description, "right", "right_image")
    _read_camera(v, description)
    points = _read_points(v, description)
    _read_point_labels(v, description, points)
    _read_objects(v, description)
    _read_relations(v, description)
    _complete_points(v)
    return v


def _read_camera(v: _SceneView, description: Any) -> None:
    """Up (from the description or its rig) and the horizontal field of view of the rig."""
    rig = _get(description, "rig")
    up = _get(description, "up")
    if up is None and rig is not None:
        up = _get(rig, "up")
    if up is not None:
        v.up = np.asarray(up, dtype=np.float64).reshape(3)
    if rig is not None:
        hfov = _get(rig, "hfov_deg")
        v.hfov_deg = _hfov_of(rig) if hfov is None else float(hfov)


def _hfov_of(rig: Any) -> float | None:
    """The horizontal field of view (degrees) from the left camera matrix and the image width."""
    try:
        k = np.asarray(_get(rig, "K_left", "K1", "K"), dtype=np.float64)
        width = float(np.asarray(_get(rig, "image_size"))[0])
        return float(np.degrees(2 * np.arctan2(width / 2, k[0, 0])))
    except (TypeError, ValueError, IndexError):
        return None


def _read_points(v: _SceneView, description: Any) -> Any:
    """The stereo points (a ``Points3D``, a mapping, or the list of ``scenespeak points``)."""
    points = _get(description, "points", "points3d", "stereo_points")
    if isinstance(points, list):
        if points:  # the JSON form of ``scenespeak points``
            v.xyz = np.array([p["xyz"] for p in points], dtype=np.float64).reshape(-1, 3)
            v.left_xy = np.array([p["left"] for p in points], dtype=np.float64).reshape(-1, 2)
            v.right_xy = np.array([p["right"] for p in points], dtype=np.float64).reshape(-1, 2)
        return points
    if points is None:
        return None
    xyz = _get(points, "xyz")
    if xyz is not None:
        v.xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    lxy, rxy = _get(points, "left_xy"), _get(points, "right_xy")
    if lxy is not None and rxy is not None:
        v.left_xy = np.asarray(lxy, dtype=np.float64).reshape(-1, 2)
        v.right_xy = np.asarray(rxy, dtype=np.float64).reshape(-1, 2)
    return points


def _read_point_labels(v: _SceneView, description: Any, points: Any) -> None:
    """One label per stereo point (from the description, or from the points themselves)."""
    labels = _get(description, "point_labels", "labels")
    if labels is None and points is not None and not isinstance(points, list):
        labels = _get(points, "labels")
    if labels is not None and v.xyz is not None and len(labels) == len(v.xyz):
        v.point_labels = [None if _is_unlabelled(lab) else str(lab) for lab in labels]


def _read_objects(v: _SceneView, description: Any) -> None:
    """Each object's hull, plane points and 3-D points, by label."""
    for obj in _get(description, "objects") or []:
        label = str(_get(obj, "label"))
        for name, dims, into in (
            ("hull", 2, v.hulls),
            ("plane_xy", 2, v.plane_points),
            ("xyz", 3, v.object_xyz),
        ):
            value = _get(obj, name)
            if value is not None:
                into[label] = np.asarray(value, dtype=np.float64).reshape(-1, dims)


def _read_relations(v: _SceneView, description: Any) -> None:
    """Relations (with their histograms), skipped objects and the summary."""
    for rel in _get(description, "relations") or []:
        v.relations.append(
            {
                "argument": str(_get(rel, "argument")),
                "referent": str(_get(rel, "referent")),
                "sentence": _get(rel, "sentence") or "",
                "f0": _get(rel, "f0"),
                "f2": _get(rel, "f2", "f02"),
            }
        )
    for sk in _get(description, "skipped") or []:
        v.skipped.append((str(_get(sk, "label")), str(_get(sk, "reason") or "")))
    summary = _get(description, "summary")
    v.summary = summary if isinstance(summary, str) else None


def _complete_points(v: _SceneView) -> None:
    """Points for the 3-D picture when the objects were built from other points.

    With no per-point labels the points are rebuilt from the objects' own 3-D points; objects
    made of other points than the labelled keypoints (dense disparity, unknown clusters) would
    be missing from the picture, so their own points are added.
    """
    if v.xyz is None and v.object_xyz:
        v.xyz = np.vstack(list(v.object_xyz.values()))
        v.point_labels = [lab for lab, p in v.object_xyz.items() for _ in range(len(p))]
    v.match_labels = v.point_labels
    if v.xyz is not None and v.point_labels is not None:
        have = set(v.point_labels)
        extra = {lab: p for lab, p in v.object_xyz.items() if lab not in have and len(p)}
        if extra:
            v.xyz = np.vstack([v.xyz, *extra.values()])
            v.point_labels = v.point_labels + [lab for lab, p in extra.items() for _ in p]
