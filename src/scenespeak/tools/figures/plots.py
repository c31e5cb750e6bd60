"""The stage pictures on plain arrays (seed paper Figs. 4, 5 b, 6–8): matches, 3-D points,
hulls in the horizontal plane, force histograms."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError
from scenespeak.geometry.polygons import polygon_centroid
from scenespeak.tools.figures._style import (
    Color,
    FigureStyle,
    _as_image,
    _as_labels,
    _as_points,
    _color_of,
    _is_unlabelled,
    _legend_for,
    _spread,
    label_colors,
)


def plot_matches(
    left: ArrayLike,
    right: ArrayLike,
    left_xy: ArrayLike,
    right_xy: ArrayLike,
    labels: Sequence[str | None] | NDArray[Any] | None = None,
    *,
    max_lines: int = 400,
    style: FigureStyle | None = None,
    **overrides: object,
) -> Figure:
    """Draw the stereo matches: both images side by side, one line per match.

    Lines are coloured by object label; matches that belong to no object are grey. The more
    nearly horizontal and short a line, the farther the point (small disparity).

    Parameters
    ----------
    left, right : (H, W[, 3]) arrays
        The images, as given to the pipeline (uint8, or floats in [0, 1]).
    left_xy, right_xy : (N, 2) arrays
        Matched pixel positions (column, row) in each image.
    labels : sequence of str or None, optional
        One label per match (``None`` = no object).
    max_lines : int
        At most this many lines are drawn (spread evenly over the matches) so the picture stays
        readable; all points are still counted in the title.
    style : FigureStyle, optional
        ``colors`` (by default :func:`label_colors` of ``labels``), ``title``, ``figsize``
        (default 10 × 4 inches), ``dpi``; also accepted as single keywords (``colors=...``).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((40, 60), np.uint8)
    >>> fig = plot_matches(img, img, [[10, 10]], [[5, 10]], ["mug"])
    >>> fig.axes[0].get_title()
    '1 matches'
    """
    lim = _as_image(left, "left image")
    rim = _as_image(right, "right image")
    lxy = _as_points(left_xy, 2, "left_xy")
    rxy = _as_points(right_xy, 2, "right_xy")
    if len(lxy) != len(rxy):
        raise InputError("matches", f"{len(lxy)} left points but {len(rxy)} right points")
    labs = _as_labels(labels, len(lxy), "labels")
    st = FigureStyle.with_overrides(style, overrides, "plot_matches")
    colors = label_colors(labs) if st.colors is None else st.colors
    title, figsize, dpi = st.title, st.figsize or (10.0, 4.0), st.dpi

    h = max(lim.shape[0], rim.shape[0])
    canvas = np.full((h, lim.shape[1] + rim.shape[1], 3), 255, np.uint8)
    canvas[: lim.shape[0], : lim.shape[1]] = lim
    canvas[: rim.shape[0], lim.shape[1] :] = rim
    offset = float(lim.shape[1])

    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    ax = fig.add_subplot()
    ax.imshow(canvas, interpolation="antialiased")
    keep = _spread(len(lxy), max_lines)
    # Draw the grey (unlabelled) lines first, the objects' on top.
    order = sorted(keep.tolist(), key=lambda i: not _is_unlabelled(labs[i]))
    if order:
        from matplotlib.collections import LineCollection

        segs = [[(lxy[i, 0], lxy[i, 1]), (rxy[i, 0] + offset, rxy[i, 1])] for i in order]
        cols = [_color_of(labs[i], colors) for i in order]
        ax.add_collection(LineCollection(segs, colors=cols, linewidths=0.8, alpha=0.9))
        ends = np.array([s[0] for s in segs] + [s[1] for s in segs])
        ax.scatter(ends[:, 0], ends[:, 1], s=4, c=cols + cols, linewidths=0)
    ax.set_xlim(0, canvas.shape[1])
    ax.set_ylim(canvas.shape[0], 0)
    ax.set_axis_off()
    ax.set_title(f"{len(lxy)} matches" + (f" ({len(keep)} drawn)" if len(keep) < len(lxy) else ""))
    _legend_for(ax, colors, labs, loc="lower right")
    if title:
        fig.suptitle(title)
    return fig


def plot_points_3d(
    xyz: ArrayLike,
    labels: Sequence[str | None] | NDArray[Any] | None = None,
    *,
    up: ArrayLike = (0.0, -1.0, 0.0),
    elev: float = 22.0,
    azim: float = -60.0,
    style: FigureStyle | None = None,
    **overrides: object,
) -> Figure:
    """Draw the 3-D keypoints and their projections onto the horizontal and vertical planes.

    As in the seed paper's Fig. 5 (b): the points in their object colour, their shadows on the
    floor (horizontal plane, cyan) and on the back wall (vertical plane facing the camera, red).
    Axes are the horizontal plane's frame of docs/interfaces.md: x to the camera's right, y forward
    (depth), z up; the camera sits at the origin.

    Parameters
    ----------
    xyz : (N, 3) array
        Points in the left camera's OpenCV frame (metres).
    labels : sequence of str or None, optional
        One label per point.
    up : 3-vector
        The world's up direction in the camera frame (default: level rig).
    elev, azim : float
        Viewing angles (degrees).
    style : FigureStyle, optional
        ``colors``, ``title``, ``figsize`` (default 6.5 × 5.5 inches), ``dpi``; also accepted
        as single keywords.

    Returns
    -------
    matplotlib.figure.Figure
    """
    pts = _as_points(xyz, 3, "xyz")
    labs = _as_labels(labels, len(pts), "labels")
    st = FigureStyle.with_overrides(style, overrides, "plot_points_3d")
    colors = label_colors(labs) if st.colors is None else st.colors
    title, figsize, dpi = st.title, st.figsize or (6.5, 5.5), st.dpi
    from scenespeak.perception.objects import plane_basis

    world = pts @ plane_basis(up).T

    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    ax = fig.add_subplot(projection="3d")
    if len(world):
        finite = np.isfinite(world).all(axis=1)
        world = world[finite]
        labs = [labs[k] for k in np.flatnonzero(finite).tolist()]
    if len(world):
        lo, hi = world.min(axis=0), world.max(axis=0)
        pad = 0.1 * np.maximum(hi - lo, 0.05)
        lo, hi = lo - pad, hi + pad
        lo[1] = min(lo[1], 0.0)  # show the camera (origin) in depth
        floor, wall = lo[2], hi[1]
        cols = [_color_of(lab, colors) for lab in labs]
        ax.scatter(world[:, 0], world[:, 1], np.full(len(world), floor), s=3, c="c", alpha=0.5)
        ax.scatter(world[:, 0], np.full(len(world), wall), world[:, 2], s=3, c="r", alpha=0.5)
        ax.scatter(world[:, 0], world[:, 1], world[:, 2], s=8, c=cols, depthshade=False)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
    ax.scatter([0.0], [0.0], [0.0], marker="^", s=60, c="k")
    ax.text(0.0, 0.0, 0.0, " camera", fontsize="small")
    ax.set_xlabel("x, right (m)")
    ax.set_ylabel("y, depth (m)")
    ax.set_zlabel("z, up (m)")
    ax.view_init(elev=elev, azim=azim)
    ax.set_title(f"{len(world)} 3-D points; horizontal (cyan) and vertical (red) projections")
    _legend_for(ax, colors, labs, loc="upper left")
    if title:
        fig.suptitle(title)
    return fig


def plot_hulls(
    hulls: Mapping[str, ArrayLike],
    points: Mapping[str, ArrayLike] | None = None,
    *,
    colors: Mapping[str, Color] | None = None,
    truth: Mapping[str, ArrayLike] | None = None,
    hfov_deg: float | None = None,
    title: str | None = None,
    figsize: tuple[float, float] = (5.5, 5.5),
    dpi: float = 100.0,
) -> Figure:
    """Draw the objects' convex hulls in the horizontal plane, camera at the origin.

    Parameters
    ----------
    hulls : mapping
        ``label -> (M, 2)`` polygon in the horizontal plane's frame (x right, y depth), metres.
    points : mapping, optional
        ``label -> (N, 2)`` keypoint projections to scatter under the hulls (paper Fig. 8 d).
    colors : mapping, optional
        ``label -> colour``.
    truth : mapping, optional
        ``label -> (K, 2)`` true footprints (from a generated scene), drawn dashed.
    hfov_deg : float, optional
        The camera's horizontal field of view; if given, its edges are drawn.
    title : str, optional
        Figure title.
    figsize, dpi
        Figure size and resolution.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> square = [[0, 1], [0.2, 1], [0.2, 1.2], [0, 1.2]]
    >>> fig = plot_hulls({"mug": square})
    >>> [t.get_text() for t in fig.axes[0].texts][0]
    'mug'
    """
    polys = {str(k): _as_points(v, 2, f"hull of {k}") for k, v in hulls.items()}
    pts = {str(k): _as_points(v, 2, f"points of {k}") for k, v in (points or {}).items()}
    true = {str(k): _as_points(v, 2, f"footprint of {k}") for k, v in (truth or {}).items()}
    colors = label_colors([*polys, *pts, *true]) if colors is None else colors

    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    ax = fig.add_subplot()
    everything = [np.zeros((1, 2))]
    everything += _draw_plane_points(ax, pts, colors)
    everything += _draw_footprints(ax, true, colors)
    for lab, poly in polys.items():
        if len(poly):
            _draw_hull(ax, lab, poly, _color_of(lab, colors))
            everything.append(poly)
    _frame_plane(ax, np.vstack(everything), hfov_deg)
    ax.set_title(f"Convex hulls in the horizontal plane ({len(polys)} objects)")
    if title:
        fig.suptitle(title)
    return fig


def _draw_plane_points(
    ax: Any, pts: Mapping[str, NDArray[np.float64]], colors: Mapping[str, Color]
) -> list[NDArray[np.float64]]:
    """Scatter each object's plane points; return those drawn (for the axis limits)."""
    drawn = []
    for lab, p in pts.items():
        if len(p):
            ax.scatter(p[:, 0], p[:, 1], s=5, color=_color_of(lab, colors), alpha=0.45)
            drawn.append(p)
    return drawn


