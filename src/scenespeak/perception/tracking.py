"""Objects followed from frame to frame of a stereo stream, with a stable id each.

The full chain (a ``describe(left, right)`` function given to the tracker: the pipeline's
:func:`scenespeak.pipeline.keyframe_describer`, i.e. ``describe_scene`` with SIFT, labelling,
stereo and dense regions) runs on a *keyframe*; between keyframes each object is *tracked*: its
points in the left image are followed by pyramidal Lucas–Kanade optical flow (Bouguet 2000,
OpenCV ``calcOpticalFlowPyrLK``) with a forward–backward check (Kalal et al. 2010), found again
in the right image by the same flow started at the previous disparity, triangulated, and the
object's keyframe points are moved by the median 3-D displacement of its tracked points. Labels
are carried by the tracks; recognition runs again when

- ``keyframe_every`` frames have passed since the last keyframe,
- a track lost too many points (the object moved out of sight, behind another, or too fast),
- the part of the image no track covers changed (something appeared).

Ids: a keyframe's objects are matched to the existing tracks (also the remembered, unseen
ones) by label, distance to the track's predicted position and hue histogram (Hungarian
assignment, :func:`scipy.optimize.linear_sum_assignment`); an unmatched object starts a new id.
A track that is not seen keeps its last position, with a guess of why it is not seen
(``"out of view"`` when its last image box leaves the image, else ``"hidden"``, with the
id of the nearer object covering it most). When the camera turns, the unseen tracks turn with
it. Only perception is
here (the records are in :mod:`scenespeak.perception.tracks`); the words, their smoothing and
the events are :mod:`scenespeak.spatial.memory`; :mod:`scenespeak.live.stream` joins them.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.calibration import StereoRig
from scenespeak.perception.objects import SceneObject, project_to_plane
from scenespeak.perception.stereo import Points3D
from scenespeak.perception.tracks import (
    FrameObjects,
    Keyframe,
    Track,
    TrackingOptions,
    Where,
    _box,
    _gray,
    _hue_hist,
    _moved_object,
    _State,
)

__all__ = ["Describe", "FrameObjects", "ObjectTracker", "Track", "TrackingOptions", "Where"]

#: The full chain on one stereo pair (left, right) → its keyframe result.
Describe = Callable[[NDArray[np.generic], NDArray[np.generic]], Keyframe]


class ObjectTracker:
    """Follow the objects of a stereo stream; see the module docstring.

    Parameters
    ----------
    rig : StereoRig
        The calibration of every frame.
    describe : callable
        ``describe(left, right)``: the full chain on a keyframe (called from the thread that
        calls :meth:`update`); :func:`scenespeak.pipeline.keyframe_describer` makes the
        pipeline's (the CLI's options without unknown objects: clusters of unlabelled points
        are not stable enough to keep an id).
    options : TrackingOptions, optional
    """

    def __init__(
        self, rig: StereoRig, describe: Describe, options: TrackingOptions | None = None
    ) -> None:
        from scenespeak.perception.calibration import rectify

        self.rig = rig
        self.describe = describe
        self.options = options or TrackingOptions()
        self.rect = rectify(rig)
        self.up = np.asarray(rig.up, dtype=np.float64)
        self._states: dict[int, _State] = {}
        self._next_id = 1
        self._frame = -1
        self._last_key = -(10**9)
        self._prev_gray: NDArray[np.uint8] | None = None
        self._key_small: NDArray[np.uint8] | None = None
        self._size: tuple[int, int] | None = None

    # ---------------------------------------------------------------------------------------
    def update(self, left: NDArray[np.generic], right: NDArray[np.generic]) -> FrameObjects:
        """Process the next frame; return every track.

        Raises
        ------
        ImageError
            From the full chain, for a pair it cannot use (different sizes, no texture). The
            tracker's state is left as it was, so the stream can go on with the next frame.
        """
        self._frame += 1
        k = self._frame
        timings: dict[str, float] = {}
        gl, gr = _gray(left), _gray(right)
        h, w = gl.shape
        from scenespeak.errors import ImageError

        if gr.shape != gl.shape:  # checked before optical flow, which would assert in OpenCV
            raise ImageError(
                "frame", f"the right image is {gr.shape[1]}x{gr.shape[0]}, the left {w}x{h}"
            )
        if self._size is not None and self._size != (w, h):
            raise ImageError(
                "frame", f"is {w}x{h}, the stream's frames are {self._size[0]}x{self._size[1]}"
            )
        t0 = time.perf_counter()
        reason = self._track(gl, gr, k) if self._prev_gray is not None else "first frame"
        timings["track"] = time.perf_counter() - t0
        description = None
        if reason:
            t0 = time.perf_counter()
            description = self.describe(left, right)
            timings["recognise"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            self._recognised(description, left, gl, gr, k)
            self._last_key = k
            small = cv2.resize(gl, (w // 4, h // 4), interpolation=cv2.INTER_AREA)
            self._key_small = np.asarray(small, dtype=np.uint8)
            timings["match"] = time.perf_counter() - t0
        self._size = (w, h)
        self._prev_gray = gl
        self._explain_unseen(k, w, h)
        tracks = tuple(s.track for s in sorted(self._states.values(), key=lambda s: s.track.id))
        return FrameObjects(k, tracks, bool(reason), reason, description, timings)

    def forget(self, track_id: int) -> None:
        """Drop a track (the working memory forgot it)."""
        self._states.pop(track_id, None)

    # ---------------------------------------------------------------------------------------
    def _track(self, gl: NDArray[np.uint8], gr: NDArray[np.uint8], k: int) -> str:
        """Follow every seen track into this frame; return why to recognise ("" = no need)."""
        opts = self.options
        seen = [s for s in self._states.values() if s.track.where == "seen"]
        lost = False
        if seen:
            pts = np.concatenate([s.left_xy[s.alive] for s in seen]).reshape(-1, 1, 2)
            rpts = np.concatenate([s.right_xy[s.alive] for s in seen]).reshape(-1, 1, 2)
            new_l, new_r, ok = self._flow(gl, gr, pts, rpts)
            start = 0
            flows = []
            for s in seen:
                n = int(s.alive.sum())
                idx = np.flatnonzero(s.alive)
                sl = slice(start, start + n)
                start += n
                good = ok[sl]
                if good.any():
                    flows.append(np.median(new_l[sl][good] - s.left_xy[idx][good], axis=0))
                s.left_xy[idx] = new_l[sl]
                s.right_xy[idx] = new_r[sl]
                s.alive[idx] = good
                if self._move(s, k) is None:
                    lost = True
            self._follow_camera(flows)
        if lost:
            return "track lost"
        if k - self._last_key >= opts.keyframe_every:
            return f"every {opts.keyframe_every} frames"
        if self._changed(gl):
            return "scene changed"
        return ""

    def _flow(
        self,
        gl: NDArray[np.uint8],
        gr: NDArray[np.uint8],
        pts: NDArray[np.float32],
        rpts: NDArray[np.float32],
    ) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.bool_]]:
        """Left points into this frame (forward–backward checked) and into the right image."""
        opts = self.options
        win = (opts.window, opts.window)
        crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03)
        assert self._prev_gray is not None
        fwd, st1, _ = cv2.calcOpticalFlowPyrLK(
            self._prev_gray, gl, pts, pts.copy(), winSize=win, maxLevel=3, criteria=crit
        )
        back, st2, _ = cv2.calcOpticalFlowPyrLK(
            gl, self._prev_gray, fwd, fwd.copy(), winSize=win, maxLevel=3, criteria=crit
        )
        fb = np.linalg.norm((back - pts).reshape(-1, 2), axis=1)
        guess = (rpts + (fwd - pts)).astype(np.float32)
        rnew, st3, _ = cv2.calcOpticalFlowPyrLK(
            gl,
            gr,
            fwd,
            guess.copy(),
            winSize=win,
            maxLevel=2,
            criteria=crit,
            flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
        )
        fl, fr = fwd.reshape(-1, 2), rnew.reshape(-1, 2)
        rows = np.abs(
            self.rect.rectify_points(fl, "left")[:, 1] - self.rect.rectify_points(fr, "right")[:, 1]
        )
        h, w = gl.shape
        inside = (fl[:, 0] >= 0) & (fl[:, 0] < w) & (fl[:, 1] >= 0) & (fl[:, 1] < h)
        ok = (st1.ravel() == 1) & (st2.ravel() == 1) & (st3.ravel() == 1) & (fb < opts.max_fb_error)
        ok &= (rows < opts.max_row_error) & inside
        return fl.astype(np.float32), fr.astype(np.float32), ok

    def _triangulate(
        self, left_xy: NDArray[np.float32], right_xy: NDArray[np.float32]
    ) -> NDArray[np.float64]:
        from scenespeak.perception.stereo import triangulate

        rect = self.rect
        return triangulate(
            rect.rectify_points(left_xy, "left"), rect.rectify_points(right_xy, "right"), rect
        )

    def _move(self, s: _State, k: int) -> NDArray[np.float64] | None:
        """Move a track by its points' median displacement; None when it is lost."""
        opts = self.options
        idx = np.flatnonzero(s.alive)
        xyz = self._triangulate(s.left_xy[idx], s.right_xy[idx])
        good = np.isfinite(xyz).all(axis=1)
        if good.any():
            z = float(s.key_obj.centroid[2] + np.median((xyz - s.key_xyz[idx])[good, 2]))
            good &= np.abs(xyz[:, 2] - z) < opts.depth_gate + 0.5 * np.ptp(s.key_xyz[:, 2])
        s.alive[idx[~good]] = False
        n = int(good.sum())
        if n < max(opts.min_points, opts.min_survival * s.n_key):
            s.track = replace(s.track, where="hidden", source="remembered", tracked_points=n)
            return None
        t = np.median(xyz[good] - s.key_xyz[idx[good]], axis=0)
        flow = np.median(s.left_xy[idx[good]] - s.key_left[idx[good]], axis=0).astype(np.float64)
        outline = s.key_outline + flow
        s.track = replace(
            s.track,
            obj=_moved_object(s.key_obj, t, self.up),
            where="seen",
            source="tracked",
            last_seen=k,
            box=_box(outline),
            outline=outline,
            behind=None,
            tracked_points=n,
        )
        return np.asarray(t, dtype=np.float64)

    def _follow_camera(self, flows: list[NDArray[np.float32]]) -> None:
        """Move the unseen tracks with the camera when it turned.

        When at least two tracks were followed and all moved alike in the image (within 8 px
        of their median, and more than 1 px), the camera turned about up: the unseen tracks'
        boxes move by that image motion and their points turn by ``atan(dx / f)`` about up.
        """
        if len(flows) < 2:
            return
        f = np.asarray(flows, dtype=np.float64)
        med = np.median(f, axis=0)
        if np.abs(f - med).max() > 8.0 or np.linalg.norm(med) < 1.0:
            return
        axis = -self.up / np.linalg.norm(self.up)
        rot, _ = cv2.Rodrigues(axis * np.arctan2(med[0], self.rect.focal))
        for s in self._states.values():
            t = s.track
            if t.where == "seen":
                continue
            o = t.obj
            xyz = o.xyz @ rot.T
            turned = _moved_object(o, np.zeros(3), self.up)
            turned = replace(
                turned,
                xyz=xyz,
                plane_xy=project_to_plane(xyz, self.up),
                centroid=xyz.mean(axis=0),
            )
            from scenespeak.perception.objects import convex_hull

            hull = convex_hull(turned.plane_xy).polygon
            outline = t.outline + med
            s.track = replace(t, obj=replace(turned, hull=hull), outline=outline, box=_box(outline))

    def _changed(self, gl: NDArray[np.uint8]) -> bool:
        """Whether the image outside the tracked boxes changed since the last keyframe."""
        if self._key_small is None:
            return False
        opts = self.options
        h, w = gl.shape
        small = cv2.resize(gl, (w // 4, h // 4), interpolation=cv2.INTER_AREA)
        diff = cv2.absdiff(small, self._key_small) > opts.change_level
        keep = np.ones_like(diff)
        for s in self._states.values():
            for box in (s.track.box, _box(s.key_outline)):
                x0, y0, x1, y1 = (int(v / 4) for v in box)
                keep[max(y0 - 3, 0) : y1 + 4, max(x0 - 3, 0) : x1 + 4] = False
        return bool((diff & keep).mean() > opts.change_fraction)

    # ---------------------------------------------------------------------------------------
    def _recognised(
        self,
        description: Keyframe,
        color: NDArray[np.generic],
        gl: NDArray[np.uint8],
        gr: NDArray[np.uint8],
        k: int,
    ) -> None:
        """Match a keyframe's objects to the tracks and seed their points afresh."""
        objs, outlines, masks, hists = _keyframe_objects(description, color, gl.shape)
        states = list(self._states.values())
        matched = _assign(objs, hists, states, self.options.match_distance)
        pts = description.points
        labels = np.array(["" if v is None else v for v in description.point_labels], dtype=object)
        for i, o in enumerate(objs):
            if i in matched:
                tid = states[matched[i]].track.id
            else:
                tid, self._next_id = self._next_id, self._next_id + 1
            seeded = self._seed(o, masks[i], pts, labels, gl, gr)
            if seeded is not None:
                self._states[tid] = _new_state(tid, o, outlines[o.label], seeded, hists[i], k)
        matched_ids = {states[c].track.id for c in matched.values()}
        for s in states:
            if s.track.id not in matched_ids and s.track.last_seen != k:
                s.track = replace(s.track, where="hidden", source="remembered")

    def _seed(
        self,
        o: SceneObject,
        mask: NDArray[np.uint8],
        pts: Points3D,
        labels: NDArray[np.object_],
        gl: NDArray[np.uint8],
        gr: NDArray[np.uint8],
    ) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float64]] | None:
        """Points to track on one object: its labelled stereo keypoints plus corners in its
        outline, found in the right image by flow from the object's median disparity."""
        sel = labels == o.label
        kl = np.asarray(pts.left_xy, np.float32)[sel]
        kr = np.asarray(pts.right_xy, np.float32)[sel]
        shift = np.median(kl - kr, axis=0) if len(kl) else np.array([0.0, 0.0], np.float32)
        corners = cv2.goodFeaturesToTrack(gl, self.options.corners, 0.01, 5, mask=mask)
        if corners is not None and len(corners):
            c = corners.reshape(-1, 2).astype(np.float32)
            guess = (c - shift).astype(np.float32).reshape(-1, 1, 2)
            win = (self.options.window, self.options.window)
            cr, st, _ = cv2.calcOpticalFlowPyrLK(
                gl,
                gr,
                c.reshape(-1, 1, 2),
                guess.copy(),
                winSize=win,
                maxLevel=2,
                flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
            )
            good = st.ravel() == 1
            kl = np.vstack([kl, c[good]])
            kr = np.vstack([kr, cr.reshape(-1, 2)[good]])
        if len(kl) < self.options.min_points:
            return None
        xyz = self._triangulate(kl, kr)
        z = float(o.centroid[2])
        ok = np.isfinite(xyz).all(axis=1) & (
            np.abs(xyz[:, 2] - z) < self.options.depth_gate + 0.5 * float(np.ptp(o.xyz[:, 2]))
        )
        if ok.sum() < self.options.min_points:
            return None
        return kl[ok].copy(), kr[ok].copy(), xyz[ok]

    # ---------------------------------------------------------------------------------------
    def _explain_unseen(self, k: int, w: int, h: int) -> None:
        """Say why each unseen track is not seen: out of view, or hidden behind a nearer one."""
        seen = [s.track for s in self._states.values() if s.track.where == "seen"]
        for s in self._states.values():
            t = s.track
            if t.where == "seen":
                continue
            x0, _, x1, _ = t.box
            bw = max(x1 - x0, 1.0)
            inside = (min(x1, w) - max(x0, 0.0)) / bw
            cover, best = None, 0.2
            for o in seen:
                ox0, _, ox1, _ = o.box
                overlap = (min(x1, ox1) - max(x0, ox0)) / bw
                if overlap > best and o.obj.centroid[2] < t.obj.centroid[2]:
                    cover, best = o.id, overlap
            margin = max(0.5 * bw, 0.03 * w)
            near_edge = x0 < margin or x1 > w - margin
            if inside < 0.75 or (cover is None and near_edge):
                s.track = replace(t, where="out of view", behind=None)
            else:
                s.track = replace(t, where="hidden", behind=cover)


