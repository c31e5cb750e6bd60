"""Views of a cylinder from higher up, synthesised from its training views at ``db add``.

A label wrapped round a cylinder photographed from a few degrees above (the training views)
looks different from above: its horizontal lines bend into ellipse arcs and it is foreshortened.
A scene seen by a rig 0.3-0.45 m above the support sees objects 0.5-1 m away from 25-45°
above, and SIFT then matches little (a grey tin 0.59 m away, 37° below the camera: 5 of 66
keypoints passed the ratio test against views from 17°, 44 against views rendered from 40°).
ASIFT (Morel & Yu, "ASIFT: A new framework for fully affine invariant image comparison",
SIAM J. Imaging Sciences 2009) simulates the views a plane can be seen from; a cylinder is not
a plane, but its image is known once its silhouette is: a point at angle ``φ`` round the axis
(0 facing the camera) and height ``τ`` along it projects, under an orthographic camera at
elevation ``e``, to

    column = c + r·sin φ,    row = v_b − τ·cos e + r·sin e·cos φ,

(``c``, ``r``: the silhouette's centre column and half width; ``v_b``: the row of the bottom
rim's centre). ``r·sin e`` is how far the bottom rim's front bulges below its ends, read off the
mask (:func:`cylinder_of`). A view from elevation ``e'`` is then a per-column remap of the
training view: the body's rows scale by ``cos e' / cos e`` and the rims' bulge by
``sin e' / sin e`` (:func:`view_from`). The top face is stretched the same way.

An object is taken for a cylinder when every masked view's silhouette is one (a straight-sided
body, an elliptic bottom rim, ``sin e`` between 0.08 and 0.7) and all have the same width
within ``width_spread`` (a box's width changes with the side it shows).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Cylinder",
    "cylinder_of",
    "elevated_views",
    "raised_cylinders",
    "source_rows",
    "view_from",
]

#: How much higher (degrees) the synthesised views are seen from than the training view.
RAISES = (18.0, 32.0)


@dataclass(frozen=True)
class Cylinder:
    """A vertical cylinder's silhouette in one view: centre column, half width (pixels), the
    rows of the bottom and top rims' centres, and the sines of the elevations the bottom and
    the top rim are seen from (they differ under perspective: the camera is nearer one)."""

    c: float
    r: float
    bottom: float
    top: float
    sin_bottom: float
    sin_top: float


def _extents(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Per column of the mask: the lowest and highest object row (-1: none)."""
    m = np.asarray(mask, bool)
    rows = np.arange(m.shape[0])[:, None]
    low = np.where(m.any(axis=0), np.max(np.where(m, rows, -1), axis=0), -1)
    high = np.where(m.any(axis=0), np.min(np.where(m, rows, m.shape[0]), axis=0), -1)
    return low, high