def _draw_footprints(
    ax: Any, true: Mapping[str, NDArray[np.float64]], colors: Mapping[str, Color]
) -> list[NDArray[np.float64]]:
    """The true footprints, dashed; return those drawn."""
    from matplotlib.patches import Polygon

    drawn = []
    for lab, poly in true.items():
        if len(poly) >= 2:
            ax.add_patch(
                Polygon(poly, closed=True, fill=False, ls="--", lw=1.0, ec=_color_of(lab, colors))
            )
            drawn.append(poly)
    return drawn


def _draw_hull(ax: Any, lab: str, poly: NDArray[np.float64], col: Color) -> None:
    """One hull, filled (a line for fewer than three vertices), its label above it."""
    from matplotlib.patches import Polygon

    if len(poly) >= 3:
        ax.add_patch(Polygon(poly, closed=True, fc=(*col[:3], 0.3), ec=col, lw=2.0))
    else:
        ax.plot(poly[:, 0], poly[:, 1], "-o", color=col, lw=2.0)
    cx, _ = polygon_centroid(poly)
    ax.annotate(
        lab,
        (cx, float(poly[:, 1].max())),
        textcoords="offset points",
        xytext=(0, 4),
        ha="center",
        va="bottom",
        fontsize="medium",
        weight="bold",
        color=tuple(0.6 * c for c in col[:3]),
        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.75},
    )


