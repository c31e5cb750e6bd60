"""Stage: labelled 3-D points → objects on the horizontal plane.

Everything here works on plain arrays: points in the left camera's OpenCV frame (X right, Y
down, Z forward, metres) and a world ``up`` direction in that frame. The horizontal plane's 2-D
frame is fixed in ``docs/interfaces.md``: x = the camera's right direction projected onto the plane,
y = its forward direction projected (depth); a level rig (``up = [0, -1, 0]``) gives (X, Z).

Steps for one object, as in the seed paper (section III/IV) with its "future work" done:

1. project the points onto the horizontal plane (:func:`project_to_plane`), heights along up
   (:func:`heights_along`);
2. remove false alarms: the paper's median + fixed radius (:func:`radius_inliers`) and density
   clustering keeping the main cluster (:func:`main_cluster`, DBSCAN on a k-d tree, :func:`dbscan`);
3. the convex hull through SciPy's Qhull (:func:`convex_hull`), with the degenerate cases
   (one point, two points, collinear points) made into a thin sliver polygon of a documented
   width and reported in the object's ``notes``.

Points no object claims are grouped into "unknown object 1..N" (:func:`cluster_unknown`) with a
minimum size and a maximum extent, so that noise and the floor or a wall do not become objects.

>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> mug = rng.normal([0.1, 0.0, 1.0], 0.02, size=(40, 3))
>>> obj = make_object("mug", mug)
>>> obj.label, obj.n_points, obj.source
('mug', 40, 'keypoints')
>>> bool(np.allclose(obj.centroid, [0.1, 0.0, 1.0], atol=0.01))
True
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull, QhullError

from scenespeak.errors import InputError
from scenespeak.geometry.clustering import (
    cluster_unknown,
    dbscan,
    main_cluster,
    radius_inliers,
    real_points,
    scaled_radius,
)
from scenespeak.geometry.frames import (
    DEFAULT_UP,
    heights_along,
    plane_basis,
    project_to_plane,
)
from scenespeak.overrides import replace_fields

__all__ = [
    "DEFAULT_UP",
    "SLIVER_WIDTH",
    "HullResult",
    "ObjectOptions",
    "SceneObject",
    "Skipped",
    "UnknownOptions",
    "build_objects",
    "cluster_unknown",
    "convex_hull",
    "dbscan",
    "heights_along",
    "main_cluster",
    "make_object",
    "plane_basis",
    "project_to_plane",
    "radius_inliers",
    "scaled_radius",
]

#: Width in metres of the sliver polygon that stands for a degenerate hull (two points,
#: collinear points, or all points at one place). One centimetre: thin enough not to change where
#: the object is, thick enough for the Histogram of Forces to see an area.
SLIVER_WIDTH: float = 0.01


@dataclass(frozen=True, eq=False)
class SceneObject:
    """One object of the scene, ready for the spatial-language stage.

    Attributes
    ----------
    label : str
        The database label, or ``"unknown object N"``.
    xyz : (N, 3) float64
        The object's 3-D points kept after outlier removal (left camera frame, metres).
    plane_xy : (N, 2) float64
        The same points in the horizontal plane's 2-D frame.
    hull : (M, 2) float64
        Convex hull in the horizontal plane, counter-clockwise, M >= 3 (a sliver polygon of
        width :data:`SLIVER_WIDTH` for degenerate point sets; see ``notes``).
    centroid : (3,) float64
        Mean of ``xyz`` (the region stage moves it to the hull's area centroid on the plane,
        :func:`scenespeak.perception.scene_regions.volume_centre`).
    heights : (N,) float64
        Heights of the points along ``up`` (metres; larger is higher).
    n_points : int
        Number of points kept.
    source : str
        Where the points come from: ``"keypoints"`` (matched SIFT keypoints), ``"dense"``
        (dense stereo inside the recognised outline) or ``"clustered"`` (unknown points).
    notes : tuple of str
        What was done that a reader should know (points dropped as outliers, a degenerate hull).
    name : str
        Unique in the scene when several objects share a label ("mug", "mug 2"); empty: the
        label.
    confidence : float
        How sure recognition is of the label, in [0, 1] (1 for unknown objects: sure that
        something is there, not what).
    """

    label: str
    xyz: NDArray[np.float64]
    plane_xy: NDArray[np.float64]
    hull: NDArray[np.float64]
    centroid: NDArray[np.float64]
    heights: NDArray[np.float64]
    n_points: int
    source: str = "keypoints"
    notes: tuple[str, ...] = field(default_factory=tuple)
    name: str = ""
    confidence: float = 1.0

    @property
    def key(self) -> str:
        """The name that tells this object apart in the scene (the label when unique)."""
        return self.name or self.label

    @property
    def plane_centroid(self) -> NDArray[np.float64]:
        """Mean of ``plane_xy``: where the object is on the horizontal plane."""
        return self.plane_xy.mean(axis=0)


@dataclass(frozen=True)
class Skipped:
    """An object that could not be described, and why (e.g. too few points)."""

    label: str
    reason: str


@dataclass(frozen=True, eq=False)
class HullResult:
    """A convex hull and what had to be done to get it.

    Attributes
    ----------
    polygon : (M, 2) float64
        Counter-clockwise vertices, M >= 3.
    degenerate : str or None
        ``None`` for a proper Qhull hull; otherwise ``"point"``, ``"two points"`` or
        ``"collinear"``, in which case ``polygon`` is a sliver of width ``SLIVER_WIDTH``.
    """

    polygon: NDArray[np.float64]
    degenerate: str | None = None


@dataclass(frozen=True)
class ObjectOptions:
    """Knobs of :func:`make_object` (the objects stage; the pipeline's defaults).

    Attributes
    ----------
    outliers : {"both", "radius", "dbscan", "none"}
        ``"radius"``: the paper's median + fixed ``radius``; ``"dbscan"``: keep the main DBSCAN
        cluster (``eps``, ``min_samples``) on the plane; ``"both"``: radius, then DBSCAN.
    radius : float or None
        0.5 m — the seed paper's fixed radius; ``None`` scales the radius to the object
        (:func:`scaled_radius`).
    eps : float
        0.05 m — DBSCAN's neighbourhood radius on the plane.
    min_samples : int
        3 — DBSCAN's core-point count.
    min_points : int
        3 — fewer points than this after outlier removal: the object is skipped (at least 1;
        3 is the fewest for a hull, with 2 two points give a sliver).
    sliver_width : float
        :data:`SLIVER_WIDTH` — width of the polygon for degenerate point sets.
    max_points : int or None
        400 — larger point sets (dense stereo gives thousands) are subsampled to this many at
        random with ``seed`` before clustering; the hull and centroid of a surface need no more.
    seed : int
        0 — seed of that subsample.

    Examples
    --------
    >>> ObjectOptions.with_overrides(None, {"radius": None}).radius is None
    True
    """

    outliers: str = "both"
    radius: float | None = 0.5
    eps: float = 0.05
    min_samples: int = 3
    min_points: int = 3
    sliver_width: float = SLIVER_WIDTH
    max_points: int | None = 400
    seed: int = 0

    def __post_init__(self) -> None:
        if self.outliers not in ("both", "radius", "dbscan", "none"):
            raise ValueError(
                f"outliers must be 'both', 'radius', 'dbscan' or 'none', not {self.outliers!r}"
            )

    @classmethod
    def with_overrides(
        cls, options: ObjectOptions | None, overrides: Mapping[str, object]
    ) -> ObjectOptions:
        """``options`` (or the defaults) with single fields replaced (unknown names refused)."""
        return replace_fields(
            options if options is not None else cls(),
            overrides,
            lambda bad, names: TypeError(f"unknown object options {bad}; the fields are {names}"),
        )


@dataclass(frozen=True)
class UnknownOptions:
    """How :func:`build_objects` groups unclaimed points (see :func:`cluster_unknown`).

    Attributes
    ----------
    eps : float
        0.04 m — DBSCAN radius on the plane.
    min_points : int
        8 — smaller clusters are noise.
    max_extent : float
        0.6 m — wider clusters are the floor, a wall or the table, not an object.
    max_distance : float or None
        Clusters whose median point is farther from the camera are background (None: no limit).
    """

    eps: float = 0.04
    min_points: int = 8
    max_extent: float = 0.6
    max_distance: float | None = None


def _sliver(xy: NDArray[np.float64], width: float) -> NDArray[np.float64]:
    """A thin rectangle around points that lie on one line (or at one place)."""
    c = xy.mean(axis=0)
    d = xy - c
    if len(xy) >= 2 and np.max(np.linalg.norm(d, axis=1)) > 1e-12:
        _, _, vt = np.linalg.svd(d, full_matrices=False)
        axis = vt[0]
    else:
        axis = np.array([1.0, 0.0])
    normal = np.array([-axis[1], axis[0]])
    t = d @ axis
    lo, hi = float(t.min()), float(t.max())
    half = width / 2.0
    if hi - lo < width:  # a point (or points closer than the width): a small square
        mid = (lo + hi) / 2.0
        lo, hi = mid - half, mid + half
    corners = [(lo, -half), (hi, -half), (hi, half), (lo, half)]
    return np.array([c + a * axis + b * normal for a, b in corners])


def _unique_rows(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """``np.unique(p, axis=0)`` for an (N, 2) float array (sorted by x, then y), ~5× faster."""
    q = p[np.lexsort((p[:, 1], p[:, 0]))]
    keep = np.ones(len(q), dtype=bool)
    keep[1:] = np.any(q[1:] != q[:-1], axis=1)
    return q[keep]


def convex_hull(xy: ArrayLike, *, sliver_width: float = SLIVER_WIDTH) -> HullResult:
    """Convex hull of points on the plane through SciPy's Qhull, degenerate cases handled.

    Parameters
    ----------
    xy : (N, 2) array_like
        Points, N >= 1.
    sliver_width : float
        Width of the polygon returned for degenerate sets (metres).

    Returns
    -------
    HullResult
        A counter-clockwise polygon with at least 3 vertices. For one point, two points or
        collinear points (or points closer together than ``sliver_width``) the polygon is a
        rectangle ``sliver_width`` wide along the points' line and ``degenerate`` says which case.

    Raises
    ------
    InputError
        If there are no points, a coordinate is not finite, or the points are not real (N, 2).

    Examples
    --------
    >>> convex_hull([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]]).polygon.shape
    (4, 2)
    >>> h = convex_hull([[0, 0], [1, 0], [2, 0]])
    >>> h.degenerate, h.polygon.shape
    ('collinear', (4, 2))
    """
    p = real_points(xy, "convex_hull", None)
    if p.size and (p.ndim != 2 or p.shape[1] != 2) and not (p.ndim == 1 and p.size == 2):
        raise InputError("convex_hull", f"expected (N, 2) points, got shape {p.shape}")
    p = p.reshape(-1, 2)
    if len(p) == 0:
        raise InputError("convex_hull", "needs at least one point")
    uniq = _unique_rows(p)
    if len(uniq) == 1:
        return HullResult(_sliver(uniq, sliver_width), "point")
    if len(uniq) == 2:
        return HullResult(_sliver(uniq, sliver_width), "two points")
    d = uniq - uniq.mean(axis=0)
    s = np.linalg.svd(d, compute_uv=False)
    # Collinear when the spread across the main line is negligible, relative to its length or in
    # absolute terms (below a micrometre Qhull's joggle would only invent a shape).
    if s[1] <= max(1e-9 * s[0], 1e-6 * np.sqrt(len(uniq))):
        return HullResult(_sliver(uniq, sliver_width), "collinear")
    try:
        hull = ConvexHull(uniq)
    except QhullError:  # pragma: no cover - guarded by the rank test above
        return HullResult(_sliver(uniq, sliver_width), "collinear")
    # In 2-D Qhull gives the vertices in counter-clockwise order.
    return HullResult(uniq[hull.vertices].copy(), None)


def make_object(
    label: str,
    xyz: ArrayLike,
    up: ArrayLike = DEFAULT_UP,
    *,
    source: str = "keypoints",
    options: ObjectOptions | None = None,
    **overrides: object,
) -> SceneObject | Skipped:
    """Make one object from its 3-D points: project, remove outliers, hull.

    Parameters
    ----------
    label : str
        The object's name.
    xyz : (N, 3) array_like
        Its points in the left camera frame (metres).
    up : (3,) array_like
        World up in that frame.
    source : str
        Recorded in :attr:`SceneObject.source`.
    options : ObjectOptions, optional
        Outlier removal, minimum size, sliver width, subsampling (the defaults otherwise).
    **overrides
        Single fields of :class:`ObjectOptions` (``radius=None``, ``outliers="radius"``, ...).

    Returns
    -------
    SceneObject or Skipped
        ``Skipped`` with the reason when too few points remain.
    """
    o = ObjectOptions.with_overrides(options, overrides)
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    n_in = len(p)
    if n_in == 0:
        return Skipped(label, "no 3-D points")
    notes: list[str] = []
    if o.max_points is not None and n_in > o.max_points:
        rng = np.random.default_rng(o.seed)
        p = p[np.sort(rng.choice(n_in, size=o.max_points, replace=False))]
        notes.append(f"{o.max_points} of {n_in} points used")
    xy = project_to_plane(p, up)
    keep = _outlier_keep(xy, o)
    dropped = int(len(p) - keep.sum())
    if dropped:
        notes.append(f"{dropped} outlier point{'s' if dropped != 1 else ''} removed")
    p, xy = p[keep], xy[keep]
    n = len(p)
    if n < max(1, o.min_points):
        what = f"only {n} point{'s' if n != 1 else ''}"
        after = " left after outlier removal" if dropped else ""
        need = f" (at least {o.min_points} needed for a hull)"
        return Skipped(label, f"{what}{after}{need}")
    hull = convex_hull(xy, sliver_width=o.sliver_width)
    if hull.degenerate is not None:
        width = o.sliver_width * 100
        notes.append(f"degenerate hull ({hull.degenerate}): drawn as a sliver {width:g} cm wide")
    return SceneObject(
        label=label,
        xyz=p,
        plane_xy=xy,
        hull=hull.polygon,
        centroid=p.mean(axis=0),
        heights=heights_along(p, up),
        n_points=n,
        source=source,
        notes=tuple(notes),
    )


def _outlier_keep(xy: NDArray[np.float64], o: ObjectOptions) -> NDArray[np.bool_]:
    """The points the outlier filters of ``o.outliers`` keep (radius, then DBSCAN)."""
    keep = np.ones(len(xy), dtype=bool)
    if o.outliers in ("both", "radius") and len(xy):
        keep &= _radius_keep(xy, o.radius)
    if o.outliers in ("both", "dbscan") and keep.sum() > 0:
        idx = np.flatnonzero(keep)
        sub = main_cluster(xy[idx], eps=o.eps, min_samples=o.min_samples)
        keep[idx[~sub]] = False
    return keep


def _radius_keep(xy: NDArray[np.float64], radius: float | None) -> NDArray[np.bool_]:
    """The paper's fixed radius, or one scaled to the object (``radius=None``)."""
    return radius_inliers(xy, scaled_radius(xy) if radius is None else radius)


