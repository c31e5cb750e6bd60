"""Clustering of points on the horizontal plane: the paper's radius filter, DBSCAN, unknown groups.

The false-alarm filters of the seed paper (median + fixed radius, :func:`radius_inliers`; the
object-scaled radius, :func:`scaled_radius`), DBSCAN on a k-d tree (Ester et al., KDD 1996,
:func:`dbscan`) with its main cluster (:func:`main_cluster`), and the grouping of points no
known object claims into unknown objects (:func:`cluster_unknown`). Plain arrays in, plain
arrays out; :mod:`scenespeak.perception.objects` builds objects with them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError
from scenespeak.geometry.frames import DEFAULT_UP, project_to_plane

__all__ = [
    "cluster_unknown",
    "dbscan",
    "main_cluster",
    "radius_inliers",
    "real_points",
    "scaled_radius",
]


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


def real_points(values: ArrayLike, name: str, dims: int | None) -> NDArray[np.float64]:
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
    p = real_points(points, "points", None)
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