def _frame_plane(ax: Any, allp: NDArray[np.float64], hfov_deg: float | None) -> None:
    """Limits around everything drawn and the camera, its field of view, axes and grid."""
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.08 * max(float((hi - lo).max()), 0.1)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(min(lo[1], 0.0) - pad, hi[1] + pad)
    if hfov_deg is not None and 0 < hfov_deg < 180:
        reach = hi[1] + pad
        half = np.radians(hfov_deg) / 2
        for s in (-1, 1):
            ax.plot([0, s * reach * np.tan(half)], [0, reach], color="0.6", lw=0.8, ls=":")
    ax.plot([0], [0], marker="^", ms=10, color="k")
    ax.annotate("camera", (0, 0), textcoords="offset points", xytext=(6, -4), fontsize="small")
    ax.set_aspect("equal", adjustable="box")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.set_xlabel("x, to the camera's right (m)")
    ax.set_ylabel("y, depth (m)")


def plot_histograms(
    f0: ArrayLike,
    f2: ArrayLike,
    *,
    title: str | None = None,
    names: tuple[str, str] = ("F0 (constant forces)", "F2 (gravitational forces)"),
    figsize: tuple[float, float] = (9.0, 3.8),
    dpi: float = 100.0,
) -> Figure:
    """Draw the force histograms F0 and F2 of one pair, polar and linear (paper Fig. 7).

    Bin ``k`` of a histogram of ``n`` values is the direction ``360 * k / n`` degrees in the
    horizontal plane: 0 = right, 90 = behind, 180 = left, 270 = in front. Each histogram is
    scaled to its maximum (F0 and F2 have different units); the linear plot's legend gives the
    maxima.

    Parameters
    ----------
    f0, f2 : (n,) arrays
        The histograms (same length; pass the hybrid F02 as ``f2`` where F2 is undefined).
    title : str, optional
        Figure title, e.g. ``"hat relative to mug"``.
    names : pair of str
        Legend names of the two histograms.
    figsize, dpi
        Figure size and resolution.

    Returns
    -------
    matplotlib.figure.Figure
    """
    h0 = np.asarray(f0, dtype=np.float64).ravel()
    h2 = np.asarray(f2, dtype=np.float64).ravel()
    if h0.size == 0 or h0.shape != h2.shape:
        raise InputError("histograms", f"F0 has {h0.size} values and F2 {h2.size}; need equal > 0")
    n = h0.size
    deg = 360.0 * np.arange(n) / n

    def scaled(h: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
        m = float(np.nanmax(np.abs(h))) if np.isfinite(h).any() else 0.0
        return (np.nan_to_num(h) / m if m > 0 else np.zeros_like(h)), m

    s0, m0 = scaled(h0)
    s2, m2 = scaled(h2)
    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    axp = fig.add_subplot(1, 2, 1, projection="polar")
    axl = fig.add_subplot(1, 2, 2)
    closed = np.append(np.radians(deg), 2 * np.pi)
    axp.plot(closed, np.append(s0, s0[0]), color="#1f77b4", lw=1.6)
    axp.fill(closed, np.append(s0, s0[0]), color="#1f77b4", alpha=0.2)
    axp.plot(closed, np.append(s2, s2[0]), color="#d62728", lw=1.6)
    axp.set_xticks(np.radians([0, 90, 180, 270]))
    axp.set_xticklabels(["0° right", "90° behind", "180° left", "270° front"], fontsize="small")
    axp.set_yticklabels([])
    axp.set_ylim(0, 1.05)
    axl.plot(deg, s0, color="#1f77b4", lw=1.6, label=f"{names[0]}, max {m0:.3g}")
    axl.plot(deg, s2, color="#d62728", lw=1.6, label=f"{names[1]}, max {m2:.3g}")
    axl.set_xlim(0, 360)
    axl.set_ylim(0, 1.08)
    axl.set_xticks([0, 45, 90, 135, 180, 225, 270, 315, 360])
    axl.set_xlabel("direction (degrees): 0 right, 90 behind, 180 left, 270 front")
    axl.set_ylabel("force / maximum")
    axl.grid(True, lw=0.4, alpha=0.5)
    axl.legend(fontsize="small", loc="upper right")
    if title:
        fig.suptitle(title)
    return fig