def build_objects(
    xyz: ArrayLike,
    labels: Sequence[str | None] | NDArray[np.object_],
    up: ArrayLike = DEFAULT_UP,
    *,
    unknown: bool = True,
    unknown_options: UnknownOptions | None = None,
    options: ObjectOptions | None = None,
    **overrides: object,
) -> tuple[list[SceneObject], list[Skipped]]:
    """Objects from labelled 3-D points: one per label, plus clustered unknown objects.

    Parameters
    ----------
    xyz : (N, 3) array_like
        Points in the left camera frame.
    labels : sequence of str or None, length N
        The label of each point; ``None`` (or ``""``) for a point no known object claims.
    up : (3,) array_like
        World up in the camera frame.
    unknown : bool
        Cluster the unlabelled points into ``"unknown object 1..N"``.
    unknown_options : UnknownOptions, optional
        How (:func:`cluster_unknown`); single fields also as ``unknown_eps``,
        ``unknown_min_points``, ``unknown_max_extent``, ``unknown_max_distance``.
    options : ObjectOptions, optional
        Passed to :func:`make_object`.
    **overrides
        Single fields of :class:`ObjectOptions` (``outliers``, ``radius``, ``eps``,
        ``min_points``, ...), ``source`` of the known objects, or the ``unknown_*`` above.

    Returns
    -------
    objects : list of SceneObject
        Known objects in order of first appearance of their label, then unknown objects left
        to right.
    skipped : list of Skipped
        Labels that had points but could not be made into an object, with the reason.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(2)
    >>> hat = rng.normal([-0.2, 0, 1.2], 0.02, (30, 3))
    >>> can = np.array([[0.3, 0, 1.0], [0.31, 0, 1.0]])
    >>> objs, skipped = build_objects(np.vstack([hat, can]), ["hat"] * 30 + ["can"] * 2)
    >>> [o.label for o in objs], skipped[0].reason
    (['hat'], 'only 2 points (at least 3 needed for a hull)')
    """
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    lab = ["" if v is None else str(v) for v in labels]
    if len(lab) != len(p):
        raise ValueError(f"{len(p)} points but {len(lab)} labels")
    rest = dict(overrides)
    source = str(rest.pop("source", "keypoints"))
    grouping = _unknown_options(unknown_options, rest)
    o = ObjectOptions.with_overrides(options, rest)
    found: list[SceneObject | Skipped] = []
    lab_arr = np.array(lab, dtype=object)
    for name in dict.fromkeys(v for v in lab if v):
        found.append(make_object(name, p[lab_arr == name], up, source=source, options=o))
    if unknown:
        free = np.flatnonzero(lab_arr == "")
        groups = cluster_unknown(
            p[free],
            up,
            eps=grouping.eps,
            min_points=grouping.min_points,
            max_extent=grouping.max_extent,
            max_distance=grouping.max_distance,
        )
        for k in range(int(groups.max(initial=-1)) + 1):
            pts = p[free[groups == k]]
            found.append(
                make_object(f"unknown object {k + 1}", pts, up, source="clustered", options=o)
            )
    objects = [f for f in found if isinstance(f, SceneObject)]
    skipped = [f for f in found if isinstance(f, Skipped)]
    return objects, skipped


def _unknown_options(base: UnknownOptions | None, overrides: dict[str, object]) -> UnknownOptions:
    """``base`` with the ``unknown_*`` keywords of ``overrides`` (taken out of it) applied."""
    keys = [k for k in overrides if k.startswith("unknown_")]
    changes = {k.removeprefix("unknown_"): overrides.pop(k) for k in keys}
    out = base if base is not None else UnknownOptions()
    return replace(out, **changes) if changes else out  # type: ignore[arg-type]
