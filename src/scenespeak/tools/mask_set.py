"""A frozen set of mask pairs for measuring outline simplification (issue 16).

Pairs of disjoint boolean masks at 64²–1024², generated from a fixed seed, on which the
mask-outline simplification rule of :mod:`scenespeak.spatial.forces.masks` is chosen
(the *tuning* seed) and then reported (the *validation* seed, never looked at while tuning).
Four kinds of object, each pair of one kind:

* ``convex``: a rasterised convex polygon of 5–40 vertices on an ellipse;
* ``star``: a rasterised star-shaped polygon of 8–200 vertices with random radii (jagged);
* ``blob``: a rasterised smooth blob (random low-frequency radius, 240 vertices);
* ``field``: a thresholded smoothed random field (a segmentation-like outline with holes and
  islands; no polygon behind it).

Polygons are rasterised by pixel centres (``skimage.draw.polygon``) in the convention of the
force histograms: pixel ``(row, col)`` has its centre at ``(x, y) = (col, -row)``, so for the
first three kinds the exact polygon is kept beside the mask. The bench cases of
``benchmarks/bench_forces.py`` are not in the set (other shapes, seeds and placements).

Examples
--------
>>> pairs = mask_pairs(TUNING_SEED, sizes=(64,), per_kind=1)
>>> [(p.kind, p.size, p.polygon_a is not None) for p in pairs]
[('convex', 64, True), ('star', 64, True), ('blob', 64, True), ('field', 64, False)]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: The seed the simplification rule was chosen on.
TUNING_SEED = 1605
#: The seed its figures are reported on (never used while choosing the rule).
VALIDATION_SEED = 2716
#: Image sizes of the set (square images).
SIZES = (64, 128, 256, 512, 1024)
#: Object kinds, in the order pairs are generated.
KINDS = ("convex", "star", "blob", "field")


@dataclass(frozen=True)
class MaskPair:
    """Two disjoint masks of one image, and the polygons they were rasterised from (if any).

    ``gap`` is the smallest distance in pixels between a pixel centre of ``a`` and one of
    ``b``; ``polygon_a`` / ``polygon_b`` are ``(N, 2)`` in ``(x, y) = (col, -row)``.
    """

    name: str
    kind: str
    size: int
    a: BoolArray
    b: BoolArray
    polygon_a: FloatArray | None
    polygon_b: FloatArray | None
    gap: float


def _convex(rng: np.random.Generator, radius: float) -> FloatArray:
    n = int(rng.integers(5, 41))
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    aspect = rng.uniform(0.4, 1.0)
    tilt = rng.uniform(0, np.pi)
    x, y = radius * np.cos(ang), aspect * radius * np.sin(ang)
    c, s = np.cos(tilt), np.sin(tilt)
    return np.column_stack([c * x - s * y, s * x + c * y])


def _star(rng: np.random.Generator, radius: float) -> FloatArray:
    n = int(rng.integers(8, 201))
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = radius * rng.uniform(rng.uniform(0.3, 0.9), 1.0, n)
    return np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])


def _blob(rng: np.random.Generator, radius: float) -> FloatArray:
    ang = np.linspace(0, 2 * np.pi, 240, endpoint=False)
    rad = np.ones_like(ang)
    for k in range(2, 7):
        rad += rng.normal(0, 0.25 / k) * np.cos(k * ang + rng.uniform(0, 2 * np.pi))
    rad = radius * np.clip(rad, 0.35, None) / rad.max()
    return np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])


def _field(rng: np.random.Generator, radius: float) -> BoolArray:
    """A segmentation-like mask in a ``2R + 1`` square: smoothed noise inside a soft disc."""
    from scipy import ndimage

    side = 2 * int(np.ceil(radius)) + 1
    noise = ndimage.gaussian_filter(rng.normal(size=(side, side)), max(1.0, radius / 6))
    noise /= noise.std()
    yy, xx = np.mgrid[:side, :side] - (side - 1) / 2
    mask = noise + 2.5 * (1.0 - np.hypot(yy, xx) / radius) > 0.6
    mask &= np.hypot(yy, xx) <= radius
    labels, count = ndimage.label(mask, structure=np.ones((3, 3)))
    if count == 0:
        mask[side // 2, side // 2] = True
        return mask
    sizes = np.bincount(labels.ravel())[1:]
    big = 1 + int(np.argmax(sizes))
    # Keep the largest component and the islands of at least 4 pixels near it.
    keep = np.flatnonzero(sizes >= 4) + 1
    return np.isin(labels, keep) | (labels == big)


def _rasterise(poly: FloatArray, size: int) -> BoolArray:
    """Pixels whose centre ``(col, -row)`` is inside ``poly``."""
    from skimage.draw import polygon as raster_polygon

    mask = np.zeros((size, size), bool)
    rr, cc = raster_polygon(-poly[:, 1], poly[:, 0], mask.shape)
    mask[rr, cc] = True
    return mask


def _place(local: BoolArray, size: int, top_left: tuple[int, int]) -> BoolArray | None:
    """``local`` pasted at ``top_left`` of a ``size`` image, or None if it does not fit."""
    r, c = top_left
    h, w = local.shape
    if r < 1 or c < 1 or r + h > size - 1 or c + w > size - 1:
        return None
    out = np.zeros((size, size), bool)
    out[r : r + h, c : c + w] = local
    return out


def _gap(a: BoolArray, b: BoolArray) -> float:
    """Smallest distance between pixel centres of ``a`` and ``b`` (0 if they share one)."""
    from scipy import ndimage

    dist = ndimage.distance_transform_edt(~a)
    return float(np.asarray(dist)[b].min())


@dataclass(frozen=True)
class _Edges:
    start: FloatArray
    end: FloatArray


def _polygons_meet(pa: FloatArray, pb: FloatArray) -> bool:
    """Whether the boundaries of two polygons come within 1e-9 of each other."""
    from scenespeak.geometry.polygons import boundaries_touch, cyclic_next

    a, b = _Edges(pa, cyclic_next(pa)), _Edges(pb, cyclic_next(pb))
    return boundaries_touch(a, b, 1e-9)


def _shape(rng: np.random.Generator, kind: str, radius: float) -> FloatArray | BoolArray:
    """One object of ``kind`` around the origin: a polygon, or a local mask (``field``)."""
    if kind == "field":
        return _field(rng, radius)
    return {"convex": _convex, "star": _star, "blob": _blob}[kind](rng, radius)


def _at(
    shape: FloatArray | BoolArray, centre: FloatArray, size: int
) -> tuple[BoolArray | None, FloatArray | None]:
    """``shape`` centred at ``centre`` (x, y) in a ``size`` image: its mask and polygon."""
    if shape.dtype == np.bool_:
        half = (shape.shape[0] - 1) // 2
        top_left = (round(float(-centre[1])) - half, round(float(centre[0])) - half)
        return _place(np.asarray(shape, dtype=np.bool_), size, top_left), None
    poly = np.asarray(shape, dtype=np.float64) + centre
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    if lo[0] < 1 or hi[0] > size - 2 or -hi[1] < 1 or -lo[1] > size - 2:
        return None, None
    return _rasterise(poly, size), poly


def _placed(
    shapes: tuple[FloatArray | BoolArray, FloatArray | BoolArray],
    centres: tuple[FloatArray, FloatArray],
    size: int,
) -> tuple[BoolArray, BoolArray, FloatArray | None, FloatArray | None, float] | None:
    """Both shapes placed, their gap measured; None if one leaves the image or they meet."""
    a, pa = _at(shapes[0], centres[0], size)
    b, pb = _at(shapes[1], centres[1], size)
    if a is None or b is None or not a.any() or not b.any():
        return None
    measured = _gap(a, b)
    if measured < 1.5:  # touching or overlapping pixels: F2 is undefined there
        return None
    if pa is not None and pb is not None and _polygons_meet(pa, pb):
        return None  # a spike between pixel centres can reach the other polygon
    return a, b, pa, pb, measured


def _pair(rng: np.random.Generator, kind: str, size: int, name: str) -> MaskPair | None:
    """One attempt at a disjoint pair, its gap near (1.5–6 px), mid or far.

    The objects are placed ``ra + rb + gap`` apart, then (near pairs) moved closer along
    the line of centres until the measured gap is at most 6 px (three steps at most).
    """
    ra, rb = (max(r, 3.0) for r in rng.uniform(0.07, 0.24, 2) * size)
    gap_class = int(rng.integers(3))
    lo_hi = ((1.5, 4.0), (0.1, 0.6), (0.6, 1.5))[gap_class]
    gap = rng.uniform(*lo_hi) * (1.0 if gap_class == 0 else ra + rb)
    phi = rng.uniform(0, 2 * np.pi)
    unit = np.array([np.cos(phi), np.sin(phi)])
    mid = np.array([size / 2, -size / 2]) + rng.uniform(-0.1, 0.1, 2) * size
    shapes = (_shape(rng, kind, ra), _shape(rng, kind, rb))
    dist = ra + rb + gap
    got = _placed(shapes, (mid - 0.5 * dist * unit, mid + 0.5 * dist * unit), size)
    for _ in range(3 if gap_class == 0 else 0):
        if got is None or got[4] <= 6.0:
            break
        dist -= got[4] - gap
        got = _placed(shapes, (mid - 0.5 * dist * unit, mid + 0.5 * dist * unit), size)
    if got is None or (gap_class == 0 and got[4] > 6.0):
        return None
    a, b, pa, pb, measured = got
    return MaskPair(name, kind, size, a, b, pa, pb, measured)


def digest(pairs: list[MaskPair]) -> str:
    """SHA-256 of the pairs' names and mask bits: pins the frozen set (tests, docs)."""
    import hashlib

    h = hashlib.sha256()
    for pair in pairs:
        h.update(pair.name.encode())
        h.update(np.packbits(pair.a).tobytes())
        h.update(np.packbits(pair.b).tobytes())
    return h.hexdigest()


def mask_pairs(seed: int, *, sizes: tuple[int, ...] = SIZES, per_kind: int = 3) -> list[MaskPair]:
    """The frozen set: ``per_kind`` disjoint pairs of each kind at each size, from ``seed``.

    Deterministic, and each ``(size, kind)`` has its own generator (seeded by ``seed``, the
    size and the kind's index), so a subset of sizes holds the same pairs as the whole set;
    attempts that overlap, touch or leave the image are redrawn from that generator.
    """
    out: list[MaskPair] = []
    for size in sizes:
        for k, kind in enumerate(KINDS):
            rng = np.random.default_rng([seed, size, k])
            made = 0
            while made < per_kind:
                pair = _pair(rng, kind, size, f"{kind}-{size}-{made}")
                if pair is not None:
                    out.append(pair)
                    made += 1
    return out
