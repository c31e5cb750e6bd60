"""The tracker's records: its options, one track, one frame's tracks, and small image helpers.

:class:`~scenespeak.perception.tracking.ObjectTracker` keeps a :class:`Track` per object and
gives a :class:`FrameObjects` per frame; the helpers here (grey conversion, hue histograms of
an outline, boxes, moving an object) work on plain arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal, Protocol

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.objects import SceneObject, project_to_plane
from scenespeak.perception.recognition.results import Detection
from scenespeak.perception.stereo import Points3D

__all__ = ["FrameObjects", "Keyframe", "Track", "TrackingOptions", "Where"]


class Keyframe(Protocol):
    """What the tracker reads from the full chain's result on a keyframe
    (:class:`scenespeak.pipeline.SceneDescription` has it)."""

    @property
    def detections(self) -> tuple[Detection, ...]: ...

    @property
    def objects(self) -> tuple[SceneObject, ...]: ...

    @property
    def points(self) -> Points3D: ...

    @property
    def point_labels(self) -> tuple[str | None, ...]: ...


Where = Literal["seen", "hidden", "out of view"]


@dataclass(frozen=True)
class TrackingOptions:
    """Knobs of :class:`ObjectTracker`.

    Attributes
    ----------
    keyframe_every : int
        Full recognition at least every this many frames.
    min_survival : float
        A track needs this share of its keyframe points still tracked.
    min_points : int
        ... and at least this many.
    corners : int
        Shi–Tomasi corners added inside each object's outline at a keyframe (besides its
        labelled SIFT keypoints).
    window : int
        Lucas–Kanade window (pixels).
    max_fb_error : float
        Forward–backward error (pixels) above which a tracked point is dropped.
    max_row_error : float
        Rectified row difference (pixels) above which a left/right pair is dropped.
    depth_gate : float
        Points farther than this (metres) from their track's median depth are dropped (they
        slid onto an object in front or behind).
    match_distance : float
        A keyframe object further than this (metres) from a track's predicted position is not
        that track.
    change_fraction, change_level : float, int
        Recognise again when more than ``change_fraction`` of the pixels outside the tracked
        boxes differ by more than ``change_level`` grey levels from the last keyframe.
    """

    keyframe_every: int = 10
    min_survival: float = 0.4
    min_points: int = 5
    corners: int = 40
    window: int = 21
    max_fb_error: float = 1.0
    max_row_error: float = 2.0
    depth_gate: float = 0.15
    match_distance: float = 0.3
    change_fraction: float = 0.004
    change_level: int = 30


@dataclass(frozen=True, eq=False)
class Track:
    """One object as the tracker knows it in the current frame.

    Attributes
    ----------
    id : int
        Stable over the stream (never reused).
    label : str
        The database label (carried from the keyframe that recognised it).
    obj : SceneObject
        Its points, hull and heights, moved to the current frame (the last known ones when
        it is not seen).
    where : {"seen", "hidden", "out of view"}
        Seen this frame, or the tracker's guess of why not.
    behind : int or None
        For ``"hidden"``: the id of the nearer track covering it.
    box : (x0, y0, x1, y1) float
        Its box in the left image (input pixels).
    outline : (M, 2) float
        Its outline in the left image (the recognised outline moved with the track).
    source : {"recognised", "tracked", "remembered"}
        How this frame's position was obtained.
    last_seen : int
        The frame it was last seen in.
    tracked_points : int
        Points followed this frame.
    """

    id: int
    label: str
    obj: SceneObject
    where: Where
    box: tuple[float, float, float, float]
    outline: NDArray[np.float64]
    source: str
    last_seen: int
    behind: int | None = None
    tracked_points: int = 0


@dataclass(frozen=True, eq=False)
class FrameObjects:
    """What the tracker made of one frame.

    Attributes
    ----------
    index : int
        Frame number (from 0).
    tracks : tuple of Track
        Every track alive (seen or remembered).
    recognised : bool
        Whether the full chain ran on this frame.
    reason : str
        Why it ran (``"first frame"``, ``"every 10 frames"``, ``"track lost"``, ``"scene
        changed"``), ``""`` when it did not.
    description : Keyframe or None
        The full chain's result on a recognised frame (a ``SceneDescription`` from the
        pipeline).
    timings : dict of str to float
        Seconds: ``track``, ``recognise``, ``match``.
    """

    index: int
    tracks: tuple[Track, ...]
    recognised: bool
    reason: str
    description: Keyframe | None = None
    timings: dict[str, float] = field(default_factory=dict)


@dataclass
class _State:
    """Mutable per-track state between frames (private to the tracker)."""

    track: Track
    key_obj: SceneObject
    key_xyz: NDArray[np.float64]  # tracked points' 3-D at the keyframe
    left_xy: NDArray[np.float32]  # their current left positions
    right_xy: NDArray[np.float32]
    n_key: int
    key_outline: NDArray[np.float64]
    key_left: NDArray[np.float32]  # their left positions at the keyframe
    hist: NDArray[np.float32]
    alive: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, bool))


def _gray(img: NDArray[np.generic]) -> NDArray[np.uint8]:
    a = np.asarray(img)
    if a.dtype != np.uint8:
        f = a.astype(np.float64)
        lo, hi = float(np.nanmin(f)), float(np.nanmax(f))
        a = np.round((f - lo) * (255.0 / max(hi - lo, 1e-12))).astype(np.uint8)
    if a.ndim == 3:
        return np.ascontiguousarray(cv2.cvtColor(a, cv2.COLOR_RGB2GRAY), dtype=np.uint8)
    return np.ascontiguousarray(a, dtype=np.uint8)


def _hue_hist(img: NDArray[np.generic], mask: NDArray[np.uint8]) -> NDArray[np.float32]:
    a = np.asarray(img)
    if a.ndim != 3:
        h = cv2.calcHist([np.ascontiguousarray(a, dtype=np.uint8)], [0], mask, [16], [0, 256])
    else:
        hsv = cv2.cvtColor(np.ascontiguousarray(a[..., :3], dtype=np.uint8), cv2.COLOR_RGB2HSV)
        h = cv2.calcHist([hsv], [0, 1], mask, [12, 4], [0, 180, 0, 256])
    h = np.asarray(h, dtype=np.float32)
    return (h / max(float(h.sum()), 1e-12)).astype(np.float32)


def _box(xy: NDArray[np.float64]) -> tuple[float, float, float, float]:
    return (
        float(xy[:, 0].min()),
        float(xy[:, 1].min()),
        float(xy[:, 0].max()),
        float(xy[:, 1].max()),
    )


def _moved_object(obj: SceneObject, t: NDArray[np.float64], up: NDArray[np.float64]) -> SceneObject:
    """``obj`` translated by the 3-D vector ``t`` (left camera frame)."""
    dxy = project_to_plane(t[None], up)[0]
    u = up / np.linalg.norm(up)
    return replace(
        obj,
        xyz=obj.xyz + t,
        plane_xy=obj.plane_xy + dxy,
        hull=obj.hull + dxy,
        centroid=obj.centroid + t,
        heights=obj.heights + float(t @ u),
    )
