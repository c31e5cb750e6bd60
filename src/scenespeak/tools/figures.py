"""Pictures of every stage, and a one-page report.

The plotting functions take plain arrays, so they work on any data (yours, or the pipeline's);
each returns a :class:`matplotlib.figure.Figure` built without :mod:`matplotlib.pyplot`, so no
display, no global state, and no backend switch are needed (``Figure.savefig`` renders with
Agg). :func:`write_figures` and :func:`write_report` adapt a whole
:class:`~scenespeak.pipeline.SceneDescription` (or the dictionary of
``scenespeak describe --format json``) and write PNG files (and one self-contained HTML page).

Like the seed paper's figures:

- :func:`plot_matches` — the left and right images side by side, one line per stereo match,
  coloured by object (paper Fig. 4);
- :func:`plot_points_3d` — the 3-D keypoints with their projections onto the horizontal and the
  vertical plane (paper Fig. 5 b);
- :func:`plot_hulls` — the convex hulls in the horizontal plane, camera at the origin, with
  labels (paper Figs. 6, 8 e);
- :func:`plot_histograms` — F0 and F2 of one pair, polar and linear (paper Fig. 7).

>>> import numpy as np
>>> from scenespeak.tools.figures import plot_histograms
>>> theta = np.linspace(0, 2 * np.pi, 180, endpoint=False)
>>> f0 = np.maximum(np.cos(theta - np.pi), 0)       # the argument lies to the left
>>> fig = plot_histograms(f0, f0**2, title="hat / mug")
>>> len(fig.axes)
2
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError

__all__ = [
    "UNLABELLED_COLOR",
    "label_colors",
    "plot_histograms",
    "plot_hulls",
    "plot_matches",
    "plot_points_3d",
    "plot_report",
    "write_figures",
    "write_report",
]

#: Colour of points that belong to no known object.
UNLABELLED_COLOR: tuple[float, float, float, float] = (0.55, 0.55, 0.55, 1.0)

# Ten well-separated colours (matplotlib's "tab10"), listed so that the order is ours.
_PALETTE: tuple[str, ...] = (
    "#1f77b4",
    "#d62728",
    "#2ca02c",
    "#ff7f0e",
    "#9467bd",
    "#17becf",
    "#e377c2",
    "#8c564b",
    "#bcbd22",
    "#7f7f7f",
)

Color = tuple[float, float, float, float]


def _is_unlabelled(label: object) -> bool:
    return label is None or (isinstance(label, str) and label.strip() in {"", "?"})


def label_colors(labels: Sequence[str | None] | NDArray[Any]) -> dict[str, Color]:
    """Give every object label one colour, the same in every figure of a scene.

    Labels are sorted so that the colours do not depend on the order the points come in.
    ``None`` and the empty string mean "no object" and get no entry (they are drawn in
    :data:`UNLABELLED_COLOR`).

    Parameters
    ----------
    labels : sequence of str or None
        Labels, repeated or not.

    Returns
    -------
    dict
        ``label -> RGBA`` tuple.

    Examples
    --------
    >>> colors = label_colors(["mug", "hat", "mug", None])
    >>> sorted(colors)
    ['hat', 'mug']
    """
    unique = sorted({str(lab) for lab in labels if not _is_unlabelled(lab)})
    return {lab: to_rgba(_PALETTE[i % len(_PALETTE)]) for i, lab in enumerate(unique)}


def _color_of(label: object, colors: Mapping[str, Color]) -> Color:
    if _is_unlabelled(label):
        return UNLABELLED_COLOR
    return colors.get(str(label), UNLABELLED_COLOR)


def _as_points(values: ArrayLike, dims: int, name: str) -> NDArray[np.float64]:
    arr = np.asarray(values, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, dims))
    if arr.ndim != 2 or arr.shape[1] != dims:
        raise InputError(name, f"expected an (N, {dims}) array of points, got shape {arr.shape}")
    return arr


def _as_labels(labels: Sequence[str | None] | NDArray[Any] | None, n: int, name: str) -> list[Any]:
    if labels is None:
        return [None] * n
    out = list(labels)
    if len(out) != n:
        raise InputError(name, f"{len(out)} labels for {n} points; give one label per point")
    return out


def _as_image(image: ArrayLike, name: str) -> NDArray[Any]:
    arr = np.asarray(image)
    if arr.ndim not in (2, 3) or arr.size == 0:
        raise InputError(name, f"expected an image (H, W) or (H, W, C), got shape {arr.shape}")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.dtype != np.uint8:
        # Floats in [0, 1] (or anything else) are shown as they are, scaled to 8 bits.
        f = arr.astype(np.float64)
        hi = float(np.nanmax(f)) if np.isfinite(f).any() else 1.0
        scale = 255.0 if hi <= 1.0 else 255.0 / max(hi, 1e-12)
        arr = np.clip(np.nan_to_num(f) * scale, 0, 255).astype(np.uint8)
    if arr.ndim == 2:
        arr = np.repeat(arr[:, :, None], 3, axis=2)
    return arr[:, :, :3]


def _spread(n: int, limit: int) -> NDArray[np.intp]:
    """Indices of at most ``limit`` items spread evenly over ``n`` (deterministic)."""
    if n <= limit:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, limit).round().astype(np.intp))


def _legend_for(ax: Any, colors: Mapping[str, Color], used: Sequence[Any], **kw: Any) -> None:
    from matplotlib.lines import Line2D

    names = sorted({str(u) for u in used if not _is_unlabelled(u)})
    handles = [Line2D([], [], color=colors.get(n, UNLABELLED_COLOR), lw=3) for n in names]
    if any(_is_unlabelled(u) for u in used):
        handles.append(Line2D([], [], color=UNLABELLED_COLOR, lw=3))
        names.append("unlabelled")
    if handles:
        ax.legend(handles, names, fontsize="small", framealpha=0.85, **kw)


# --------------------------------------------------------------------------------------------
# Stage pictures on plain arrays
# --------------------------------------------------------------------------------------------


def plot_matches(
    left: ArrayLike,
    right: ArrayLike,
    left_xy: ArrayLike,
    right_xy: ArrayLike,
    labels: Sequence[str | None] | NDArray[Any] | None = None,
    *,
    colors: Mapping[str, Color] | None = None,
    max_lines: int = 400,
    title: str | None = None,
    figsize: tuple[float, float] = (10.0, 4.0),
    dpi: float = 100.0,
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
    colors : mapping, optional
        ``label -> colour``; by default :func:`label_colors` of ``labels``.
    max_lines : int
        At most this many lines are drawn (spread evenly over the matches) so the picture stays
        readable; all points are still counted in the title.
    title : str, optional
        Figure title.
    figsize, dpi
        Size of the figure (inches) and resolution.

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
    colors = label_colors(labs) if colors is None else colors

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
    colors: Mapping[str, Color] | None = None,
    title: str | None = None,
    figsize: tuple[float, float] = (6.5, 5.5),
    dpi: float = 100.0,
    elev: float = 22.0,
    azim: float = -60.0,
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
    colors : mapping, optional
        ``label -> colour``.
    title : str, optional
        Figure title.
    figsize, dpi, elev, azim
        Figure size, resolution and viewing angles.

    Returns
    -------
    matplotlib.figure.Figure
    """
    pts = _as_points(xyz, 3, "xyz")
    labs = _as_labels(labels, len(pts), "labels")
    colors = label_colors(labs) if colors is None else colors
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


