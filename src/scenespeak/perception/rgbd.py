"""Stage: a depth image and a segmentation (masks, boxes, outlines) → objects.

Everything works on arrays: a depth image in metres (NaN = no depth, :mod:`.depth`), the
colour camera's :class:`~scenespeak.perception.intrinsics.Intrinsics`, and pixel sets. The
objects come out as :class:`~scenespeak.contract.SpatialObject` (the one contract with the
spatial half) wrapped in :class:`MeasuredObject`, which adds what perception knows about them
(pixels in the mask or box, pixels kept, notes).

1. **Back-projection** (pinhole): pixel ``(u, v)`` with depth ``Z`` is
   ``X = (u - cx) Z / fx``, ``Y = (v - cy) Z / fy`` (Hartley & Zisserman, *Multiple View
   Geometry*, eq. 6.1 inverted).
2. **The object's own surface** (:func:`surface_modes`): a depth sensor's flying pixels (mixed
   foreground/background depths at edges) and a box's background are separated from the
   object by the modes of the pixels' depth histogram. Bins are ``bin_width * Z^2`` wide
   (depth noise of a triangulating sensor grows with ``Z^2``: ``sigma_Z = Z^2 sigma_d / (f b)``,
   Khoshelham & Elberink 2012, eq. 9); a mode is a run of bins that each hold at least
   ``mode_fraction`` of the pixels, so thinly spread flying pixels never join the surface.
   A mask keeps its largest mode and the pixels depth-continuous with it (a face seen at a
   grazing angle, :func:`~scenespeak.perception.surfaces.connected_surface`); a recognised
   outline keeps the nearest mode that holds at least ``box_share`` of the largest one, and
   a box the nearest such mode that spans the box
   (:func:`~scenespeak.perception.surfaces.box_span`), after the support plane's pixels are
   removed (the floor under an object is as near as the object's base).
3. **The support plane and up** (:func:`estimate_support_plane`): RANSAC (Fischler & Bolles
   1981) over a grid sample of the background pixels, among planes whose normal is within
   ``max_tilt_deg`` of the camera's up (a hand-held or robot camera is rarely rolled more),
   refined by least squares (SVD of the inliers); its normal, turned towards the camera, is
   the world's up.
4. **Footprint**: the kept points projected onto the horizontal plane
   (:func:`scenespeak.perception.objects.project_to_plane`), the extreme ``trim`` fraction of
   each plane coordinate dropped (a few noisy pixels must not stretch the hull), then the
   convex hull (Qhull) of the points extreme in their slice (:func:`_hull_candidates`). The centroid
   is the mean of all kept points (the visible surface's centroid).

Image plane (no depth): :func:`image_object` makes the hull of a mask's pixels in the image
frame of the contract (x = column, y = image up = ``height - 1 - row``, pixels).

>>> import numpy as np
>>> from scenespeak.perception.intrinsics import Intrinsics
>>> cam = Intrinsics(500.0, 500.0, 32.0, 24.0, 64, 48)
>>> depth = np.full((48, 64), 2.0, np.float32); depth[10:30, 20:40] = 1.0
>>> ys, xs = np.mgrid[8:32, 18:42]  # a box a little larger than the object
>>> obj = measure_object("mug", "mug", ys.ravel(), xs.ravel(), depth, cam, (0, -1, 0),
...                      surface="nearest")
>>> obj.kept_pixels, obj.pixels, obj.object.centroid.round(3).tolist()
(400, 576, [-0.005, -0.009, 1.0])
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Literal, TypedDict, Unpack

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.contract import SpatialObject
from scenespeak.perception.intrinsics import Intrinsics
from scenespeak.perception.objects import Skipped, convex_hull, plane_basis
from scenespeak.perception.surfaces import box_span, connected_surface, surface_modes

__all__ = [
    "MeasureOptions",
    "MeasuredObject",
    "RGBDOptions",
    "SupportPlane",
    "backproject",
    "box_span",
    "connected_surface",
    "depth_points",
    "estimate_support_plane",
    "image_object",
    "measure_object",
    "surface_modes",
]

Surface = Literal["largest", "nearest", "spanning", "connected"]


@dataclass(frozen=True)
class RGBDOptions:
    """Knobs of the RGB-D stage (defaults are the CLI's).

    Attributes
    ----------
    bin_width : float
        Depth-histogram bin width at 1 m (metres); it grows with ``Z^2``.
    mode_fraction : float
        A bin belongs to a mode when it holds at least this fraction of the pixels (and at
        least 2).
    box_share : float
        A box keeps its nearest mode holding at least this share of the largest mode.
    span_share : float
        ... and (``surface="spanning"``) spanning at least this share of the box's extent
        that the best-spanning such mode spans (:func:`box_span`).
    continuity_deg : float
        ``surface="connected"`` (masks): neighbouring pixels on a surface up to this angle to
        the viewing ray are continuous (:func:`connected_surface`).
    min_pixels : int
        Fewer kept pixels than this: the object is skipped.
    trim : float
        Fraction of the kept points dropped at each end of each plane coordinate before the
        hull (only for objects with more than 200 points).
    height_points : int
        At most this many heights go to the spatial half (an even, fixed subsample).
    plane_threshold : float
        Support-plane inlier distance at 1 m (metres; grows with ``Z^2``, at least this).
    plane_clearance : float
        Box and outline pixels at most this high above the support plane (or 2.5 times the
        plane's spread, if more) are the plane.
    plane_iterations : int
        RANSAC hypotheses.
    plane_min_fraction : float
        The plane must hold at least this fraction of the sampled background pixels.
    plane_stride : int
        Grid step of the pixels sampled for the plane.
    max_tilt_deg : float
        Largest angle between the plane's normal and the camera's up (``[0, -1, 0]``).
    seed : int
        Seed of the RANSAC sampling.
    """

    bin_width: float = 0.01
    mode_fraction: float = 0.003
    box_share: float = 0.3
    span_share: float = 0.8
    continuity_deg: float = 88.0
    min_pixels: int = 20
    trim: float = 0.005
    height_points: int = 400
    plane_threshold: float = 0.01
    plane_clearance: float = 0.015
    plane_iterations: int = 256
    plane_min_fraction: float = 0.15
    plane_stride: int = 4
    max_tilt_deg: float = 65.0
    seed: int = 0


@dataclass(frozen=True, eq=False)
class MeasuredObject:
    """A :class:`SpatialObject` and what perception knows about how it was measured.

    Attributes
    ----------
    object : SpatialObject
        What the spatial half reads (name, label, hull, frame, heights, points, centroid).
    source : str
        ``"mask"``, ``"box"``, ``"database"`` or ``"stereo mask"``; ``"image"`` without depth.
    pixels : int
        Pixels of the mask, box or outline.
    kept_pixels : int
        Pixels kept as the object's own surface (with depth); ``pixels`` in the image plane.
    notes : tuple of str
        What was done that a reader should know.
    kept : (K,) intp or None
        The kept pixels as flat indexes ``row * width + column`` of the depth image, when
        known (so that a farther box can leave them to the nearer object).
    """

    object: SpatialObject
    source: str
    pixels: int
    kept_pixels: int
    notes: tuple[str, ...] = field(default_factory=tuple)
    kept: NDArray[np.intp] | None = None

    @property
    def name(self) -> str:
        return self.object.name

    @property
    def label(self) -> str:
        return self.object.label


@dataclass(frozen=True)
class SupportPlane:
    """The dominant support plane: ``normal . X = offset`` (camera frame, metres).

    ``normal`` is unit length and points to the camera's side (it is the world's up);
    ``inliers`` of ``samples`` sampled pixels lie on it; ``spread`` is the robust standard
    deviation of their distances to it (1.4826 × MAD, metres).
    """

    normal: tuple[float, float, float]
    offset: float
    inliers: int
    samples: int
    spread: float = 0.0

    def height(self, xyz: NDArray[np.float64]) -> NDArray[np.float64]:
        """Height of points above the plane (metres, along the normal)."""
        return np.asarray(xyz, np.float64) @ np.asarray(self.normal) - self.offset


@dataclass(frozen=True)
class MeasureOptions:
    """How :func:`measure_object` reads one region's pixels.

    Attributes
    ----------
    surface : {"largest", "connected", "nearest", "spanning"}
        Which depth mode is the object: the largest; the largest and the pixels
        depth-continuous with it (a mask: :func:`connected_surface`); the nearest substantial
        one (an outline: the wall behind is farther); the nearest substantial one that spans
        the region's extent (a box: :func:`box_span`).
    plane : SupportPlane or None
        Pixels on it are dropped first (for boxes and outlines).
    source : str
        Recorded in :attr:`MeasuredObject.source`.
    rgbd : RGBDOptions
        The stage's options (depth modes, plane clearance, minimum pixels).
    """

    surface: Surface = "largest"
    plane: SupportPlane | None = None
    source: str = "mask"
    rgbd: RGBDOptions = field(default_factory=RGBDOptions)


class MeasureKeywords(TypedDict, total=False):
    """:func:`measure_object`'s ``options`` and earlier keywords (each sets its field)."""

    options: MeasureOptions | RGBDOptions | None
    surface: Surface
    plane: SupportPlane | None
    source: str


def _measure_options(keywords: MeasureKeywords) -> MeasureOptions:
    given = keywords.get("options")
    o = given if isinstance(given, MeasureOptions) else MeasureOptions(rgbd=given or RGBDOptions())
    fields = {k: v for k, v in keywords.items() if k != "options"}
    return replace(o, **fields) if fields else o  # type: ignore[arg-type]


def backproject(us: ArrayLike, vs: ArrayLike, z: ArrayLike, cam: Intrinsics) -> NDArray[np.float64]:
    """Pixels ``(u = column, v = row)`` with depth ``z`` to 3-D points ``(N, 3)``.

    Examples
    --------
    >>> cam = Intrinsics(500.0, 500.0, 320.0, 240.0, 640, 480)
    >>> backproject([320, 820], [240, 240], [1.0, 2.0], cam).tolist()
    [[0.0, 0.0, 1.0], [2.0, 0.0, 2.0]]
    """
    zz = np.asarray(z, np.float64)
    x = (np.asarray(us, np.float64) - cam.cx) * zz / cam.fx
    y = (np.asarray(vs, np.float64) - cam.cy) * zz / cam.fy
    return np.column_stack([x, y, zz])


def depth_points(depth: NDArray[np.floating], cam: Intrinsics) -> NDArray[np.float64]:
    """Every valid pixel of a depth image as a 3-D point ``(N, 3)`` (row-major order)."""
    with np.errstate(invalid="ignore"):
        vs, us = np.nonzero(np.isfinite(depth) & (depth > 0))
    return backproject(us, vs, depth[vs, us], cam)


def _choose_mode(
    modes: list[tuple[float, float, int]], surface: Surface, share: float
) -> tuple[float, float, int]:
    best = max(modes, key=lambda m: m[2])
    if surface == "largest":
        return best
    return next(m for m in modes if m[2] >= share * best[2])


def _spanning_mode(
    modes: list[tuple[float, float, int]],
    ys: NDArray[np.intp],
    xs: NDArray[np.intp],
    z: NDArray[np.float64],
    extent: tuple[int, int, int, int],
    o: RGBDOptions,
) -> tuple[float, float, int]:
    """A box's object: the nearest substantial depth mode that spans the box.

    Substantial: at least ``box_share`` of the largest mode's pixels. Spans: its
    :func:`box_span` is at least ``span_share`` of the best substantial mode's. A nearer
    object reaching into the box (a card in front of a tin) is nearer but spans only part
    of it; the wall behind spans it too but is farther.
    """
    best = max(modes, key=lambda m: m[2])
    cands = [m for m in modes if m[2] >= o.box_share * best[2]]
    spans = []
    for near, far, _ in cands:
        sel = (z >= near) & (z <= far)
        spans.append(box_span(ys[sel], xs[sel], extent))
    top = max(spans)
    return next(m for m, s in zip(cands, spans, strict=True) if s >= o.span_share * top)


def _even(n: int, k: int) -> NDArray[np.intp]:
    """At most ``k`` evenly spread indices of ``range(n)``."""
    if n <= k:
        return np.arange(n)
    return np.linspace(0, n - 1, k).astype(np.intp)


def measure_object(
    name: str,
    label: str,
    ys: NDArray[np.intp],
    xs: NDArray[np.intp],
    depth: NDArray[np.floating],
    cam: Intrinsics,
    up: ArrayLike,
    **keywords: Unpack[MeasureKeywords],
) -> MeasuredObject | Skipped:
    """One object from its pixels (rows ``ys``, columns ``xs``) and the depth image.

    Parameters
    ----------
    name, label : str
        The object's name (distinct in the scene) and label.
    ys, xs : (N,) int arrays
        Its pixels: a mask's, a box's or a recognised outline's.
    depth : (H, W) float
        Metres, NaN where there is no depth.
    cam : Intrinsics
        The depth image's (= the colour image's) camera.
    up : (3,) array_like
        World up in the camera frame.
    **keywords
        ``options``: a :class:`MeasureOptions` or an :class:`RGBDOptions` (the stage's alone);
        the earlier ``surface``, ``plane``, ``source`` set their fields of it.

    Returns
    -------
    MeasuredObject or Skipped
        ``Skipped`` (with the reason) when fewer than ``min_pixels`` pixels remain.
    """
    mo = _measure_options(keywords)
    o, surface, plane, source = mo.rgbd, mo.surface, mo.plane, mo.source
    n_pix = len(ys)
    extent = (
        (int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1)
        if n_pix
        else (0, 0, 0, 0)
    )
    z = np.asarray(depth[ys, xs], dtype=np.float64)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(z) & (z > 0)
    notes: list[str] = []
    ys, xs, z = ys[ok], xs[ok], z[ok]
    if n_pix - len(z):
        notes.append(f"{n_pix - len(z)} of {n_pix} pixels without depth")
    if plane is not None and len(z):
        clearance = max(o.plane_clearance, 2.5 * plane.spread)
        off = plane.height(backproject(xs, ys, z, cam)) > clearance
        if (~off).any():
            notes.append(f"{int((~off).sum())} pixels on the support plane dropped")
        ys, xs, z = ys[off], xs[off], z[off]
    keep, note = _surface_pixels(ys, xs, z, surface, extent, cam, o)
    if note:
        notes.append(note)
        ys, xs, z = ys[keep], xs[keep], z[keep]
    xyz = backproject(xs, ys, z, cam)
    if len(xyz) < o.min_pixels:
        return Skipped(
            name,
            f"only {len(xyz)} of its {n_pix} pixels have depth on the object "
            f"(at least {o.min_pixels} needed)",
        )
    return MeasuredObject(
        _spatial(name, label, xyz, up, o),
        source=source,
        pixels=n_pix,
        kept_pixels=len(xyz),
        notes=tuple(notes),
        kept=ys.astype(np.intp) * depth.shape[1] + xs,
    )


def _surface_pixels(
    ys: NDArray[np.intp],
    xs: NDArray[np.intp],
    z: NDArray[np.float64],
    surface: Surface,
    extent: tuple[int, int, int, int],
    cam: Intrinsics,
    o: RGBDOptions,
) -> tuple[NDArray[np.bool_], str]:
    """Which pixels are the object's own surface, and the note saying what was dropped."""
    modes = surface_modes(z, bin_width=o.bin_width, mode_fraction=o.mode_fraction)
    if not modes:
        return np.ones(len(z), dtype=bool), ""
    if surface == "spanning":
        near, far, _ = _spanning_mode(modes, ys, xs, z, extent, o)
    else:
        near, far, _ = _choose_mode(
            modes, "largest" if surface == "connected" else surface, o.box_share
        )
    keep = (z >= near) & (z <= far)
    joined = 0
    if surface == "connected" and not keep.all():
        grown = connected_surface(
            ys, xs, z, keep, cam, bin_width=o.bin_width, continuity_deg=o.continuity_deg
        )
        joined = int(np.count_nonzero(grown & ~keep))
        keep = grown
    dropped = int(len(z) - keep.sum())
    if not dropped:
        return keep, ""
    extra = f", and {joined} depth-continuous with it" if joined else ""
    return keep, (
        f"{dropped} pixels off the object's surface dropped "
        f"(kept depth {near:.2f}-{far:.2f} m{extra})"
    )


def _hull_candidates(xy: NDArray[np.float64], bins: int = 128) -> NDArray[np.float64]:
    """The points extreme within their slice: per ``bins`` slices along x the lowest and the
    highest y, per slice along y the lowest and the highest x.

    Every convex-hull vertex of the whole set is one of these or within one slice width
    (1/``bins`` of the object's extent, a millimetre for a 13 cm object) of their hull, so the
    hull of a surface of thousands of pixels comes from a few hundred points.
    """
    if len(xy) <= 4 * bins:
        return xy
    # per column: NumPy's axis-0 reductions of an (N, 2) array are ~20x slower than these
    lo = np.array([xy[:, 0].min(), xy[:, 1].min()])
    span = np.maximum(np.array([xy[:, 0].max(), xy[:, 1].max()]) - lo, 1e-12)
    keep = np.zeros(len(xy), dtype=bool)
    for axis in (0, 1):
        b = np.minimum(((xy[:, axis] - lo[axis]) * (bins / span[axis])).astype(np.intp), bins - 1)
        other = xy[:, 1 - axis]
        mn = np.full(bins, np.inf)
        mx = np.full(bins, -np.inf)
        np.minimum.at(mn, b, other)
        np.maximum.at(mx, b, other)
        for ext in (mn, mx):  # one point per slice (depth in whole millimetres ties a lot)
            idx = np.flatnonzero(other == ext[b])
            first = np.full(bins, len(xy))
            np.minimum.at(first, b[idx], idx)  # the first of the tied points in each slice
            keep[first[first < len(xy)]] = True
    return xy[keep]


def _trim_bounds(xy: NDArray[np.float64], trim: float) -> NDArray[np.bool_]:
    """Points within the [trim, 1 - trim] quantiles of both coordinates (all, for few points)."""
    if trim <= 0 or len(xy) <= 200:
        return np.ones(len(xy), dtype=bool)
    sample = xy[_even(len(xy), 2000)]
    k = int(trim * (len(sample) - 1))
    part = np.partition(sample, [k, len(sample) - 1 - k], axis=0)
    lo, hi = part[k], part[len(sample) - 1 - k]
    return (xy[:, 0] >= lo[0]) & (xy[:, 0] <= hi[0]) & (xy[:, 1] >= lo[1]) & (xy[:, 1] <= hi[1])


@lru_cache(maxsize=16)
def _basis(up: tuple[float, ...]) -> NDArray[np.float64]:
    """:func:`scenespeak.perception.objects.plane_basis` (rows x, y, up), once per up."""
    basis = plane_basis(up)
    basis.setflags(write=False)
    return basis


def _spatial(
    name: str, label: str, xyz: NDArray[np.float64], up: ArrayLike, o: RGBDOptions
) -> SpatialObject:
    """The contract object of kept 3-D points: hull on the plane, heights, centroid."""
    basis = _basis(tuple(np.asarray(up, np.float64).tolist()))
    xy = xyz @ basis[:2].T
    xy = xy[_trim_bounds(xy, o.trim)]
    hull = convex_hull(_hull_candidates(xy)).polygon
    heights = xyz[_even(len(xyz), o.height_points)] @ basis[2]
    return SpatialObject(
        name=name,
        label=label,
        hull=hull,
        frame="horizontal",
        heights=heights,
        points=xyz,
        centroid=np.array([xyz[:, 0].mean(), xyz[:, 1].mean(), xyz[:, 2].mean()]),
    )


def image_object(
    name: str,
    label: str,
    ys: NDArray[np.intp],
    xs: NDArray[np.intp],
    height: int,
    *,
    source: str = "image",
    mask: NDArray[np.bool_] | None = None,
) -> MeasuredObject:
    """An object in the image plane: the convex hull of its pixels (x = column, y = image up).

    Examples
    --------
    >>> ys, xs = np.mgrid[10:20, 30:40]
    >>> o = image_object("mug", "mug", ys.ravel(), xs.ravel(), 100)
    >>> o.object.frame, o.object.hull.min(axis=0).tolist(), o.object.hull.max(axis=0).tolist()
    ('image', [30.0, 80.0], [39.0, 89.0])
    """
    pts = np.column_stack([xs, height - 1 - np.asarray(ys)]).astype(np.float64)
    hull = convex_hull(pts, sliver_width=1.0).polygon
    obj = SpatialObject(name=name, label=label, hull=hull, frame="image", mask=mask)
    return MeasuredObject(obj, source=source, pixels=len(ys), kept_pixels=len(ys))


def _ransac_normals(
    p: NDArray[np.float64], iterations: int, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit normals (K, 3) and offsets (K,) of planes through random point triples."""
    idx = rng.integers(0, len(p), size=(iterations, 3))
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    n = np.cross(b - a, c - a)
    norm = np.linalg.norm(n, axis=1)
    good = norm > 1e-9
    n = n[good] / norm[good, None]
    d = np.einsum("ij,ij->i", n, a[good])
    flip = d > 0  # turn the normal towards the camera (the origin is on its positive side)
    n[flip] *= -1.0
    d[flip] *= -1.0
    return n, d


def estimate_support_plane(
    depth: NDArray[np.floating],
    cam: Intrinsics,
    *,
    exclude: NDArray[np.bool_] | None = None,
    up_hint: ArrayLike = (0.0, -1.0, 0.0),
    options: RGBDOptions | None = None,
) -> SupportPlane | None:
    """The dominant support plane (floor, table, shelf) of a depth image, or None.

    RANSAC on a grid sample of the valid pixels outside ``exclude`` (the objects' masks),
    among planes whose normal (turned towards the camera) is within ``max_tilt_deg`` of
    ``up_hint``; inliers within ``plane_threshold * max(1, Z^2)``; refined by a least-squares
    fit (SVD) of the inliers. None when the best plane holds fewer than ``plane_min_fraction``
    of the samples (or fewer than 50 pixels).

    Examples
    --------
    >>> cam = Intrinsics(300.0, 300.0, 80.0, 60.0, 160, 120)
    >>> v, u = np.mgrid[0:120, 0:160].astype(float)
    >>> # a floor 0.5 m below a level camera: Y = 0.5, so Z = 0.5 fy / (v - cy)
    >>> z = np.where(v > 62, 0.5 * 300.0 / np.maximum(v - 60.0, 1e-9), np.nan)
    >>> plane = estimate_support_plane(z.astype(np.float32), cam)
    >>> (np.round(plane.normal, 3) + 0.0).tolist(), round(plane.offset, 3)
    ([0.0, -1.0, 0.0], -0.5)
    """
    o = options or RGBDOptions()
    s = max(1, int(o.plane_stride))
    sub = np.asarray(depth)[::s, ::s]
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(sub) & (sub > 0)
    if exclude is not None:
        valid &= ~np.asarray(exclude, bool)[::s, ::s]
    vs, us = np.nonzero(valid)
    if len(vs) < 50:
        return None
    p = backproject(us * s, vs * s, sub[vs, us], cam)
    tol = o.plane_threshold * np.maximum(1.0, p[:, 2] ** 2)
    rng = np.random.default_rng(o.seed)
    score_idx = rng.choice(len(p), size=min(len(p), 1500), replace=False)
    n, d = _ransac_normals(p, o.plane_iterations, rng)
    hint = np.asarray(up_hint, np.float64)
    hint = hint / np.linalg.norm(hint)
    upright = n @ hint >= np.cos(np.radians(o.max_tilt_deg))
    if not upright.any():
        return None
    n, d = n[upright], d[upright]
    ps = p[score_idx]
    resid = np.abs(ps @ n.T - d[None, :])
    scores = np.count_nonzero(resid <= tol[score_idx, None], axis=0)
    best = int(np.argmax(scores))
    normal, offset = n[best], float(d[best])
    inl = np.abs(p @ normal - offset) <= tol
    spread = 0.0
    for _ in range(3):
        # least squares (SVD) on the inliers, then the inliers again within 3 robust sigmas
        # of the fit (the hypothesis tolerance also takes in a wall's foot at a few metres)
        if inl.sum() < 3:
            return None
        q = p[inl]
        centre = q.mean(axis=0)
        _, _, vt = np.linalg.svd(q - centre, full_matrices=False)
        normal = vt[2] * (1.0 if vt[2] @ centre <= 0 else -1.0)
        offset = float(normal @ centre)
        resid = np.abs(p @ normal - offset)
        spread = 1.4826 * float(np.median(resid[inl]))
        inl = resid <= np.minimum(tol, max(0.004, 3.0 * spread))
    inliers = int(np.count_nonzero(inl))
    if inliers < max(50, o.plane_min_fraction * len(p)) or normal @ hint < np.cos(
        np.radians(o.max_tilt_deg)
    ):
        return None
    nrm = normal + 0.0
    return SupportPlane(
        (float(nrm[0]), float(nrm[1]), float(nrm[2])), offset, inliers, len(p), spread
    )
