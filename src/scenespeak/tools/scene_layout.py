"""Random layouts of the generator's scenes and the geometry they are checked with.

Part of :mod:`scenespeak.tools.scenes` (which re-exports :func:`sample_layout` and
:func:`footprint_relation`): footprints that keep ``CLEARANCE`` apart (separating axes), inside
both cameras' views, each visible enough; the true relation of two footprints.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.geometry.polygons import polygon_area, polygon_centroid
from scenespeak.tools.render import (
    Camera,
)
from scenespeak.tools.scene_configs import (
    GeneratorConfig,
    config_catalogue,
    config_choice,
)
from scenespeak.tools.scene_model import (
    CATALOGUE,
    CLEARANCE,
    DIAGONAL_TOLERANCE_DEG,
    SUPERSAMPLE,
    CatalogueObject,
    Placement,
    Rig,
)

# --------------------------------------------------------------------------------------------
# geometry


def _sat_gap(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """Largest separating gap between two convex polygons (negative when they overlap)."""
    best = -np.inf
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.c_[edges[:, 1], -edges[:, 0]]
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        pa, pb = a @ normals.T, b @ normals.T
        gap = np.maximum(pb.min(0) - pa.max(0), pa.min(0) - pb.max(0))
        best = max(best, float(gap.max()))
    return best


def _silhouette(cam: Camera, pl: Placement) -> NDArray[np.float64]:
    """Convex silhouette of a placed object in final-image pixels."""
    uv = cam.project(pl.corners_world(), SUPERSAMPLE).astype(np.float32)
    return cv2.convexHull(uv).reshape(-1, 2).astype(np.float64)


def _raster(poly: NDArray[np.float64], size: tuple[int, int], scale: float) -> NDArray[np.bool_]:
    w, h = size
    img = np.zeros((int(h * scale), int(w * scale)), np.uint8)
    pts = np.round((poly + 0.5) * scale * 16 - 8).astype(np.int32)
    cv2.fillPoly(img, [pts], 1, lineType=cv2.LINE_8, shift=4)
    return img.astype(bool)


def _poly_area(poly: NDArray[np.float64]) -> float:
    """Unsigned shoelace area (``geometry.polygons.polygon_area``)."""
    return abs(polygon_area(np.asarray(poly, dtype=np.float64)))


def footprint_relation(
    argument: NDArray[np.float64], referent: NDArray[np.float64]
) -> tuple[str, float, bool]:
    """Ground-truth relation of two footprints in the horizontal plane's 2-D frame.

    The direction of the vector from the referent's footprint centroid to the argument's gives
    the primary direction: the nearest of 0° right, 90° behind, 180° left, 270° front. The
    relation is ambiguous (on this count) when that direction is within ±20° of a diagonal, or
    when the footprints overlap.

    Returns
    -------
    primary, angle_deg, ambiguous

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]])
    >>> footprint_relation(sq - [3, 0], sq)[0]
    'left'
    >>> footprint_relation(sq + [0, 3], sq)[0]
    'behind'
    """
    ca, cr = polygon_centroid(argument), polygon_centroid(referent)
    v = ca - cr
    angle = float(np.degrees(np.arctan2(v[1], v[0])) % 360.0)
    names = ("right", "behind", "left", "front")
    primary = names[int(np.round(angle / 90.0)) % 4]
    off = abs(((angle - 45.0) % 90.0) - 45.0)  # distance to the nearest axis, 0..45
    diagonal = off > 45.0 - DIAGONAL_TOLERANCE_DEG
    overlap = _sat_gap(np.asarray(argument, float), np.asarray(referent, float)) <= 0
    return primary, angle, bool(diagonal or overlap)


# --------------------------------------------------------------------------------------------
# layouts


def sample_layout(
    seed: int | Sequence[int],
    rig: Rig,
    *,
    catalogue: Sequence[CatalogueObject] | GeneratorConfig = CATALOGUE,
    n_objects: int | None = None,
    stacked: bool = False,
    distance_range: tuple[float, float] = (0.5, 2.0),
    min_visible: float = 0.6,
    max_tries: int = 4000,
) -> tuple[Placement, ...]:
    """Random layout of 3-5 distinct catalogue objects on the floor, fixed by ``seed``.

    Objects stand on the floor (one may stand on another when ``stacked``), their centroids
    ``distance_range`` metres from the left camera, footprints at least 3 cm apart, wholly
    inside both images, and each at least ``min_visible`` unoccluded (estimated from the
    silhouettes in depth order). ``catalogue`` may be a ``GeneratorConfig`` (its own mix).
    """
    rng = np.random.default_rng(seed)
    config = catalogue if isinstance(catalogue, GeneratorConfig) else None
    objects: Sequence[CatalogueObject] = (
        config_catalogue(config)
        if config is not None
        else cast(Sequence[CatalogueObject], catalogue)
    )
    if config is not None:
        min_visible = config.min_visible
        lo, hi = config.n_objects
        n_objects = int(rng.integers(lo, hi + 1))
    n = int(n_objects) if n_objects is not None else int(rng.integers(3, 6))
    if config is None and not 1 <= n <= len(objects):
        raise InputError("n_objects", f"must be between 1 and {len(objects)}, got {n}")
    left, right = rig.camera("left"), rig.camera("right")
    w, h = rig.image_size
    half = np.tan(np.radians(rig.hfov_deg) / 2)
    for _ in range(50):
        if config is not None:
            chosen = config_choice(rng, config, objects, n)
        else:
            chosen = [objects[i] for i in rng.choice(len(objects), n, replace=False)]
        placed: list[Placement] = []
        top: CatalogueObject | None = None
        if stacked and n >= 2:
            top = chosen[-1]
            chosen = chosen[:-1]
        for obj in chosen:
            for _t in range(max_tries // 50):
                y = rng.uniform(0.3, distance_range[1])
                x = rng.uniform(-half * y, half * y)
                yaw = rng.uniform(0, 360) if obj.shape == "cylinder" else rng.uniform(-35.0, 35.0)
                pl = Placement(obj, (float(x), float(y), 0.0), float(yaw))
                if _fits(pl, placed, left, right, rig, distance_range):
                    placed.append(pl)
                    break
            else:
                break
        if len(placed) != len(chosen):
            continue
        if top is not None:
            bases = [
                b
                for b in placed
                if b.obj.shape != "card"
                and _sat_gap(
                    Placement(top, (*b.position[:2], 0.0), 0.0).footprint_world(),
                    _shrink(b.footprint_world(), 0.005),
                )
                < -min(top.size[0], top.size[1]) * 0.999
            ]
            if not bases:
                continue
            base = bases[int(rng.integers(len(bases)))]
            pl = Placement(
                top,
                (base.position[0], base.position[1], base.obj.size[2]),
                float(rng.uniform(0, 360) if top.shape == "cylinder" else base.yaw_deg),
                on=base.obj.label,
            )
            if not _in_view(pl, left, right, w, h):
                continue
            placed.append(pl)
        if min(_visible_estimate(placed, left, rig.image_size)) >= min_visible:
            return tuple(placed)
    raise InputError(f"seed {seed}", "no layout found; use fewer objects or a wider range")


def _shrink(poly: NDArray[np.float64], by: float) -> NDArray[np.float64]:
    c = poly.mean(axis=0)
    d = poly - c
    r = np.linalg.norm(d, axis=1, keepdims=True)
    return c + d * np.maximum(r - by, 0) / r


def _in_view(pl: Placement, left: Camera, right: Camera, w: int, h: int) -> bool:
    for cam in (left, right):
        if (cam.to_camera(pl.corners_world())[:, 2] < 0.1).any():
            return False
        uv = cam.project(pl.corners_world(), SUPERSAMPLE)
        if uv.min() < 2 or (uv[:, 0] > w - 3).any() or (uv[:, 1] > h - 3).any():
            return False
    return True


def _fits(
    pl: Placement,
    placed: Sequence[Placement],
    left: Camera,
    right: Camera,
    rig: Rig,
    distance_range: tuple[float, float],
) -> bool:
    dist = float(np.linalg.norm(left.to_camera(pl.centroid_world()[None])[0]))
    if not distance_range[0] <= dist <= distance_range[1]:
        return False
    if not _in_view(pl, left, right, *rig.image_size):
        return False
    fp = pl.footprint_world()
    return all(_sat_gap(fp, q.footprint_world()) >= CLEARANCE for q in placed)


def _visible_estimate(
    placed: Sequence[Placement], cam: Camera, size: tuple[int, int]
) -> list[float]:
    scale = 0.25
    masks = [_raster(_silhouette(cam, p), size, scale) for p in placed]
    depth = [float(cam.to_camera(p.centroid_world()[None])[0, 2]) for p in placed]
    out = []
    for i, m in enumerate(masks):
        cover = np.zeros_like(m)
        for j, mj in enumerate(masks):
            if depth[j] < depth[i] and placed[i].on != placed[j].obj.label:
                cover |= mj
        total = max(int(m.sum()), 1)
        out.append(float((m & ~cover).sum()) / total)
    return out