def _keyframe_objects(
    description: Keyframe, color: NDArray[np.generic], shape: tuple[int, ...]
) -> tuple[
    list[SceneObject],
    dict[str, NDArray[np.float64]],
    list[NDArray[np.uint8]],
    list[NDArray[np.float32]],
]:
    """A keyframe's recognised objects with their outlines, outline masks and hue histograms."""
    outlines = {d.label: np.asarray(d.outline_in_scene, float) for d in description.detections}
    objs = [o for o in description.objects if o.label in outlines]
    masks = []
    for o in objs:
        m = np.zeros(shape[:2], np.uint8)
        cv2.fillPoly(m, [np.round(outlines[o.label]).astype(np.int32).reshape(-1, 1, 2)], 1)
        masks.append(m)
    return objs, outlines, masks, [_hue_hist(color, m) for m in masks]


def _assign(
    objs: list[SceneObject],
    hists: list[NDArray[np.float32]],
    states: list[_State],
    match_distance: float,
) -> dict[int, int]:
    """Keyframe object index → state index: same label, near the track's position (twice as far
    for an unseen one), similar hue; Hungarian assignment (``linear_sum_assignment``)."""
    from scipy.optimize import linear_sum_assignment

    cost = np.full((len(objs), len(states)), 1e6)
    for i, o in enumerate(objs):
        for j, s in enumerate(states):
            if s.track.label != o.label:
                continue
            d = float(np.linalg.norm(o.centroid - s.track.obj.centroid))
            limit = match_distance * (1.0 if s.track.where == "seen" else 2.0)
            if d > limit:
                continue
            app = float(cv2.compareHist(hists[i], s.hist, cv2.HISTCMP_BHATTACHARYYA))
            cost[i, j] = d / limit + 0.5 * app
    rows, cols = linear_sum_assignment(cost) if objs and states else ((), ())
    return {int(r): int(c) for r, c in zip(rows, cols, strict=True) if cost[r, c] < 1e5}


def _new_state(
    tid: int,
    o: SceneObject,
    outline: NDArray[np.float64],
    seeded: tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float64]],
    hist: NDArray[np.float32],
    k: int,
) -> _State:
    """A track's state as a keyframe recognised it (its points seeded afresh)."""
    lxy, rxy, xyz = seeded
    track = Track(tid, o.label, o, "seen", _box(outline), outline, "recognised", k, None, len(xyz))
    return _State(
        track, o, xyz, lxy, rxy, len(xyz), outline, lxy.copy(), hist, np.ones(len(xyz), bool)
    )