def _polygon_centroid(poly: NDArray[np.float64]) -> NDArray[np.float64]:
    if len(poly) < 3:
        return poly.mean(axis=0)
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2.0
    if abs(area) < 1e-15:
        return poly.mean(axis=0)
    return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6.0 * area)


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
    from matplotlib.patches import Polygon

    polys = {str(k): _as_points(v, 2, f"hull of {k}") for k, v in hulls.items()}
    pts = {str(k): _as_points(v, 2, f"points of {k}") for k, v in (points or {}).items()}
    true = {str(k): _as_points(v, 2, f"footprint of {k}") for k, v in (truth or {}).items()}
    colors = label_colors([*polys, *pts, *true]) if colors is None else colors

    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    ax = fig.add_subplot()
    everything = [np.zeros((1, 2))]
    for lab, p in pts.items():
        if len(p):
            ax.scatter(p[:, 0], p[:, 1], s=5, color=_color_of(lab, colors), alpha=0.45)
            everything.append(p)
    for lab, poly in true.items():
        if len(poly) >= 2:
            ax.add_patch(
                Polygon(poly, closed=True, fill=False, ls="--", lw=1.0, ec=_color_of(lab, colors))
            )
            everything.append(poly)
    for lab, poly in polys.items():
        if not len(poly):
            continue
        col = _color_of(lab, colors)
        if len(poly) >= 3:
            ax.add_patch(Polygon(poly, closed=True, fc=(*col[:3], 0.3), ec=col, lw=2.0))
        else:
            ax.plot(poly[:, 0], poly[:, 1], "-o", color=col, lw=2.0)
        cx, _ = _polygon_centroid(poly)
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
        everything.append(poly)
    allp = np.vstack(everything)
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
    ax.set_title(f"Convex hulls in the horizontal plane ({len(polys)} objects)")
    if title:
        fig.suptitle(title)
    return fig


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

    rig = _get(description, "rig")
    up = _get(description, "up")
    if up is None and rig is not None:
        up = _get(rig, "up")
    if up is not None:
        v.up = np.asarray(up, dtype=np.float64).reshape(3)
    if rig is not None:
        hfov = _get(rig, "hfov_deg")
        if hfov is None:
            try:
                k = np.asarray(_get(rig, "K_left", "K1", "K"), dtype=np.float64)
                width = float(np.asarray(_get(rig, "image_size"))[0])
                hfov = float(np.degrees(2 * np.arctan2(width / 2, k[0, 0])))
            except (TypeError, ValueError, IndexError):
                hfov = None
        v.hfov_deg = None if hfov is None else float(hfov)

    points = _get(description, "points", "points3d", "stereo_points")
    if isinstance(points, Mapping) or (points is not None and not isinstance(points, list)):
        xyz = _get(points, "xyz")
        if xyz is not None:
            v.xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        lxy, rxy = _get(points, "left_xy"), _get(points, "right_xy")
        if lxy is not None and rxy is not None:
            v.left_xy = np.asarray(lxy, dtype=np.float64).reshape(-1, 2)
            v.right_xy = np.asarray(rxy, dtype=np.float64).reshape(-1, 2)
    elif isinstance(points, list) and points:  # the JSON form of ``scenespeak points``
        v.xyz = np.array([p["xyz"] for p in points], dtype=np.float64).reshape(-1, 3)
        v.left_xy = np.array([p["left"] for p in points], dtype=np.float64).reshape(-1, 2)
        v.right_xy = np.array([p["right"] for p in points], dtype=np.float64).reshape(-1, 2)
    labels = _get(description, "point_labels", "labels")
    if labels is None and points is not None and not isinstance(points, list):
        labels = _get(points, "labels")
    if labels is not None and v.xyz is not None and len(labels) == len(v.xyz):
        v.point_labels = [None if _is_unlabelled(lab) else str(lab) for lab in labels]

    for obj in _get(description, "objects") or []:
        label = str(_get(obj, "label"))
        hull = _get(obj, "hull")
        if hull is not None:
            v.hulls[label] = np.asarray(hull, dtype=np.float64).reshape(-1, 2)
        plane = _get(obj, "plane_xy")
        if plane is not None:
            v.plane_points[label] = np.asarray(plane, dtype=np.float64).reshape(-1, 2)
        oxyz = _get(obj, "xyz")
        if oxyz is not None:
            v.object_xyz[label] = np.asarray(oxyz, dtype=np.float64).reshape(-1, 3)

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

    # Points with no per-point labels: rebuild them from the objects' own 3-D points.
    if v.xyz is None and v.object_xyz:
        v.xyz = np.vstack(list(v.object_xyz.values()))
        v.point_labels = [lab for lab, p in v.object_xyz.items() for _ in range(len(p))]
    v.match_labels = v.point_labels
    if v.xyz is not None and v.point_labels is not None:
        # Objects built from other points than the labelled keypoints (dense disparity, unknown
        # clusters) would be missing from the 3-D picture: add their own points.
        have = set(v.point_labels)
        extra = {lab: p for lab, p in v.object_xyz.items() if lab not in have and len(p)}
        if extra:
            v.xyz = np.vstack([v.xyz, *extra.values()])
            v.point_labels = v.point_labels + [lab for lab, p in extra.items() for _ in p]
    return v


