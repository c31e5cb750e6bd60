"""Which pixels of a region are one surface: depth modes, box spans, depth continuity.

The pieces of :mod:`scenespeak.perception.rgbd` that look at a region's depths alone:

- :func:`surface_modes` — the dense depth intervals of a pixel set (histogram with bins
  ``bin_width * Z^2``, hysteresis);
- :func:`box_span` — how much of a box's extent a pixel set spans (a box's object touches
  its sides);
- :func:`connected_surface` — a mode grown over the pixels depth-continuous with it (a face
  seen at a grazing angle).
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.intrinsics import Intrinsics

__all__ = ["box_span", "connected_surface", "surface_modes"]


def surface_modes(
    z: NDArray[np.floating], *, bin_width: float = 0.01, mode_fraction: float = 0.01
) -> list[tuple[float, float, int]]:
    """The dense depth intervals of a pixel set: ``(near, far, pixels)`` per mode, nearest first.

    Bins are ``bin_width * mean(Z)^2`` wide (at least 2 mm). A mode is a maximal run of bins
    each holding at least a tenth of ``t = max(2, mode_fraction * len(z))`` pixels (and at
    least 2) that contains a bin of at least ``t`` (hysteresis, as Canny's edge thresholds): a
    surface receding from the camera (a box's top seen at a grazing angle) thins out but never
    breaks, while flying pixels strewn between an object and its background are too sparse
    to join.

    Examples
    --------
    >>> z = np.r_[np.full(500, 1.0), np.linspace(1.0, 2.0, 20), np.full(300, 2.0)]
    >>> [(round(a, 2), round(b, 2), n) for a, b, n in surface_modes(z)]
    [(1.0, 1.02, 501), (1.99, 2.01, 301)]
    """
    zz = np.asarray(z, np.float64)
    zz = zz[np.isfinite(zz)]
    if len(zz) == 0:
        return []
    zmid = float(zz[len(zz) // 2]) if len(zz) < 64 else float(np.mean(zz))
    width = max(0.002, bin_width * zmid * zmid)
    lo = float(zz.min())
    nb = int((float(zz.max()) - lo) / width) + 1
    idx = ((zz - lo) / width).astype(np.intp)
    counts = np.bincount(idx, minlength=nb)
    high = max(2.0, mode_fraction * len(zz))
    core = counts >= high
    if not core.any():
        core = counts == counts.max()
    weak = (counts >= max(2.0, 0.1 * high)) | core
    edges = np.flatnonzero(np.diff(np.r_[0, weak.astype(np.int8), 0]))
    starts, stops = edges[::2], edges[1::2]
    ccore = np.r_[0, np.cumsum(core)]
    csum = np.r_[0, np.cumsum(counts)]
    return [
        (lo + a * width, lo + b * width, int(csum[b] - csum[a]))
        for a, b in zip(starts.tolist(), stops.tolist(), strict=True)
        if ccore[b] > ccore[a]
    ]


def box_span(
    ys: NDArray[np.intp], xs: NDArray[np.intp], extent: tuple[int, int, int, int]
) -> float:
    """How much of a box's extent ``(x0, y0, x1, y1)`` (exclusive ends) a pixel set spans.

    The product of the fractions of the box's width and height between the set's extreme
    columns and rows: 1 for a set that touches all four sides (a detector's box is drawn
    around the visible object), small for a part of a nearer object that only reaches into
    a corner or a strip of it.

    Examples
    --------
    >>> ys, xs = np.mgrid[0:10, 0:5]
    >>> box_span(ys.ravel(), xs.ravel(), (0, 0, 10, 10))
    0.5
    """
    if len(ys) == 0:
        return 0.0
    x0, y0, x1, y1 = extent
    wx = (int(xs.max()) - int(xs.min()) + 1) / max(1, x1 - x0)
    wy = (int(ys.max()) - int(ys.min()) + 1) / max(1, y1 - y0)
    return float(min(1.0, wx) * min(1.0, wy))


def _links(
    zz: NDArray[np.float64], axis: int, big: float, small: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Which neighbours along ``axis`` are on one surface (see :func:`connected_surface`)."""
    d = np.diff(zz, axis=axis)
    near = np.fmin(zz[1:], zz[:-1]) if axis == 0 else np.fmin(zz[:, 1:], zz[:, :-1])
    tol = small[1:] if axis == 0 else small[:, 1:]
    pad = [(0, 0), (0, 0)]
    pad[axis] = (1, 1)
    dd = np.pad(d, pad, constant_values=np.nan)
    before = dd[:-2] if axis == 0 else dd[:, :-2]
    after = dd[2:] if axis == 0 else dd[:, 2:]
    with np.errstate(invalid="ignore"):
        ad = np.abs(d)
        ramp = (ad <= big * near) & ((np.abs(d - before) <= tol) | (np.abs(after - d) <= tol))
        return (ad <= tol) | ramp


def connected_surface(
    ys: NDArray[np.intp],
    xs: NDArray[np.intp],
    z: NDArray[np.float64],
    seed: NDArray[np.bool_],
    cam: Intrinsics,
    *,
    bin_width: float = 0.01,
    continuity_deg: float = 88.0,
) -> NDArray[np.bool_]:
    """``seed`` grown over the pixels depth-continuous with it (a receding face of the object).

    A depth mode is a depth interval; a face seen at a grazing angle (a box's top from a
    level camera) spans more depth than the histogram joins, row after row centimetres
    apart. In the image that face is continuous. Two 4-neighbours are on one surface when
    their depths differ by at most one histogram bin (``bin_width Z^2``), or by at most
    ``Z tan(a) / f`` (the step of a surface at ``a = continuity_deg`` to the viewing ray: the
    pixel's footprint ``Z / f`` times the slope) on a *ramp* — the step before or after it along
    the same line is the same within a bin (a plane's depth changes smoothly; a depth edge or
    a flying pixel is one step that its neighbours do not repeat). This is organised
    point-cloud segmentation with depth-dependent thresholds (Holz, Holzer, Rusu & Behnke
    2011; Trevor, Gedikli, Rusu & Christensen 2013) with a second-difference test for the
    grazing steps. The linked pixels form 4-connected components (on a grid of pixels and
    links, one ``cv2.connectedComponents`` pass); each component holding at least a fifth of
    the seed's pixels joins it.

    Parameters
    ----------
    ys, xs : (N,) int arrays
        The pixels (rows, columns) of one object region.
    z : (N,) float
        Their depths (metres, finite).
    seed : (N,) bool
        The pixels already kept (the region's main depth mode).
    cam : Intrinsics
    bin_width : float
        Depth-histogram bin width at 1 m (grows with ``Z^2``), as :func:`surface_modes`.
    continuity_deg : float
        The most grazing surface angle to the viewing ray still read as continuous.

    Examples
    --------
    >>> cam = Intrinsics(500.0, 500.0, 50.0, 50.0, 100, 100)
    >>> ys, xs = np.mgrid[0:30, 0:10]
    >>> z = np.where(ys < 10, 1.0, 1.0 + 0.03 * (ys - 9))  # a face, then a receding one
    >>> z[:, 9] = 2.0  # and a column of wall behind them
    >>> seed = z < 1.02
    >>> grown = connected_surface(ys.ravel(), xs.ravel(), z.ravel(), seed.ravel(), cam)
    >>> int(seed.sum()), int(grown.sum())
    (90, 270)
    """
    y0, x0 = int(ys.min()), int(xs.min())
    r, c = ys - y0, xs - x0
    h, w = int(r.max()) + 1, int(c.max()) + 1
    zz = np.full((h, w), np.nan)
    zz[r, c] = z
    big = np.tan(np.radians(continuity_deg)) / max(cam.fx, cam.fy)
    small = np.maximum(0.002, bin_width * zz * zz)
    grid = np.zeros((2 * h - 1, 2 * w - 1), np.uint8)  # pixels at even places, links between
    grid[::2, ::2] = np.isfinite(zz)
    grid[1::2, ::2] = _links(zz, 0, big, small)
    grid[::2, 1::2] = _links(zz, 1, big, small)
    n, lab = cv2.connectedComponents(grid, connectivity=4)
    labs = lab[::2, ::2][r, c]
    held = np.bincount(labs[seed], minlength=n)
    held[0] = 0
    join = held >= 0.2 * max(1, int(np.count_nonzero(seed)))
    return np.asarray(seed | join[labs], dtype=bool)