def cylinder_of(
    mask: NDArray[np.bool_], *, max_residual: float = 2.0, sin_top: float | None = None
) -> Cylinder | None:
    """The cylinder a view's object mask is the silhouette of, or None.

    Over the columns within 0.9 r of the centre (``cos φ = sqrt(1 − ((u − c) / r)²)``) the
    bottom edge ``row = v_b + k_b·cos φ`` and the top edge ``row = v_t − k_t·cos φ`` are fitted
    by least squares (``k = r·sin e``). None when the fit is off by more than ``max_residual``
    pixels (RMS), either ``sin e`` is outside 0.05–0.8 (a flat edge: a box's face, or a view
    from level), or the mask is less than 12 pixels wide. With ``sin_top`` (the top rim's
    elevation from the object's other views), ``k_t`` is that and only the bottom edge must
    fit: a mask that left out part of the top face (a plain top like the background) has a
    ragged, flat top edge.

    Examples
    --------
    >>> m = np.zeros((200, 200), bool)
    >>> u = np.arange(60, 141); cos = np.sqrt(1 - ((u - 100) / 40.5) ** 2)
    >>> for x, k in zip(u, cos):
    ...     m[int(round(50 - 6 * k)) : int(round(150 + 12 * k)) + 1, x] = True
    >>> cyl = cylinder_of(m)
    >>> round(cyl.r), round(cyl.sin_bottom, 2), round(cyl.sin_top, 2), round(cyl.bottom)
    (40, 0.3, 0.16, 150)
    >>> box = np.zeros((200, 200), bool); box[50:150, 60:140] = True
    >>> cylinder_of(box) is None  # flat edges: a box's face
    True
    >>> flat_top = m.copy(); flat_top[:56] = False  # the top face left out of the mask
    >>> cylinder_of(flat_top) is None
    True
    >>> cyl = cylinder_of(flat_top, sin_top=0.16)
    >>> round(cyl.sin_bottom, 2), round(cyl.bottom)
    (0.3, 150)
    """
    m = np.asarray(mask, bool)
    cols = np.flatnonzero(m.any(axis=0))
    if len(cols) < 12:
        return None
    c = float(cols[0] + cols[-1]) / 2.0
    r = float(cols[-1] - cols[0] + 1) / 2.0
    low, high = _extents(m)
    u = cols[np.abs(cols - c) <= 0.9 * r]
    cos = np.sqrt(np.clip(1.0 - ((u - c) / r) ** 2, 0.0, 1.0))
    n = len(u)
    a = np.zeros((2 * n, 4))
    a[:n, 0], a[:n, 2] = 1.0, cos
    a[n:, 1], a[n:, 3] = 1.0, -cos
    b = np.concatenate([low[u], high[u]]).astype(np.float64)
    if sin_top is None:
        sol, *_ = np.linalg.lstsq(a, b, rcond=None)
        res = a @ sol - b
    else:  # k_t known: v_t is the top edge's mean offset, only the bottom must fit
        sol, *_ = np.linalg.lstsq(a[:n][:, [0, 2]], b[:n], rcond=None)
        res = a[:n][:, [0, 2]] @ sol - b[:n]
        k_t = sin_top * r
        sol = np.array([sol[0], float(np.mean(high[u] + k_t * cos)), sol[1], k_t])
    rms = float(np.sqrt(np.mean(res**2)))
    sb, st = float(sol[2]) / r, float(sol[3]) / r
    if rms > max_residual or not (0.05 <= sb <= 0.8 and 0.05 <= st <= 0.8):
        return None
    if sol[0] - sol[1] < r * (sb + st):
        return None
    return Cylinder(c, r, float(sol[0]), float(sol[1]), sb, st)


