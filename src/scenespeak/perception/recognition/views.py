"""Training views: an image (and mask) → SIFT features inside the object and its outline."""

from __future__ import annotations

import dataclasses
import math
import sqlite3
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from os import PathLike

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import ImageError
from scenespeak.perception.features import Features, as_mask, detect, load_image, to_gray
from scenespeak.perception.recognition.colour import chromatic_pixels, view_colour
from scenespeak.perception.recognition.grey import view_grey

__all__ = ["ImageLike", "MaskLike", "outline_from_mask"]


ImageLike = str | PathLike[str] | NDArray[np.generic]
MaskLike = str | PathLike[str] | NDArray[np.generic] | None


# --------------------------------------------------------------------------------------------
# Training views
# --------------------------------------------------------------------------------------------


#: How the source of a synthesised view ends (``"view_00.png seen 18 degrees higher"``), for
#: people reading ``db list``; the labelling tells these views by the ``raised_views`` table
#: (:func:`record_raised`), never by the name (an image may be called anything).
RAISED_SOURCE = " degrees higher"
#: Each synthesised view and the learnt view of the same ``db add`` it comes from; created by
#: the first ``db add`` that synthesises one (a database without it has no synthesised view).
_RAISED_TABLE = (
    "CREATE TABLE IF NOT EXISTS raised_views "
    "(view_id INTEGER PRIMARY KEY, source_view INTEGER NOT NULL)"
)


def record_raised(conn: sqlite3.Connection, views: Sequence[_ViewData], ids: Sequence[int]) -> None:
    """Write which of ``views`` (stored as rows ``ids``, in one transaction) were synthesised,
    and from which of them (:attr:`_ViewData.raised_from`)."""
    pairs = [(ids[k], ids[v.raised_from]) for k, v in enumerate(views) if v.raised_from is not None]
    if pairs:
        conn.execute(_RAISED_TABLE)
        conn.executemany("INSERT INTO raised_views(view_id, source_view) VALUES (?, ?)", pairs)


def insert_view(conn: sqlite3.Connection, oid: int, v: _ViewData) -> int:
    """Write one training view of object ``oid``: its features as BLOBs and its outline; its
    row id."""
    f = v.features
    kp = np.column_stack([f.xy, f.size, f.angle]).astype(np.float32)
    cur = conn.execute(
        "INSERT INTO views(object_id, source, width, height, has_mask, n, "
        "descriptors, keypoints, outline) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
        (
            oid,
            v.source,
            v.width,
            v.height,
            int(v.has_mask),
            len(f),
            np.ascontiguousarray(f.descriptors, np.uint8).tobytes(),
            kp.tobytes(),
            np.ascontiguousarray(v.outline, np.float32).tobytes(),
        ),
    )
    vid = int(cur.lastrowid or 0)
    row = v.colour_row()
    if row is not None:
        conn.execute(
            "INSERT INTO view_colours(view_id, signature, aspect, grey, grey_aspect) "
            "VALUES (?, ?, ?, ?, ?)",
            (vid, *row),
        )
    return vid


def forget_raised(conn: sqlite3.Connection, oid: int) -> None:
    """Delete the ``raised_views`` rows of object ``oid``'s views (before the views go: a
    later view may take a deleted view's row id)."""
    if has_raised_table(conn):
        conn.execute(
            "DELETE FROM raised_views WHERE view_id IN (SELECT id FROM views WHERE object_id = ?)",
            (oid,),
        )


def has_raised_table(conn: sqlite3.Connection) -> bool:
    """Whether the database has a ``raised_views`` table (some ``db add`` synthesised views)."""
    q = "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'raised_views'"
    return conn.execute(q).fetchone() is not None


