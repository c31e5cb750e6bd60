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

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull, QhullError

from scenespeak.errors import InputError
from scenespeak.geometry.frames import (
    DEFAULT_UP,
    heights_along,
    plane_basis,
    project_to_plane,
)

__all__ = [
    "DEFAULT_UP",
    "SLIVER_WIDTH",
    "HullResult",
    "SceneObject",
    "Skipped",
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
        Mean of ``xyz``.
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


def radius_inliers(xy: ArrayLike, radius: float) -> NDArray[np.bool_]:
    """The seed paper's false-alarm filter: keep points within ``radius`` of the median.

    The median is taken per coordinate (the paper's "median X and Z values").

    Examples
    --------
    >>> radius_inliers([[0, 0], [0.01, 0], [0, 0.01], [2, 2]], radius=0.5).tolist()
    [True, True, True, False]
    """
    p = np.asarray(xy, dtype=np.float64)
    if len(p) == 0:
        return np.zeros(0, dtype=bool)
    med = np.median(p, axis=0)
    return np.linalg.norm(p - med, axis=1) <= radius


def _real_points(values: ArrayLike, name: str, dims: int | None) -> NDArray[np.float64]:
    """Points as float64 ``(N, dims)``; complex, text or wrongly shaped input refused."""
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"cannot be read as points ({exc})") from None
    if arr.dtype.kind not in "biuf" or np.iscomplexobj(arr):
        raise InputError(name, f"points must be real numbers, got dtype {arr.dtype}")
    if dims is not None and not (arr.ndim == 2 and arr.shape[1] == dims) and arr.size:
        raise InputError(name, f"expected an (N, {dims}) array of points, got shape {arr.shape}")
    p = arr.astype(np.float64)
    if not np.isfinite(p).all():
        raise InputError(name, "a point is NaN or infinite")
    return p


def scaled_radius(xy: ArrayLike, factor: float = 4.0, floor: float = 0.05) -> float:
    """An outlier radius scaled to the object: ``max(floor, factor × median distance of the
    points from their median)``.

    The seed paper's fixed 0.5 m radius cut a 1.17 m piano keyboard (Middlebury) to 0.99 m and
    keeps a stray match 40 cm from a 6 cm can. For points spread evenly along a segment of
    length L the median distance is L/4, so ``factor = 4`` keeps the whole segment (radius L)
    and a compact object's radius shrinks with it (robust: the median, not the spread, sets
    it, so up to half of the points can be outliers).

    Examples
    --------
    >>> keys = np.c_[np.linspace(-0.585, 0.585, 200), np.zeros(200)]
    >>> bool(radius_inliers(keys, scaled_radius(keys)).all())  # the whole 1.17 m keyboard
    True
    >>> can = np.r_[np.random.default_rng(0).normal(0, 0.015, (40, 2)), [[0.4, 0.0]]]
    >>> radius_inliers(can, scaled_radius(can))[-1]  # a stray point 40 cm from a can
    np.False_
    """
    p = np.asarray(xy, dtype=np.float64)
    if len(p) == 0:
        return float(floor)
    med = np.median(p, axis=0)
    return max(float(floor), float(factor) * float(np.median(np.linalg.norm(p - med, axis=1))))


def _radius_keep(xy: NDArray[np.float64], radius: float | None) -> NDArray[np.bool_]:
    """The radius filter with a fixed radius, or scaled to the object (``None``)."""
    return radius_inliers(xy, scaled_radius(xy) if radius is None else radius)


