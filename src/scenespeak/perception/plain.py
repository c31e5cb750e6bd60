"""The plain background of a rendered or very clean image: where no stereo method measures.

Part of geometry first (:mod:`scenespeak.perception.regions`). SGBM gives a plain region the
disparity its aggregation paths carry in from the nearest texture, so the plain floor and sky
beside an object take the object's depth. :func:`plain_background` marks the plain pixels
connected to the image's border (grown up to the objects' edges); :func:`plain_parts` is what
:func:`~scenespeak.perception.regions.scene_geometry` takes from the left image alone.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from scenespeak.perception.regions import RegionOptions

__all__ = [
    "PLAIN_SHARE",
    "SEGMENT_STRIDE",
    "PlainParts",
    "plain_background",
    "plain_parts",
    "plain_pixels",
]


def _options(options: RegionOptions | None) -> RegionOptions:
    from scenespeak.perception.regions import RegionOptions

    return options or RegionOptions()


#: The plain background is left out of the segments (:attr:`SceneGeometry.plain`) when it
#: covers at least this share of the image (a rendered floor scene: 60-90 %; photo cards
#: before a textured wall: 0.005 %, whose few plain pixels are left as they are).
PLAIN_SHARE = 0.1

#: :func:`scene_geometry` segments every ``SEGMENT_STRIDE``-th pixel in both directions.
SEGMENT_STRIDE = 2

#: :func:`plain_parts`: the plain background for the support plane and the one the segments
#: leave out (on the segmentation's grid), and the full-size textured pixels; or all None.
PlainParts = tuple[NDArray[np.bool_] | None, NDArray[np.bool_] | None, NDArray[np.bool_] | None]


def plain_pixels(
    gray: NDArray[np.generic], options: RegionOptions | None = None, stride: int = 1
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """On the ``stride`` grid: the plain pixels (mean absolute gradient, horizontal plus
    vertical Sobel / 8, over the ``texture_window`` square at most ``min_texture``), and the
    pixels with only a vertical gradient (a horizontal edge). Both all False when
    ``min_texture`` is 0.

    >>> img = np.zeros((20, 20), np.uint8); img[10:] = 90
    >>> plain, edge = plain_pixels(img)
    >>> bool(plain[2, 5]), bool(edge[10, 5]), bool(plain[10, 5])
    (True, True, False)
    """
    plain, edge, _fine, _reach = _plain_masks(gray, _options(options), stride)
    return plain, edge


def _plain_masks(
    gray: NDArray[np.generic], opts: RegionOptions, stride: int
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_] | None, int]:
    """:func:`plain_pixels`' two masks, the pixels plain over the ``edge_window`` square
    (None when ``edge_window`` is 0), on the ``stride`` grid, and how many grid steps the
    larger window reaches past an edge (its half side and the Sobel's pixel)."""
    g = np.asarray(gray)
    if g.ndim == 3:
        g = cv2.cvtColor(np.ascontiguousarray(g[..., :3]), cv2.COLOR_RGB2GRAY)
    st = max(int(stride), 1)
    shape = g[::st, ::st].shape
    if opts.min_texture <= 0:
        return np.zeros(shape, bool), np.zeros(shape, bool), None, 0
    f = np.asarray(g, np.float32)
    win = (max(int(opts.texture_window), 1),) * 2
    limit = opts.min_texture * 8  # a Sobel response is 8 x the gray levels per pixel
    ax = np.abs(cv2.Sobel(f, cv2.CV_32F, 1, 0, ksize=3))
    ay = np.abs(cv2.Sobel(f, cv2.CV_32F, 0, 1, ksize=3))
    gx = np.asarray(cv2.boxFilter(ax, -1, win))[::st, ::st]
    gy = np.asarray(cv2.boxFilter(ay, -1, win))[::st, ::st]
    plain = gx + gy <= limit
    fine = None
    if opts.edge_window > 0:
        small = (int(opts.edge_window),) * 2
        fine = np.asarray(cv2.boxFilter(ax + ay, -1, small))[::st, ::st] <= limit
    reach = -(-(int(opts.texture_window) // 2 + 1) // st)
    return plain, (gx <= limit) & ~plain, fine, reach


def plain_background(
    gray: NDArray[np.generic], options: RegionOptions | None = None, stride: int = 1
) -> NDArray[np.bool_]:
    """Plain pixels connected to the image's border through plain pixels (on the ``stride``
    grid): the floor and the sky, where SGBM's depth is carried in from elsewhere.

    A pixel is plain when the mean absolute gradient (horizontal plus vertical Sobel, / 8)
    over the ``texture_window`` square round it is at most ``min_texture`` (a box's top edge
    is a horizontal line: it must close the face it bounds; :func:`plain_pixels`). Plain
    pixels that textured ones enclose — the plain face of a box inside its edges — are not
    background; pixels with only a vertical gradient (a horizontal edge: the horizon, a box's
    top edge) are, since a match along rows finds no disparity there. The border's plain
    regions are then grown through the pixels plain over the smaller ``edge_window`` square
    up to the objects' edges, as deep as the band the larger window added and no deeper
    (:func:`_background`). All False when ``min_texture`` is 0.

    Examples
    --------
    >>> img = np.full((40, 60), 120, np.uint8)
    >>> img[10:30, 20:40] = 200                  # a plain box face, its edges textured
    >>> bg = plain_background(img)
    >>> bool(bg[2, 2]), bool(bg[20, 30]), bool(bg[20, 20]), bool(bg[10, 30])
    (True, False, False, True)
    """
    return _background(*_plain_masks(gray, _options(options), stride))


def _background(
    plain: NDArray[np.bool_],
    edge: NDArray[np.bool_],
    fine: NDArray[np.bool_] | None = None,
    reach: int = 0,
) -> NDArray[np.bool_]:
    """:func:`plain_background` of :func:`plain_pixels`' two masks; with ``fine`` (the pixels
    plain over the smaller ``edge_window`` square) the border's plain regions are grown
    ``reach`` steps (4-neighbours, on the masks' grid) through ``fine`` pixels: the band that
    the larger window made textured round each object, and no deeper (a face of one flat
    colour that meets the floor at a faint edge would otherwise be flooded). Only they seed
    the growth: a horizontal edge's band also covers the plain face below it."""
    if not plain.any():
        return np.asarray(edge)
    n, lab = cv2.connectedComponents(plain.astype(np.uint8), connectivity=4)
    border = np.unique(np.r_[lab[0], lab[-1], lab[:, 0], lab[:, -1]])
    open_ = np.zeros(n, bool)
    open_[border] = True
    open_[0] = False  # label 0: the textured pixels
    seed = open_[lab]
    if fine is not None and reach > 0:
        cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
        grown = seed.astype(np.uint8)
        allowed = (fine | seed).astype(np.uint8)
        for _ in range(reach):
            grown = cv2.dilate(grown, cross) & allowed
        seed = grown.astype(bool)
    return np.asarray(seed | edge)


def plain_parts(
    image: NDArray[np.generic] | None,
    shape: tuple[int, int],
    options: RegionOptions,
    stride: int = SEGMENT_STRIDE,
) -> PlainParts:
    """What :func:`scene_geometry` takes from the left ``image`` alone: its plain background
    on the ``stride`` grid for the support plane (:func:`plain_pixels`' masks, not grown), the
    one the segments leave out (grown up to the objects' edges, :func:`plain_background`),
    and the full-size mask of its pixels that are not plain (:attr:`SceneGeometry.textured`);
    ``(None, None, None)`` without an image of the map's ``shape`` or when the background
    covers less than :data:`PLAIN_SHARE` of it.

    It needs no stereo, so the pipeline computes it in the thread that labels while the other
    one matches (``scene_geometry(..., plain=)``).

    >>> img = np.zeros((40, 60), np.uint8); img[10:30, 20:40] = 200
    >>> from scenespeak.perception.regions import RegionOptions
    >>> background, outside, textured = plain_parts(img, (40, 60), RegionOptions())
    >>> background.shape, textured.shape, bool(background[0, 0]), bool(textured[10, 30])
    ((20, 30), (40, 60), True, True)
    >>> bool((outside >= background).all())
    True
    """
    h, w = shape
    if image is None or np.asarray(image).shape[:2] != (h, w):
        return None, None, None
    st = max(int(stride), 1)
    plain, horizontal, fine, reach = _plain_masks(image, options, st)
    background = _background(plain, horizontal)
    if float(background.mean()) < PLAIN_SHARE:
        return None, None, None  # a textured scene: its depth is measured, leave it as it is
    # the segments also lose the band of floor the texture window adds round each object;
    # the support plane keeps its points (on a plain floor, the objects' feet and the floor
    # just below them are all it has to go by)
    outside = _background(plain, horizontal, fine, reach)
    textured = np.repeat(np.repeat(~plain, st, axis=0), st, axis=1)[:h, :w]
    return background, outside, textured
