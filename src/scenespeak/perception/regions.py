"""Geometry first: the support plane and the objects standing on it, from dense stereo.

Objects stand on a support surface (a floor, a table). With a dense depth map and the world's
``up`` direction, every object standing on the support is a connected set of pixels above it,
textured or not, cut from its neighbours where the depth jumps (an occlusion boundary).
Appearance then only *names* segments (keypoint votes, :func:`name_segments`); segments nothing
names are unknown objects. Several instances of one object and unknown objects come out of the
same step.

1. :func:`point_map` — 3-D point and height along ``up`` of every pixel with a disparity.
2. :func:`support_plane` — the plane's normal starts as ``up``; its level is the lowest height
   band that holds a real share of the points (objects' feet or a textured floor), then RANSAC
   (Fischler & Bolles 1981) over the points near that level refines normal and offset, with the
   normal kept within ``up_tolerance_deg`` of ``up``.
3. :func:`segment` — pixels at least ``min_height`` above the plane, minus depth-jump edges
   (neighbours whose depths differ by more than ``jump + jump_rel · Z``), in 4-connected
   components of at least ``min_pixels`` pixels.

SGBM (Hirschmüller 2008) gives a plain region the disparity its aggregation paths carry in
from the nearest texture: a plain floor beside an object takes the object's depth along the
rows it spans, so the object's segment grows a band of floor sideways, and two objects on one
row join through it (on tuning-40, 14 of the 26 missed objects sat in such a segment).
:func:`plain_background` marks the pixels that no stereo method can measure and that are not
enclosed by texture — plain regions reaching the image's border, the floor and the sky — and
:func:`segment` leaves them out; a plain face inside an object's textured outline is kept.

>>> import numpy as np
>>> z = np.full((60, 80), np.nan)
>>> z[20:50, 10:30] = 1.0           # a box front at 1 m
>>> z[25:50, 45:70] = 1.6           # another at 1.6 m
>>> heights = np.where(np.isfinite(z), 0.0, np.nan)
>>> heights[20:50, 10:30] = np.linspace(0.3, 0.0, 30)[:, None]
>>> heights[25:50, 45:70] = np.linspace(0.25, 0.0, 25)[:, None]
>>> seg = segment(z, heights, 0.0, RegionOptions(min_pixels=20))
>>> len(seg.sizes), int(seg.labels[30, 20]) != int(seg.labels[30, 60])
(2, True)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.plain import (
    SEGMENT_STRIDE,
    PlainParts,
    plain_background,
    plain_parts,
    plain_pixels,
)

__all__ = [
    "PlainParts",
    "RegionOptions",
    "SceneGeometry",
    "Segments",
    "clean_disparity",
    "components",
    "name_segments",
    "plain_background",
    "plain_parts",
    "plain_pixels",
    "point_map",
    "scene_geometry",
    "segment",
    "support_plane",
]


@dataclass(frozen=True)
class RegionOptions:
    """Knobs of the geometric segmentation (metres unless said otherwise).

    Attributes
    ----------
    min_height : float
        Pixels less than this above the support plane are the support.
    max_height : float
        Pixels higher than this above the support are background (walls, sky).
    band : float
        Height band (bin) of the first estimate of the support's level.
    band_share : float
        The lowest band (above the 0.5th percentile) holding this share of the points is the
        first estimate of the support's level.
    plane_tolerance : float
        RANSAC inlier distance to the plane.
    up_tolerance_deg : float
        The plane's normal stays within this angle of ``up`` (0: it is ``up``, only the level
        is measured; :func:`scene_geometry` uses 0 over a plain floor).
    ransac_iterations : int
        RANSAC samples (seeded; the result is deterministic).
    jump, jump_rel : float
        Depth jump that separates two neighbouring pixels: ``jump + jump_rel · Z``.
    min_pixels : int
        Smaller segments are dropped (noise of the dense map).
    opening : int
        Side of the square that opens the mask before the components (cuts thin bridges).
    max_distance : float
        Points farther than this from the camera are background.
    min_texture : float
        Gray levels per pixel: a pixel whose mean absolute gradient (horizontal plus vertical
        Sobel, / 8) over a ``texture_window`` square is at most this is plain
        (:func:`plain_background`; 0: off). A rendered plain floor gives exactly 0, the
        objects' textures 0.1-20 (medians 0.5-10); a camera's noise makes every pixel
        textured and turns the test off by itself.
    texture_window : int
        Side of that square (pixels of the input image).
    edge_window : int
        The plain background is grown, through pixels plain over this smaller square, up to
        the objects' silhouettes (:func:`plain_background`; 0: not grown). Over
        ``texture_window`` a floor pixel within half its side of an object's edge is textured,
        so every object's segment had a band of floor round it that took the object's depth
        from SGBM: 16-34 % of the segment pixels of a 20-pixel-wide cylinder 1.5-2 m away.
    """

    min_height: float = 0.015
    max_height: float = 1.2
    band: float = 0.01
    band_share: float = 0.01
    plane_tolerance: float = 0.01
    up_tolerance_deg: float = 8.0
    ransac_iterations: int = 120
    jump: float = 0.03
    jump_rel: float = 0.03
    min_pixels: int = 40
    opening: int = 5
    max_distance: float = 3.0
    min_texture: float = 0.1
    texture_window: int = 7
    edge_window: int = 3


@dataclass(frozen=True, eq=False)
class Segments:
    """Objects standing on the support, as pixel segments of the left image.

    Attributes
    ----------
    labels : (h, w) int32
        Segment index per pixel, -1 where none (no depth, support, background, edge).
    sizes : (K,) int64
        Pixels per segment.
    level : float
        Height of the support plane along ``up`` (metres, in the camera frame).
    """

    labels: NDArray[np.int32]
    sizes: NDArray[np.int64]
    level: float

    def mask(self, k: int) -> NDArray[np.bool_]:
        """The pixels of segment ``k``."""
        return self.labels == k


def clean_disparity(
    disparity: NDArray[np.floating], min_disparity: int, num_disparities: int
) -> NDArray[np.float32]:
    """The disparity map without values at the ends of the search range (NaN there).

    Where nothing matches (a white sky, a plain floor), SGBM's winner is often the first or
    last disparity it tried; those pixels passed its checks but carry no depth: on the
    rendered scenes 60-80 % of the map sat exactly at ``min_disparity`` (2.66 m for a scene
    whose objects were 1.2-1.9 m away).

    >>> clean_disparity(np.array([25.0, 25.2, 40.0, 72.0, np.nan]), 25, 48).tolist()
    [nan, nan, 40.0, nan, nan]
    """
    d = np.asarray(disparity, dtype=np.float32)
    lo, hi = float(min_disparity) + 0.5, float(min_disparity + num_disparities) - 1.5
    with np.errstate(invalid="ignore"):
        return np.where((d > lo) & (d < hi), d, np.float32(np.nan)).astype(np.float32)


def point_map(
    xyz: NDArray[np.float64], xy: NDArray[np.float64], shape: tuple[int, int]
) -> NDArray[np.float32]:
    """Scatter 3-D points at their (column, row) pixel positions into an ``(h, w, 3)`` map
    (NaN where no point)."""
    h, w = shape
    out = np.full((h, w, 3), np.nan, np.float32)
    if len(xyz):
        c = np.clip(np.rint(xy[:, 0]).astype(np.intp), 0, w - 1)
        r = np.clip(np.rint(xy[:, 1]).astype(np.intp), 0, h - 1)
        out[r, c] = xyz
    return out


def _plane_from(p: NDArray[np.float64]) -> tuple[NDArray[np.float64], float] | None:
    # The normal is the cross product of the two edges from p[0], as np.cross computes it (the
    # same float64 differences and products, in the same order), without np.cross's ~0.1 ms
    # of overhead per call (120 calls per scene).
    (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = p.tolist()
    a0, a1, a2 = x1 - x0, y1 - y0, z1 - z0
    b0, b1, b2 = x2 - x0, y2 - y0, z2 - z0
    n = np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    norm = float(np.linalg.norm(n))
    if norm < 1e-12:
        return None
    n = n / norm
    return n, float(n @ p[0])


def _level_near(h: NDArray[np.floating], level0: float, tolerance: float) -> float:
    """The median of the heights ``h`` within ``tolerance`` of ``level0`` (``level0`` if none).

    >>> _level_near(np.array([0.0, 0.01, 0.02, 0.5]), 0.01, 0.015)
    0.01
    """
    on = h[np.abs(h - level0) <= tolerance]
    return float(np.median(on)) if len(on) else float(level0)


def support_plane(
    xyz: NDArray[np.float64],
    up: NDArray[np.float64],
    options: RegionOptions | None = None,
    *,
    seed: int = 0,
) -> tuple[NDArray[np.float64], float]:
    """The support plane ``{p : n · p = level}`` with ``n`` near ``up`` (unit, pointing up).

    Returns ``(n, level)``; heights above the support are ``p · n − level``. Without enough
    points the plane is ``(up, lowest height)``.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> floor = np.c_[rng.uniform(-1, 1, 400), np.full(400, 0.25), rng.uniform(1, 3, 400)]
    >>> box = np.c_[rng.uniform(0, 0.2, 300), rng.uniform(0.0, 0.25, 300), np.full(300, 1.5)]
    >>> n, level = support_plane(np.r_[floor, box], np.array([0.0, -1.0, 0.0]))
    >>> (np.round(n, 2) + 0.0).tolist(), round(level, 2)
    ([0.0, -1.0, 0.0], -0.25)
    """
    opts = options or RegionOptions()
    u = np.asarray(up, dtype=np.float64)
    u = u / np.linalg.norm(u)
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) < 3:
        return u, float((p @ u).min()) if len(p) else 0.0
    p = p[np.linalg.norm(p, axis=1) <= opts.max_distance]
    if len(p) < 3:
        return u, 0.0
    h = p @ u
    lo = float(np.percentile(h, 0.5))
    bins = np.floor((h - lo) / opts.band).astype(np.intp)
    counts = np.bincount(np.clip(bins, 0, None))
    # the lowest band with a real share of the points: a textured support, or the feet of the
    # objects standing on a plain one (the fullest band is not it: the faces of five objects
    # put 5-8 % of the points in every centimetre of height)
    first = int(np.flatnonzero(counts >= max(opts.band_share * len(p), 3))[0])
    level0 = lo + (first + 0.5) * opts.band
    near = p[np.abs(h - level0) <= 3 * opts.band]
    if opts.up_tolerance_deg <= 0:  # the normal is up: only the level is measured
        return u, _level_near(h, level0, opts.plane_tolerance)
    best = (u, level0)
    if len(near) >= 3:
        rng = np.random.default_rng(seed)
        cos_tol = np.cos(np.radians(opts.up_tolerance_deg))
        best_count = int((np.abs(near @ u - level0) <= opts.plane_tolerance).sum())
        for _ in range(opts.ransac_iterations):
            fit = _plane_from(near[rng.choice(len(near), 3, replace=False)])
            if fit is None:
                continue
            n, d = fit
            if n @ u < 0:
                n, d = -n, -d
            if n @ u < cos_tol:
                continue
            count = int((np.abs(near @ n - d) <= opts.plane_tolerance).sum())
            if count > best_count:
                best, best_count = (n, d), count
        n, d = best
        inl = near[np.abs(near @ n - d) <= opts.plane_tolerance]
        if len(inl) >= 3:  # least squares on the inliers, normal still near up
            c = inl.mean(axis=0)
            _s, _v, vt = np.linalg.svd(inl - c, full_matrices=False)
            m = vt[-1] if vt[-1] @ u >= 0 else -vt[-1]
            if m @ u >= cos_tol:
                best = (m, float(m @ c))
    return best


def segment(
    depth: NDArray[np.floating],
    heights: NDArray[np.floating],
    level: float,
    options: RegionOptions | None = None,
    background: NDArray[np.bool_] | None = None,
) -> Segments:
    """Segments of the pixels standing on the support, cut where the depth jumps.

    Parameters
    ----------
    depth : (h, w) float
        Distance along the optical axis (Z) per pixel, NaN where unknown.
    heights : (h, w) float
        Height along the plane's normal per pixel (same NaNs).
    level : float
        The support's height (:func:`support_plane`).
    options : RegionOptions, optional
    background : (h, w) bool, optional
        Pixels that belong to no object whatever their depth (:func:`plain_background`).
    """
    opts = options or RegionOptions()
    z = np.asarray(depth, dtype=np.float32)
    above = np.asarray(heights, dtype=np.float32) - np.float32(level)
    with np.errstate(invalid="ignore"):
        keep = (
            np.isfinite(z)
            & (above >= opts.min_height)
            & (above <= opts.max_height)
            & (z <= opts.max_distance)
        )
    if background is not None:
        keep &= ~background
    zz = np.where(keep, z, np.nan)
    limit = opts.jump + opts.jump_rel * np.nan_to_num(zz, nan=0.0)
    edge = np.zeros(z.shape, bool)
    with np.errstate(invalid="ignore"):
        dx = np.abs(np.diff(zz, axis=1)) > np.maximum(limit[:, 1:], limit[:, :-1])
        dy = np.abs(np.diff(zz, axis=0)) > np.maximum(limit[1:], limit[:-1])
    # cut on the far side of each jump: the nearer object keeps its pixels
    far_x = np.nan_to_num(zz[:, 1:]) > np.nan_to_num(zz[:, :-1])
    edge[:, 1:] |= dx & far_x
    edge[:, :-1] |= dx & ~far_x
    far_y = np.nan_to_num(zz[1:]) > np.nan_to_num(zz[:-1])
    edge[1:] |= dy & far_y
    edge[:-1] |= dy & ~far_y
    m = (keep & ~edge).astype(np.uint8)
    if opts.opening > 1:  # thin bridges: SGBM streaks along rows of a plain background
        kernel = np.ones((opts.opening, opts.opening), np.uint8)
        m = np.asarray(cv2.morphologyEx(m, cv2.MORPH_OPEN, kernel), np.uint8)
    return components(m.astype(bool), float(level), opts.min_pixels)


def components(mask: NDArray[np.bool_], level: float, min_pixels: int) -> Segments:
    """4-connected components of ``mask`` with at least ``min_pixels`` pixels."""
    m = np.asarray(mask, dtype=np.uint8)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=4)
    sizes = stats[1:, cv2.CC_STAT_AREA].astype(np.int64)
    big = np.flatnonzero(sizes >= min_pixels)
    remap = np.full(n, -1, np.int32)
    remap[big + 1] = np.arange(len(big), dtype=np.int32)
    return Segments(remap[lab], sizes[big], float(level))


def name_segments(
    segments: Segments,
    votes: list[NDArray[np.float64]],
    *,
    min_votes: int = 2,
    min_share: float = 0.3,
) -> list[int]:
    """The segment each named object stands in: the one holding most of its keypoint votes.

    Parameters
    ----------
    segments : Segments
    votes : list of (K_i, 2) arrays
        Per named object (a recognised detection), the pixel positions of its inlier keypoints.
    min_votes, min_share : int, float
        A segment is the object's when it holds at least ``min_votes`` of its keypoints and at
        least ``min_share`` of them; otherwise ``-1`` (the object keeps its carried outline).

    Examples
    --------
    >>> lab = np.full((10, 10), -1, np.int32); lab[2:6, 2:6] = 0; lab[6:9, 6:9] = 1
    >>> seg = Segments(lab, np.array([16, 9]), 0.0)
    >>> name_segments(seg, [np.array([[3.0, 3], [4, 4], [7, 7]]), np.array([[0.0, 0]])])
    [0, -1]
    """
    h, w = segments.labels.shape
    out: list[int] = []
    for xy in votes:
        if len(xy) == 0:
            out.append(-1)
            continue
        # each keypoint votes with the segments of its 5 x 5 neighbourhood (a keypoint sits on
        # texture; the dense map can have a hole exactly there)
        off = np.arange(-2, 3)
        c = np.rint(xy[:, 0]).astype(np.intp)[:, None, None] + off[None, None, :]
        r = np.rint(xy[:, 1]).astype(np.intp)[:, None, None] + off[None, :, None]
        hit = segments.labels[np.clip(r, 0, h - 1), np.clip(c, 0, w - 1)].reshape(len(xy), -1)
        n_seg = len(segments.sizes)
        if n_seg == 0:
            out.append(-1)
            continue
        per = np.stack([(hit == k).any(axis=1) for k in range(n_seg)], axis=1)  # (K, S)
        counts = per.sum(axis=0)
        k = int(np.argmax(counts))
        ok = counts[k] >= min_votes and counts[k] >= min_share * len(xy)
        out.append(k if ok else -1)
    return out


@dataclass(frozen=True, eq=False)
class SceneGeometry:
    """The scene's support plane, its segments and the dense point map (input left pixels);
    ``textured``: where the plain background (:func:`plain_background`, at least
    :data:`PLAIN_SHARE` of the image) was left out of the segments, the pixels that are not
    plain (:func:`plain_pixels`); None where it was not."""

    normal: NDArray[np.float64]
    level: float
    segments: Segments
    points: NDArray[np.float32]  # (h, w, 3), NaN where no depth
    textured: NDArray[np.bool_] | None = None

    @property
    def plain(self) -> bool:
        """Whether the plain background was left out of the segments."""
        return self.textured is not None


def scene_geometry(
    dense: Any,
    up: NDArray[np.float64],
    shape: tuple[int, int],
    options: RegionOptions,
    stride: int = SEGMENT_STRIDE,
    image: NDArray[np.generic] | None = None,
    plain: Callable[[], PlainParts] | None = None,
) -> SceneGeometry:
    """Clean the dense map, lift it to 3-D, find the support plane and segment.

    The segmentation runs on every ``stride``-th pixel in both directions (a quarter of the
    work at 2) and is read back at full resolution by nearest neighbour: an object 2 m away
    is still 20 pixels wide, 10 on that grid. With the left ``image`` (the dense map's grid:
    no resampling rectification), its plain background (:func:`plain_background`), when it
    covers at least :data:`PLAIN_SHARE` of the image, takes part in no segment and in no
    support plane: SGBM carried its depth in from the objects beside it. The segments also
    leave out the band of floor round each object that only the finer ``edge_window`` sees
    as plain; the support plane keeps those points (on a plain floor the objects' feet and
    the floor just below them are all it has: without them it tilted by 1-2 degrees and cut
    the foot of a cup on tuning-40). ``plain``: a call that returns
    :func:`plain_parts` of ``image`` with these ``shape``, ``options`` and ``stride``, already
    computed elsewhere (the pipeline's other thread).
    """
    from scenespeak.perception import stereo

    h, w = shape
    st = max(int(stride), 1)
    d = clean_disparity(dense.disparity, dense.min_disparity, dense.num_disparities)
    clean = dataclasses.replace(dense, disparity=d)
    grid = np.zeros(shape, bool)
    roi = getattr(dense, "roi", None)
    if roi is not None and dense.rect.maps_left is None:
        # the map is NaN outside the part computed: the grid's points inside it are all
        # there are (the same points, in the same order; 1.6 -> 0.9 ms on the bench scenes)
        x0, y0, x1, y1 = roi
        grid[y0 + (-y0) % st : y1 : st, x0 + (-x0) % st : x1 : st] = True
    else:
        grid[::st, ::st] = True
    xyz, xy = stereo.region_points(clean, grid, max_points=None)
    small_shape = ((h + st - 1) // st, (w + st - 1) // st)
    pm_small = point_map(xyz, xy / st, small_shape)
    made = plain() if plain is not None else plain_parts(image, shape, options, st)
    background, outside, textured = made
    if background is not None:
        sx = np.clip(np.rint(xy[:, 0] / st).astype(np.intp), 0, small_shape[1] - 1)
        sy = np.clip(np.rint(xy[:, 1] / st).astype(np.intp), 0, small_shape[0] - 1)
        measured = ~background[sy, sx]
        if int(measured.sum()) >= 3:
            xyz = xyz[measured]
    # on a plain floor the plane's only points are the objects' feet and the floor right
    # beside them, whose depth SGBM carried in from the objects: a normal fitted to them
    # tilted from up by 1.6 degrees (median) to 7.7 on stress60 and cut the lower part of far
    # objects (5 cm at 1.9 m); there the normal is up and only the level is measured
    plane_opts = (
        options if background is None else dataclasses.replace(options, up_tolerance_deg=0.0)
    )
    n, level = support_plane(xyz[:: max(len(xyz) // 20000, 1)], up, plane_opts)
    with np.errstate(invalid="ignore"):
        heights = pm_small @ n.astype(np.float32)
    small_opts = dataclasses.replace(
        options,
        min_pixels=max(options.min_pixels // (st * st), 1),
        opening=max(options.opening // st, 1) | 1,
    )
    seg = segment(pm_small[..., 2], heights, level, small_opts, outside)
    labels = np.repeat(np.repeat(seg.labels, st, axis=0), st, axis=1)[:h, :w]
    pm = np.repeat(np.repeat(pm_small, st, axis=0), st, axis=1)[:h, :w]
    full = Segments(np.ascontiguousarray(labels), seg.sizes * st * st, seg.level)
    return SceneGeometry(n, level, full, np.ascontiguousarray(pm), textured)