def dbscan(points: ArrayLike, eps: float, min_samples: int = 3) -> NDArray[np.intp]:
    """DBSCAN (Ester et al. 1996) on a k-d tree: cluster number per point, -1 for noise.

    The same algorithm and parameters as :class:`sklearn.cluster.DBSCAN` (Euclidean distance,
    neighbourhoods ``<= eps`` including the point itself, core points with at least
    ``min_samples`` neighbours): clusters are the connected groups of core points, a border
    point joins the cluster of its nearest core point. Built on SciPy's ``cKDTree`` because
    importing ``sklearn.cluster`` alone takes about 2 s, more than describing a whole scene;
    the tests check the result against scikit-learn's.

    Clusters are numbered in the order of their first core point.

    Examples
    --------
    >>> dbscan([[0, 0], [0.01, 0], [0.02, 0], [1, 1]], eps=0.015, min_samples=2).tolist()
    [0, 0, 0, -1]
    """
    p = _real_points(points, "points", None)
    if p.ndim != 2 and p.size:
        raise InputError("points", f"expected an (N, D) array of points, got shape {p.shape}")
    if isinstance(eps, bool) or not isinstance(eps, int | float | np.integer | np.floating):
        raise InputError("eps", f"must be a positive distance, got {eps!r}")
    if not (np.isfinite(eps) and eps > 0):
        raise InputError("eps", f"must be a positive finite distance, got {eps}")
    n = len(p)
    labels = np.full(n, -1, dtype=np.intp)
    if n == 0:
        return labels
    if n <= _DENSE_DBSCAN_MAX:
        return _dbscan_dense(p.reshape(n, -1), eps, min_samples)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    tree = cKDTree(p)
    counts = np.asarray(tree.query_ball_point(p, eps, return_length=True))
    core = counts >= min_samples
    if not core.any():
        return labels
    pairs = tree.query_pairs(eps, output_type="ndarray")
    both = core[pairs[:, 0]] & core[pairs[:, 1]] if len(pairs) else np.zeros(0, bool)
    cc = pairs[both]
    graph = coo_matrix((np.ones(len(cc), np.int8), (cc[:, 0], cc[:, 1])), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    core_idx = np.flatnonzero(core)
    # number the clusters by their first core point
    _, first = np.unique(comp[core_idx], return_index=True)
    order = np.argsort(core_idx[first])
    remap = np.empty(len(first), dtype=np.intp)
    remap[order] = np.arange(len(first))
    uniq = np.unique(comp[core_idx])
    labels[core_idx] = remap[np.searchsorted(uniq, comp[core_idx])]
    border = np.flatnonzero(~core)
    if len(border):
        core_tree = cKDTree(p[core_idx])
        dist, nearest = core_tree.query(p[border], k=1, distance_upper_bound=eps * (1 + 1e-12))
        ok = np.isfinite(dist)
        labels[border[ok]] = labels[core_idx[nearest[ok]]]
    return labels


#: Up to this many points :func:`dbscan` works on the full distance matrix (a few MB); the
#: k-d tree and sparse-graph path costs ~1 ms of fixed overhead per call, more than the whole
#: dense computation for the few hundred points of an object.
_DENSE_DBSCAN_MAX = 1200


def _dbscan_dense(p: NDArray[np.float64], eps: float, min_samples: int) -> NDArray[np.intp]:
    """:func:`dbscan` on the full matrix of squared distances (for small point sets)."""
    from scipy.spatial.distance import cdist

    n = len(p)
    labels = np.full(n, -1, dtype=np.intp)
    # SciPy's C loop: the same sums of squared coordinate differences, in the same order, as
    # NumPy broadcasting would give (bit for bit), without its (n, n) temporaries
    d2 = cdist(p, p, "sqeuclidean")
    near = d2 <= eps * eps
    core = np.count_nonzero(near, axis=1) >= min_samples
    core_idx = np.flatnonzero(core)
    m = len(core_idx)
    if m == 0:
        return labels
    adj = near[core_idx][:, core_idx]
    # connected components of the core points, breadth first from the lowest unvisited index,
    # so the clusters come numbered by their first core point
    comp = np.full(m, -1, dtype=np.intp)
    k = 0
    while True:
        rest = np.flatnonzero(comp < 0)
        if len(rest) == 0:
            break
        frontier = rest[:1]
        comp[frontier] = k
        while len(frontier):
            frontier = np.flatnonzero(adj[frontier].any(axis=0) & (comp < 0))
            comp[frontier] = k
        k += 1
    labels[core_idx] = comp
    border = np.flatnonzero(~core)
    if len(border):
        dist = np.where(near[np.ix_(border, core_idx)], d2[np.ix_(border, core_idx)], np.inf)
        nearest = dist.argmin(axis=1)
        ok = np.isfinite(dist[np.arange(len(border)), nearest])
        labels[border[ok]] = labels[core_idx[nearest[ok]]]
    return labels


def main_cluster(xy: ArrayLike, eps: float, min_samples: int = 3) -> NDArray[np.bool_]:
    """Keep the largest DBSCAN cluster (density clustering, :func:`dbscan`).

    When DBSCAN finds no cluster at all (every point is noise, e.g. three scattered keypoints),
    all points are kept: the caller decides whether so few points make an object.

    Parameters
    ----------
    xy : (N, D) array_like
        Points (on the plane or in 3-D).
    eps : float
        DBSCAN neighbourhood radius in metres.
    min_samples : int
        DBSCAN core-point size.

    Examples
    --------
    >>> pts = [[0, 0], [0.01, 0], [0.02, 0], [0.0, 0.01], [1, 1], [1.01, 1], [3, 3]]
    >>> main_cluster(pts, eps=0.05, min_samples=2).tolist()
    [True, True, True, True, False, False, False]
    """
    p = np.asarray(xy, dtype=np.float64)
    n = len(p)
    if n == 0:
        return np.zeros(0, dtype=bool)
    if n < min_samples:
        return np.ones(n, dtype=bool)
    labels = dbscan(p, eps=eps, min_samples=min_samples)
    good = labels[labels >= 0]
    if good.size == 0:
        return np.ones(n, dtype=bool)
    counts = np.bincount(good)
    return labels == int(np.argmax(counts))


def cluster_unknown(
    xyz: ArrayLike,
    up: ArrayLike = DEFAULT_UP,
    *,
    eps: float = 0.04,
    min_points: int = 8,
    max_extent: float = 0.6,
    max_distance: float | None = None,
) -> NDArray[np.intp]:
    """Group points no known object claims into unknown objects.

    DBSCAN on the horizontal plane (``eps`` metres, ``min_samples = 3``); clusters with fewer
    than ``min_points`` points (noise), wider than ``max_extent`` metres on the plane (the
    floor, a wall, the table) or, with ``max_distance``, whose median point is farther than that
    from the camera (the background) are dropped.

    Returns
    -------
    (N,) intp
        Cluster number 0..K-1 per point, ordered left to right on the plane; -1 for points in
        no kept cluster.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> a = rng.normal([-0.3, 0, 1.0], 0.01, (20, 3))
    >>> b = rng.normal([0.3, 0, 1.0], 0.01, (20, 3))
    >>> lab = cluster_unknown(np.vstack([a, b, [[0, 0, 3.0]]]))
    >>> sorted(set(lab.tolist()))
    [-1, 0, 1]
    """
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    out = np.full(len(p), -1, dtype=np.intp)
    if len(p) < max(min_points, 3):
        return out
    xy = project_to_plane(p, up)
    raw = dbscan(xy, eps=eps, min_samples=3)
    kept: list[tuple[float, NDArray[np.bool_]]] = []
    for k in range(int(raw.max(initial=-1)) + 1):
        m = raw == k
        if m.sum() < min_points:
            continue
        span = xy[m].max(axis=0) - xy[m].min(axis=0)
        if float(np.max(span)) > max_extent:
            continue
        if max_distance is not None and np.median(np.linalg.norm(p[m], axis=1)) > max_distance:
            continue
        kept.append((float(np.median(xy[m, 0])), m))
    kept.sort(key=lambda t: t[0])
    for i, (_, m) in enumerate(kept):
        out[m] = i
    return out


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
    p = _real_points(xy, "convex_hull", None)
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
    outliers: str = "both",
    radius: float | None = 0.5,
    eps: float = 0.05,
    min_samples: int = 3,
    min_points: int = 3,
    sliver_width: float = SLIVER_WIDTH,
    max_points: int | None = 400,
    seed: int = 0,
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
    outliers : {"both", "radius", "dbscan", "none"}
        ``"radius"``: the paper's median + fixed ``radius``; ``"dbscan"``: keep the main DBSCAN
        cluster (``eps``, ``min_samples``) on the plane; ``"both"``: radius, then DBSCAN.
    radius, eps, min_samples
        Parameters of the two filters (metres, metres, points). ``radius=None`` scales the
        radius to the object (:func:`scaled_radius`) instead of the paper's fixed one.
    min_points : int
        Fewer points than this after outlier removal: the object is skipped (at least 1). With
        the default 3, two points are skipped; with 2, they give a sliver.
    sliver_width : float
        Width of the polygon for degenerate point sets (see :func:`convex_hull`).
    max_points : int or None
        Subsample larger point sets (dense stereo gives thousands) to this many, at random with
        ``seed``, before clustering; the hull and centroid of a surface do not need more.
    seed : int
        Seed of that subsample.

    Returns
    -------
    SceneObject or Skipped
        ``Skipped`` with the reason when too few points remain.
    """
    if outliers not in ("both", "radius", "dbscan", "none"):
        raise ValueError(f"outliers must be 'both', 'radius', 'dbscan' or 'none', not {outliers!r}")
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    finite = np.all(np.isfinite(p), axis=1)
    p = p[finite]
    n_in = len(p)
    if n_in == 0:
        return Skipped(label, "no 3-D points")
    notes: list[str] = []
    if max_points is not None and n_in > max_points:
        rng = np.random.default_rng(seed)
        p = p[np.sort(rng.choice(n_in, size=max_points, replace=False))]
        notes.append(f"{max_points} of {n_in} points used")
    xy = project_to_plane(p, up)
    keep = np.ones(len(p), dtype=bool)
    if outliers in ("both", "radius") and len(p):
        keep &= _radius_keep(xy, radius)
    if outliers in ("both", "dbscan") and keep.sum() > 0:
        idx = np.flatnonzero(keep)
        sub = main_cluster(xy[idx], eps=eps, min_samples=min_samples)
        keep[idx[~sub]] = False
    dropped = int(len(p) - keep.sum())
    if dropped:
        notes.append(f"{dropped} outlier point{'s' if dropped != 1 else ''} removed")
    p, xy = p[keep], xy[keep]
    n = len(p)
    if n < max(1, min_points):
        what = f"only {n} point{'s' if n != 1 else ''}"
        after = " left after outlier removal" if dropped else ""
        need = f" (at least {min_points} needed for a hull)"
        return Skipped(label, f"{what}{after}{need}")
    hull = convex_hull(xy, sliver_width=sliver_width)
    if hull.degenerate is not None:
        notes.append(
            f"degenerate hull ({hull.degenerate}): drawn as a sliver {sliver_width * 100:g} cm wide"
        )
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


def build_objects(
    xyz: ArrayLike,
    labels: Sequence[str | None] | NDArray[np.object_],
    up: ArrayLike = DEFAULT_UP,
    *,
    unknown: bool = True,
    unknown_eps: float = 0.04,
    unknown_min_points: int = 8,
    unknown_max_extent: float = 0.6,
    unknown_max_distance: float | None = None,
    **options: object,
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
        Cluster the unlabelled points into ``"unknown object 1..N"`` (see
        :func:`cluster_unknown` for the other ``unknown_*`` parameters).
    **options
        Passed to :func:`make_object` (``outliers``, ``radius``, ``eps``, ``min_points``, ...).

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
    objects: list[SceneObject] = []
    skipped: list[Skipped] = []
    order = list(dict.fromkeys(v for v in lab if v))
    lab_arr = np.array(lab, dtype=object)
    for name in order:
        result = make_object(name, p[lab_arr == name], up, **options)  # type: ignore[arg-type]
        (objects if isinstance(result, SceneObject) else skipped).append(result)  # type: ignore[arg-type]
    if unknown:
        free = np.flatnonzero(lab_arr == "")
        groups = cluster_unknown(
            p[free],
            up,
            eps=unknown_eps,
            min_points=unknown_min_points,
            max_extent=unknown_max_extent,
            max_distance=unknown_max_distance,
        )
        for k in range(int(groups.max(initial=-1)) + 1):
            name = f"unknown object {k + 1}"
            opts = dict(options)
            opts["source"] = "clustered"
            result = make_object(name, p[free[groups == k]], up, **opts)  # type: ignore[arg-type]
            (objects if isinstance(result, SceneObject) else skipped).append(result)  # type: ignore[arg-type]
    return objects, skipped