def outline_from_mask(mask: NDArray[np.generic], *, tolerance: float = 1.0) -> NDArray[np.float32]:
    """Outline of the largest region of a mask, as a simplified polygon.

    Parameters
    ----------
    mask : (H, W) array
        Non-zero where the object is.
    tolerance : float
        Douglas–Peucker tolerance in pixels.

    Returns
    -------
    (M, 2) float32
        Vertices (column, row), at least 3; empty ``(0, 2)`` if the mask is empty.

    Examples
    --------
    >>> m = np.zeros((50, 60), bool); m[10:20, 5:30] = True
    >>> outline_from_mask(m).tolist()
    [[5.0, 10.0], [5.0, 19.0], [29.0, 19.0], [29.0, 10.0]]
    """
    m = as_mask(mask).astype(np.uint8)
    number = int | float | np.integer | np.floating
    if isinstance(tolerance, bool) or not isinstance(tolerance, number):
        raise ImageError("tolerance", f"must be a number of pixels, got {tolerance!r:.40}")
    if not (math.isfinite(float(tolerance)) and tolerance >= 0):
        raise ImageError("tolerance", f"must be a finite number of pixels >= 0, got {tolerance}")
    contours, _ = cv2.findContours(m, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if not contours:
        return np.zeros((0, 2), np.float32)
    biggest = max(contours, key=lambda c: (cv2.contourArea(c), len(c)))
    poly = cv2.approxPolyDP(biggest, tolerance, True).reshape(-1, 2)
    if poly.shape[0] < 3:
        poly = biggest.reshape(-1, 2)
    if poly.shape[0] < 3:  # a one-pixel-thin region: use its bounding box
        x, y, w, h = cv2.boundingRect(biggest)
        poly = np.array([[x, y], [x + w - 1, y], [x + w - 1, y + h - 1], [x, y + h - 1]])
    return poly.astype(np.float32)


def _border_outline(width: int, height: int) -> NDArray[np.float32]:
    return np.array(
        [[-0.5, -0.5], [width - 0.5, -0.5], [width - 0.5, height - 0.5], [-0.5, height - 0.5]],
        np.float32,
    )


@dataclass(frozen=True)
class _ViewData:
    source: str
    width: int
    height: int
    has_mask: bool
    features: Features
    outline: NDArray[np.float32]
    #: the colour signature and chromatic-box aspect inside the mask (None: no mask, or gray)
    colour: tuple[NDArray[np.float32], float] | None = None
    #: the grey signature and object-box aspect inside the mask (None: no colour signature)
    grey: tuple[NDArray[np.float32], float] | None = None
    #: for a view synthesised from another (:func:`raised_views`): that view's place among the
    #: views of the same ``db add`` (None: a learnt view)
    raised_from: int | None = None

    def colour_row(self) -> tuple[bytes, float, bytes | None, float | None] | None:
        """The view's ``view_colours`` row after its id: colour signature, aspect, grey
        signature, grey aspect (None: no colour signature, no row)."""
        if self.colour is None:
            return None
        sig = np.ascontiguousarray(self.colour[0], np.float32).tobytes()
        if self.grey is None:
            return sig, float(self.colour[1]), None, None
        grey = np.ascontiguousarray(self.grey[0], np.float32).tobytes()
        return sig, float(self.colour[1]), grey, float(self.grey[1])


def _source_name(item: object, i: int, kind: str) -> str:
    if isinstance(item, str | PathLike):
        return str(item)
    return f"<{kind} array {i}>"


def _read_image(item: ImageLike, i: int) -> NDArray[np.uint8]:
    if isinstance(item, str | PathLike):
        return load_image(item, gray=True)
    try:
        return to_gray(np.asarray(item))
    except ImageError as exc:
        raise ImageError(_source_name(item, i, "image"), exc.problem) from None


_Signature = tuple[NDArray[np.float32], float]


def _colour_of(
    item: ImageLike, mask: NDArray[np.bool_], gray: NDArray[np.uint8]
) -> tuple[_Signature, _Signature] | None:
    """The colour signature inside ``mask`` of an RGB image (a file read again in colour),
    and the grey signature of ``gray`` (the image as learnt) there."""
    image = load_image(item, gray=False) if isinstance(item, str | PathLike) else np.asarray(item)
    if image.ndim != 3 or image.shape[:2] != mask.shape:
        return None
    colour = view_colour(image, mask)
    if colour is None:
        return None
    rows, cols = np.nonzero(mask)
    rgb: NDArray[np.uint8] = np.asarray(image[rows, cols, :3], np.uint8)
    return colour, view_grey(gray, mask, chromatic_pixels(rgb))


def _read_mask(item: MaskLike, i: int, shape: tuple[int, ...]) -> NDArray[np.bool_] | None:
    if item is None:
        return None
    name = _source_name(item, i, "mask")
    arr: NDArray[np.generic]
    if isinstance(item, str | PathLike):
        arr = load_image(item, gray=True)
    else:
        arr = np.asarray(item)
        if arr.ndim == 3:
            arr = np.asarray(arr.any(axis=2) if arr.dtype == bool else arr.max(axis=2))
    if arr.shape[:2] != shape:
        raise ImageError(
            name,
            f"mask size {arr.shape[:2]} differs from its image's {shape}; give one mask "
            "per image, the same size",
        )
    m = np.asarray(arr) != 0
    if not m.any():
        raise ImageError(name, "the mask is empty (no object pixels)")
    return m


def extract_views(
    images: Sequence[ImageLike],
    masks: Sequence[MaskLike],
    sift: tuple[int, float],
    progress: Callable[[int, int], object] | None = None,
    *,
    raise_cylinders: bool = True,
) -> list[_ViewData]:
    """Each training image's view (its features inside its mask, outline and signatures) with
    ``sift = (max_features, contrast_threshold)``; ``progress(done, total)`` after each; with
    ``raise_cylinders``, :func:`raised_views` after them."""
    out = []
    for i, (img, msk) in enumerate(zip(images, masks, strict=True)):
        out.append(_extract_view(img, msk, i, *sift))
        if progress is not None:
            progress(i + 1, len(images))
    if raise_cylinders:
        out += raised_views(images, masks, *sift)
    return out


def read_grey_views(
    images: Sequence[ImageLike], masks: Sequence[MaskLike]
) -> tuple[list[NDArray[np.uint8]], list[NDArray[np.bool_] | None]]:
    """Each training image in grey and its mask (None: no mask), checked as at ``db add``."""
    grays: list[NDArray[np.uint8]] = []
    ms: list[NDArray[np.bool_] | None] = []
    for i, (img, msk) in enumerate(zip(images, masks, strict=True)):
        gray = _read_image(img, i)
        grays.append(gray)
        ms.append(_read_mask(msk, i, gray.shape))
    return grays, ms


def raised_views(
    images: Sequence[ImageLike],
    masks: Sequence[MaskLike],
    max_features: int,
    contrast_threshold: float,
) -> list[_ViewData]:
    """Views of a cylinder from higher up (:mod:`~scenespeak.perception.recognition.
    cylinder_views`), synthesised from the masked training views; []  for an object that is
    not a cylinder or has no masks. Each keeps its features *at their places in the training
    view it comes from* (mapped back through the remap, :func:`~scenespeak.perception.
    recognition.cylinder_views.source_rows`) and that view's outline, so the labelling checks
    them with that view (:func:`~scenespeak.perception.recognition.loading.synthetic_of`):
    the same surface point's learnt and synthesised descriptors vote for one view, not two.
    No colour or grey signature: the cues keep the real views'."""
    from scenespeak.perception.recognition.cylinder_views import (
        RAISES,
        raised_cylinders,
        source_rows,
        view_from,
    )

    grays, ms = read_grey_views(images, masks)
    out = []
    for i, cyl in enumerate(raised_cylinders(ms)):
        mask = ms[i]
        if cyl is None or mask is None:
            continue
        h, w = grays[i].shape[:2]
        for raise_deg in RAISES:
            view, vmask = view_from(grays[i], cyl, raise_deg)
            feats = detect(
                view, mask=vmask, max_features=max_features, contrast_threshold=contrast_threshold
            )
            rows, _ = source_rows((h, w), cyl, raise_deg)
            col = np.clip(np.rint(feats.xy[:, 0]).astype(np.intp), 0, w - 1)
            row = np.clip(np.rint(feats.xy[:, 1]).astype(np.intp), 0, h - 1)
            back = rows[row, col]
            feats = feats.subset(back >= 0)
            if len(feats) == 0:
                continue
            xy = feats.xy.copy()
            xy[:, 1] = back[back >= 0]
            feats = dataclasses.replace(feats, xy=xy)
            source = f"{_source_name(images[i], i, 'image')} seen {raise_deg:g}{RAISED_SOURCE}"
            out.append(_ViewData(source, w, h, True, feats, outline_from_mask(mask), raised_from=i))
    return out


def _extract_view(
    image: ImageLike, mask: MaskLike, i: int, max_features: int, contrast_threshold: float
) -> _ViewData:
    gray = _read_image(image, i)
    h, w = gray.shape
    m = _read_mask(mask, i, (h, w))
    source = _source_name(image, i, "image")
    feats = detect(gray, mask=m, max_features=max_features, contrast_threshold=contrast_threshold)
    if len(feats) == 0:
        if m is not None and isinstance(mask, str | PathLike):
            raise ImageError(
                mask,
                f"no SIFT keypoints found inside this mask ({int(m.sum())} pixels) on {source}; "
                "use a mask that covers the object, or a sharper, more textured image",
            )
        raise ImageError(
            source,
            "no SIFT keypoints found"
            + (" inside the mask" if m is not None else "")
            + "; use a sharper, more textured or larger image of the object",
        )
    outline = outline_from_mask(m) if m is not None else _border_outline(w, h)
    cues = _colour_of(image, m, gray) if m is not None else None
    colour, grey = (None, None) if cues is None else cues
    return _ViewData(source, w, h, m is not None, feats, outline, colour, grey)