def _rows_along(
    cyl: Cylinder, raise_deg: float, cos: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """For fractions ``t`` (0 bottom rim, 1 top rim; a grid of 257) along the axis: the rows
    in the training view and in the view from ``raise_deg`` higher of the surface points at
    ``cos φ`` (one column each: shape (257, columns)), and the grid."""
    t = np.linspace(0.0, 1.0, 257)[:, None]
    e0 = np.arcsin(cyl.sin_bottom + t * (cyl.sin_top - cyl.sin_bottom))
    e1 = np.minimum(e0 + np.radians(raise_deg), np.radians(85.0))
    mid0 = float(np.arcsin((cyl.sin_bottom + cyl.sin_top) / 2.0))
    mid1 = min(mid0 + np.radians(raise_deg), np.radians(85.0))
    length1 = (cyl.bottom - cyl.top) * np.cos(mid1) / np.cos(mid0)
    src = cyl.bottom + t * (cyl.top - cyl.bottom) + cyl.r * np.sin(e0) * cos[None, :]
    dst = cyl.bottom - t * length1 + cyl.r * np.sin(e1) * cos[None, :]
    return src, dst, t[:, 0]


def source_rows(
    shape: tuple[int, int], cyl: Cylinder, raise_deg: float
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Per pixel of the view of ``cyl`` from ``raise_deg`` degrees higher (an image of
    ``shape``): the row of the training view it comes from (the same column; -1 off the
    object), and the object's pixels (module docstring)."""
    h, w = shape
    u = np.arange(w, dtype=np.float64)
    sn = (u - cyl.c) / cyl.r
    inside = np.abs(sn) < 0.98
    cos = np.sqrt(np.clip(1.0 - sn * sn, 0.0, 1.0))
    src, dst, _ = _rows_along(cyl, raise_deg, cos)
    rows = np.arange(h, dtype=np.float64)
    map_v = np.full((h, w), -1.0)
    body = np.zeros((h, w), bool)
    top_dst, top_src = dst[-1], src[-1]  # the top rim's front, per column
    s_top0 = cyl.sin_top
    s_top1 = float(np.sin(min(np.arcsin(s_top0) + np.radians(raise_deg), np.radians(85.0))))
    centre1 = top_dst - cyl.r * s_top1 * cos  # the new top face's centre row, per column
    centre0 = top_src - cyl.r * s_top0 * cos
    for x in np.flatnonzero(inside):
        d = dst[::-1, x]  # increasing rows: top rim first
        on = (rows >= d[0]) & (rows <= d[-1])
        map_v[on, x] = np.interp(rows[on], d, src[::-1, x])
        body[on, x] = True
        face = ~on & (np.abs(rows - centre1[x]) <= cyl.r * s_top1 * cos[x])
        map_v[face, x] = centre0[x] + (rows[face] - centre1[x]) * (s_top0 / s_top1)
        body[face, x] = True
    return map_v, body


def view_from(
    image: NDArray[np.generic], cyl: Cylinder, raise_deg: float
) -> tuple[NDArray[np.generic], NDArray[np.bool_]]:
    """The view of ``cyl`` (in ``image``) from ``raise_deg`` degrees higher, and its mask: the
    body remapped per column (module docstring, :func:`source_rows`), the top face stretched,
    the rest the image's border colour (a plain background). The bottom rim's centre stays
    where it was."""
    img = np.asarray(image)
    h, w = img.shape[:2]
    map_v, body = source_rows((h, w), cyl, raise_deg)
    border = np.concatenate([img[0], img[-1], img[:, 0], img[:, -1]]).reshape(-1, *img.shape[2:])
    fill = np.median(border, axis=0).astype(img.dtype)
    u = np.arange(w, dtype=np.float32)
    map_u = np.broadcast_to(u[None, :], (h, w)).astype(np.float32)
    out = cv2.remap(img, map_u, map_v.astype(np.float32), interpolation=cv2.INTER_LINEAR)
    keep = body[..., None] if out.ndim == 3 else body
    return np.where(keep, out, fill).astype(img.dtype), body


def _cylinders(masks: Sequence[NDArray[np.bool_] | None]) -> list[Cylinder | None]:
    """Each view's cylinder (:func:`cylinder_of`) when most views (at least 3 and 60 %) are a
    cylinder's silhouette, and then also the views whose top edge alone does not fit, with the
    others' median top elevation (``sin_top``); all None otherwise."""
    cyls = [None if m is None else cylinder_of(np.asarray(m, bool)) for m in masks]
    good = [cy for cy in cyls if cy is not None]
    if len(good) < max(3, 0.6 * len(masks)):
        return [None] * len(masks)
    top = float(np.median([cy.sin_top for cy in good]))
    return [
        cy if cy is not None or m is None else cylinder_of(np.asarray(m, bool), sin_top=top)
        for cy, m in zip(cyls, masks, strict=True)
    ]


def elevated_views(
    images: Sequence[NDArray[np.generic]],
    masks: Sequence[NDArray[np.bool_] | None],
    *,
    width_spread: float = 0.05,
    raises: tuple[float, ...] = RAISES,
) -> list[tuple[int, float, NDArray[np.generic], NDArray[np.bool_]]]:
    """Synthesised views ``(view index, degrees raised, image, mask)`` of an object that is
    a cylinder: most of its views (at least 3 and 60 %) are a cylinder's silhouette
    (:func:`cylinder_of`; then also those whose top edge alone does not fit, the top face left
    out of the mask, :func:`_cylinders`) and those are the same width within ``width_spread``
    (a box's width changes with the side it shows); [] otherwise. Only those views are
    raised."""
    cyls = _cylinders(masks)
    good = [(i, cy) for i, cy in enumerate(cyls) if cy is not None]
    if not good:
        return []
    widths = np.array([cy.r for _, cy in good])
    if float(widths.max() / widths.min()) > 1.0 + width_spread:
        return []
    return [(i, d, *view_from(images[i], cy, d)) for i, cy in good for d in raises]


def raised_cylinders(
    masks: Sequence[NDArray[np.bool_] | None], *, width_spread: float = 0.05
) -> list[Cylinder | None]:
    """Each view's cylinder as :func:`elevated_views` raises it (all None: not a cylinder)."""
    cyls = _cylinders(masks)
    widths = np.array([cy.r for cy in cyls if cy is not None])
    if not len(widths) or float(widths.max() / widths.min()) > 1.0 + width_spread:
        return [None] * len(masks)
    return cyls