def _save(fig: Figure, path: Path, dpi: float | None = None) -> Path:
    buf = io.BytesIO()
    _plain_text(fig).savefig(buf, format="png", dpi=dpi, facecolor="white")
    return _write_file(path, buf.getvalue())


def _plain_text(fig: Figure) -> Figure:
    """Labels come from files (a database someone else made): "$x$" stays text, not mathtext."""
    from matplotlib.text import Text

    for t in fig.findobj(Text):
        t.set_parse_math(False)
    return fig


def _write_file(path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` without following a symlink planted there.

    The bytes go to a new file beside it (``O_EXCL | O_NOFOLLOW``), which then replaces
    ``path`` itself: a symlink at ``path`` is replaced, its target is never written.
    """
    if path.is_dir() and not path.is_symlink():
        raise InputError(path, "is a folder; cannot write the figure there (remove or rename it)")
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        fd = os.open(tmp, flags, 0o644)
        try:
            with os.fdopen(fd, "wb", closefd=False) as f:
                f.write(data)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise InputError(path, f"cannot write the figure ({exc.strerror or exc})") from None
    return path


def _pick_relation(view: _SceneView, pair: tuple[str, str] | None) -> dict[str, Any] | None:
    usable = [r for r in view.relations if r["f0"] is not None and r["f2"] is not None]
    if pair is not None:
        for r in usable:
            if (r["argument"], r["referent"]) == tuple(pair):
                return r
        raise InputError("pair", f"no relation of {pair[0]!r} to {pair[1]!r} in this scene")
    return usable[0] if usable else None


def _scene_figures(
    view: _SceneView, pair: tuple[str, str] | None
) -> list[tuple[str, Callable[[], Figure]]]:
    """Names and builders of the figures this scene has the data for."""
    colors = label_colors([*(view.point_labels or []), *view.hulls, *view.plane_points])
    out: list[tuple[str, Callable[[], Figure]]] = []
    left, right, left_xy, right_xy = view.left, view.right, view.left_xy, view.right_xy
    if left is not None and right is not None and left_xy is not None and right_xy is not None:
        lbl = view.match_labels
        if lbl is not None and len(lbl) != len(left_xy):
            lbl = None
        out.append(
            (
                "matches",
                lambda: plot_matches(left, right, left_xy, right_xy, lbl, colors=colors),
            )
        )
    xyz = view.xyz
    if xyz is not None and len(xyz):
        out.append(
            (
                "points3d",
                lambda: plot_points_3d(xyz, view.point_labels, up=view.up, colors=colors),
            )
        )
    if view.hulls:
        out.append(
            (
                "hulls",
                lambda: plot_hulls(
                    view.hulls, view.plane_points, colors=colors, hfov_deg=view.hfov_deg
                ),
            )
        )
    rel = _pick_relation(view, pair)
    if rel is not None:
        out.append(
            (
                "histograms",
                lambda: plot_histograms(
                    rel["f0"], rel["f2"], title=f"{rel['argument']} relative to {rel['referent']}"
                ),
            )
        )
    return out


def write_figures(
    description: Any,
    out_dir: str | PathLike[str],
    *,
    pair: tuple[str, str] | None = None,
    report: bool = True,
    dpi: float = 100.0,
) -> list[Path]:
    """Write the pictures of every stage of one described scene as PNG files.

    Files (each only when the description holds the data for it): ``matches.png``,
    ``points3d.png``, ``hulls.png``, ``histograms.png`` (of ``pair``, by default the first
    described pair) and, with ``report=True``, ``report.png`` and ``report.html``
    (see :func:`write_report`).

    Parameters
    ----------
    description : SceneDescription or dict
        The result of :func:`scenespeak.pipeline.describe_scene`, or its ``to_dict()`` / the
        JSON of ``scenespeak describe --format json`` (hulls, histograms and sentences only).
    out_dir : path
        Folder to write into (created if missing).
    pair : (argument, referent), optional
        The pair whose histograms to draw.
    report : bool
        Also write the one-page report.
    dpi : float
        Resolution of the PNG files.

    Returns
    -------
    list of Path
        The files written, in the order above.
    """
    out = _figures_dir(out_dir)
    view = _scene_view(description)
    written = [
        _save(build(), out / f"{name}.png", dpi) for name, build in _scene_figures(view, pair)
    ]
    if report:
        written.extend(write_report(description, out, pair=pair, _view=view))
    return written


def _figures_dir(out_dir: str | PathLike[str]) -> Path:
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder; --figures needs a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(out, f"cannot create the figures folder ({exc.strerror or exc})") from exc
    return out


def plot_report(
    description: Any, *, pair: tuple[str, str] | None = None, _view: _SceneView | None = None
) -> Figure:
    """One page (A4-ish landscape) with every stage's picture and the sentences beside them.

    Parameters
    ----------
    description : SceneDescription or dict
        As for :func:`write_figures`.
    pair : (argument, referent), optional
        The pair whose histograms to draw.

    Returns
    -------
    matplotlib.figure.Figure
    """
    view = _scene_view(description) if _view is None else _view
    images = {name: _render(build(), dpi=90.0) for name, build in _scene_figures(view, pair)}
    page_w, page_h, margin, gap, title_h = 16.0, 10.0, 0.25, 0.2, 0.6
    fig = Figure(figsize=(page_w, page_h), dpi=100)
    fig.suptitle("scenespeak: what the stereo pair shows", fontsize=14, y=1.0 - 0.15 / page_h)

    def aspect(name: str) -> float:
        h, w = images[name].shape[:2]
        return w / h

    def place(name: str, x: float, y: float, w: float, h: float) -> None:
        # (x, y) is the top-left corner in inches from the page's top-left
        ax = fig.add_axes((x / page_w, 1.0 - (y + h) / page_h, w / page_w, h / page_h))
        ax.imshow(images[name])
        ax.set_axis_off()

    # Left block: the matches across its width, the 3-D points and the hulls side by side
    # below, as large as the page allows with every picture at its own aspect ratio.
    top = title_h
    room = page_h - top - margin
    right_w = 4.6
    left_w = page_w - 2 * margin - gap - right_w
    below = [n for n in ("points3d", "hulls") if n in images]

    def left_height(w: float) -> float:
        h = w / aspect("matches") if "matches" in images else 0.0
        if below:
            h += max((w - gap) / len(below) / aspect(n) for n in below) + gap
        return h

    if left_height(left_w) > room:
        left_w *= room / left_height(left_w)
    y = top
    if "matches" in images:
        h = left_w / aspect("matches")
        place("matches", margin, y, left_w, h)
        y += h + gap
    cell = (left_w - gap) / max(len(below), 1)
    for k, name in enumerate(below):
        place(name, margin + k * (cell + gap), y, cell, cell / aspect(name))
    # Right column: the histograms at the bottom, the sentences above them.
    x_right = page_w - margin - right_w
    hist_h = 0.0
    if "histograms" in images:
        hist_h = right_w / aspect("histograms")
        place("histograms", x_right, page_h - margin - hist_h, right_w, hist_h)
    text = _report_text(view)
    text_h = room - hist_h - gap
    lines = text.count("\n") + 1
    size = max(6.0, min(10.0, 72.0 * text_h / (1.3 * lines)))  # shrink a long list to fit
    fig.text(
        x_right / page_w,
        1.0 - top / page_h,
        text,
        va="top",
        ha="left",
        fontsize=size,
        family="serif",
    )
    return fig


def _render(fig: Figure, dpi: float = 100.0) -> NDArray[np.uint8]:
    buf = io.BytesIO()
    # cropped to what is drawn, so that the page can lay each picture out at its real shape
    _plain_text(fig).savefig(
        buf, format="png", dpi=dpi, facecolor="white", bbox_inches="tight", pad_inches=0.05
    )
    buf.seek(0)
    from matplotlib.image import imread

    img = imread(buf, format="png")
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def _wrap(text: str, width: int = 52) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width)) or text


def _report_text(view: _SceneView) -> str:
    lines = ["Description"]
    if view.summary:
        lines += [_wrap(view.summary), ""]
    for i, rel in enumerate(view.relations, 1):
        if rel["sentence"]:
            lines.append(_wrap(f"{i}. {rel['sentence']}"))
    if not view.relations:
        lines.append("(no pair of objects could be described)")
    if view.skipped:
        lines += ["", "Not described"]
        lines += [_wrap(f"- {lab}: {why}") for lab, why in view.skipped]
    return "\n".join(lines)


def write_report(
    description: Any,
    out_dir: str | PathLike[str],
    *,
    pair: tuple[str, str] | None = None,
    _view: _SceneView | None = None,
) -> list[Path]:
    """Write the one-page report: ``report.png`` and a self-contained ``report.html``.

    The HTML page embeds every picture as base64 PNG (no other file is needed to view or send
    it) and lists the sentences, the objects and the objects that could not be described.

    Parameters
    ----------
    description : SceneDescription or dict
        As for :func:`write_figures`.
    out_dir : path
        Folder to write into (created if missing).
    pair : (argument, referent), optional
        The pair whose histograms to draw.

    Returns
    -------
    list of Path
        ``[report.png, report.html]``.
    """
    out = _figures_dir(out_dir)
    view = _scene_view(description) if _view is None else _view
    png = _save(plot_report(description, pair=pair, _view=view), out / "report.png", 100.0)

    images = []
    for name, build in _scene_figures(view, pair):
        buf = io.BytesIO()
        _plain_text(build()).savefig(buf, format="png", dpi=90, facecolor="white")
        data = base64.b64encode(buf.getvalue()).decode("ascii")
        images.append(
            f'<figure><img alt="{html.escape(name)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(_CAPTIONS.get(name, name))}</figcaption></figure>"
        )
    sentences = "".join(
        f"<li>{html.escape(r['sentence'])}</li>" for r in view.relations if r["sentence"]
    )
    objects = "".join(
        f"<tr><td>{html.escape(lab)}</td><td>{len(view.plane_points.get(lab, []))}</td>"
        f"<td>{len(hull)}</td></tr>"
        for lab, hull in view.hulls.items()
    )
    skipped = "".join(
        f"<li><b>{html.escape(lab)}</b>: {html.escape(why)}</li>" for lab, why in view.skipped
    )
    summary = f"<p>{html.escape(view.summary)}</p>" if view.summary else ""
    page = _HTML.format(
        images="\n".join(images) or "<p>(no pictures: the description holds no stage data)</p>",
        summary=summary,
        sentences=f"<ol>{sentences}</ol>" if sentences else "<p>No pair could be described.</p>",
        objects=objects,
        skipped=f"<h2>Not described</h2><ul>{skipped}</ul>" if skipped else "",
    )
    page_path = _write_file(out / "report.html", page.encode("utf-8"))
    return [png, page_path]


_CAPTIONS = {
    "matches": "Stereo matches between the left and right images, coloured by object.",
    "points3d": "3-D keypoints with their horizontal (cyan) and vertical (red) projections.",
    "hulls": "Convex hulls of the objects in the horizontal plane; the camera is at the origin.",
    "histograms": "Histograms of forces F0 and F2 of one pair (0° right, 90° behind).",
}

_HTML = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>scenespeak report</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; color: #222; }}
main {{ display: flex; gap: 2em; align-items: flex-start; }}
.pictures {{ flex: 3; display: flex; flex-wrap: wrap; gap: 1em; }}
.pictures figure {{ margin: 0; max-width: 48%; }}
.pictures img {{ max-width: 100%; border: 1px solid #ddd; }}
figcaption {{ font-size: 0.85em; color: #555; }}
aside {{ flex: 1; min-width: 18em; }}
table {{ border-collapse: collapse; }} td, th {{ border: 1px solid #ccc; padding: 0.2em 0.6em; }}
</style></head>
<body>
<h1>scenespeak: what the stereo pair shows</h1>
<main>
<section class="pictures">
{images}
</section>
<aside>
<h2>Description</h2>
{summary}
{sentences}
<h2>Objects</h2>
<table><tr><th>object</th><th>points</th><th>hull vertices</th></tr>{objects}</table>
{skipped}
</aside>
</main>
</body></html>
"""
