"""Rendered stereo scenes of textured household objects, with their ground truth.

pybullet's CPU TinyRenderer (``pip install scenespeak[scenes]``) renders boxes, cylinders and
flat cards textured with photographs that ship with scikit-image, standing on a plain floor
0.5–2 m in front of a parallel stereo rig (level or pitched), like the paper's experiment. Every
scene folder holds the stereo pair, its calibration, a label image and ``truth.json``: each
object's centroid, footprint, distance and visible fraction, and the reference relation of every
ordered pair. ``objects/<label>/`` holds training views with masks for the object database.
The folder format and the ground-truth rule are documented in ``docs/scenes.md``.

Examples
--------
>>> from scenespeak.scenes import generate_dataset, load_dataset, load_truth
>>> ds = generate_dataset("scenes", n_scenes=2, seed=0)  # doctest: +SKIP
>>> truth = load_truth(load_dataset(ds).scenes[0])  # doctest: +SKIP
>>> [(r.argument, r.referent, r.primary) for r in truth.relations][:1]  # doctest: +SKIP
[('mug', 'box', 'left')]
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any, Literal

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak import _render
from scenespeak.calibration import ground_basis
from scenespeak.errors import InputError

__all__ = [
    "CATALOGUE",
    "DATASET_FORMAT",
    "CatalogueObject",
    "Dataset",
    "ObjectTruth",
    "Placement",
    "RelationTruth",
    "RigTruth",
    "SceneTruth",
    "generate_dataset",
    "generate_object_views",
    "generate_scene",
    "ground_truth_relations",
    "load_dataset",
    "load_truth",
    "primary_direction",
]

DATASET_FORMAT = "scenespeak-scenes/1"

#: Height of the left camera above the floor for a level and a pitched rig, metres.
LEVEL_CAMERA_HEIGHT = 0.20
PITCHED_CAMERA_HEIGHT = 0.50
#: Default downward pitch of a pitched rig, degrees.
DEFAULT_PITCH_DEG = 20.0
#: A relation is ambiguous when its direction is within this many degrees of a diagonal.
AMBIGUOUS_MARGIN_DEG = 20.0
#: ... or when either object is less visible than this in the left image.
AMBIGUOUS_VISIBLE_FRACTION = 0.5
#: Distance range of object centroids from the left camera, metres (the paper's 50–200 cm).
DISTANCE_RANGE = (0.5, 2.0)

Shape = Literal["box", "cylinder", "card"]
Direction = Literal["right", "behind", "left", "front"]
_DIRECTIONS: tuple[Direction, ...] = ("right", "behind", "left", "front")


@dataclass(frozen=True)
class CatalogueObject:
    """An object that scenes are made of.

    Attributes
    ----------
    label : str
        Its name (unique in a catalogue), used as the folder name of its training views.
    shape : {"box", "cylinder", "card"}
        Box, upright cylinder, or a thin standing card (a box a few millimetres deep).
    size : (float, float, float)
        Width (x), depth (y) and height (z) in metres when it faces the camera; for a cylinder
        width and depth are its diameters.
    texture : str
        Name of the scikit-image photograph on its faces (``skimage.data.<texture>()``).
    """

    label: str
    shape: Shape
    size: tuple[float, float, float]
    texture: str

    def to_dict(self) -> dict[str, Any]:
        """The ``dataset.json`` entry of this object."""
        return {
            "label": self.label,
            "shape": self.shape,
            "size": list(self.size),
            "texture": self.texture,
        }


#: The default catalogue: sizes of real household objects, photographs from scikit-image.
CATALOGUE: tuple[CatalogueObject, ...] = (
    CatalogueObject("box", "box", (0.16, 0.06, 0.22), "astronaut"),
    CatalogueObject("mug", "cylinder", (0.085, 0.085, 0.095), "coffee"),
    CatalogueObject("can", "cylinder", (0.066, 0.066, 0.122), "rocket"),
    CatalogueObject("card", "card", (0.15, 0.004, 0.105), "chelsea"),
    CatalogueObject("book", "box", (0.15, 0.03, 0.21), "immunohistochemistry"),
    CatalogueObject("carton", "box", (0.095, 0.095, 0.20), "hubble_deep_field"),
    CatalogueObject("tin", "cylinder", (0.10, 0.10, 0.14), "colorwheel"),
)


@dataclass(frozen=True)
class Placement:
    """Where an object stands: floor position, turn about the vertical, base height.

    Attributes
    ----------
    label : str
        The catalogue label.
    x, y : float
        Position of the object's vertical axis on the floor, metres, in the horizontal plane's
        2-D frame (x right, y forward from the point below the left camera).
    yaw_deg : float
        Turn about the vertical axis, degrees, counter-clockwise seen from above; 0 = its front
        faces the camera.
    base : float
        Height of its bottom above the floor (0 on the floor; the top of another object when
        stacked).
    """

    label: str
    x: float
    y: float
    yaw_deg: float = 0.0
    base: float = 0.0


@dataclass(frozen=True)
class ObjectTruth:
    """The ground truth of one object of a scene (an entry of ``truth.json``)."""

    label: str
    index: int
    centroid: tuple[float, float, float]
    footprint: tuple[tuple[float, float], ...]
    distance: float
    visible_fraction: float
    shape: str = ""
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw_deg: float = 0.0
    base: float = 0.0
    bbox_left: tuple[int, int, int, int] = (0, 0, 0, 0)

    @property
    def footprint_array(self) -> NDArray[np.float64]:
        """The footprint as an ``(N, 2)`` array."""
        return np.asarray(self.footprint, dtype=np.float64).reshape(-1, 2)


@dataclass(frozen=True)
class RelationTruth:
    """The reference relation of an ordered pair: where the argument is from the referent."""

    argument: str
    referent: str
    primary: Direction
    ambiguous: bool
    angle_deg: float = float("nan")
    reason: str = ""


@dataclass(frozen=True)
class RigTruth:
    """The rig a scene was rendered with."""

    pitch_deg: float
    baseline: float
    hfov_deg: float
    image_size: tuple[int, int]
    camera_height: float = 0.0


@dataclass(frozen=True)
class SceneTruth:
    """Everything ``truth.json`` says about a scene.

    Attributes
    ----------
    scene_dir : Path
        The scene folder.
    objects : tuple of ObjectTruth
        The objects, in the order of their index in ``left_labels.png`` (index 1 first).
    relations : tuple of RelationTruth
        Every ordered pair of distinct objects.
    rig : RigTruth
        The rig.
    up : (float, float, float)
        The world's up direction in the left camera frame (as in ``calib.json``).
    """

    scene_dir: Path
    objects: tuple[ObjectTruth, ...]
    relations: tuple[RelationTruth, ...]
    rig: RigTruth
    up: tuple[float, float, float] = (0.0, -1.0, 0.0)

    @property
    def left(self) -> Path:
        """The left image."""
        return self.scene_dir / "left.png"

    @property
    def right(self) -> Path:
        """The right image."""
        return self.scene_dir / "right.png"

    @property
    def calib(self) -> Path:
        """The calibration file."""
        return self.scene_dir / "calib.json"

    @property
    def labels(self) -> tuple[str, ...]:
        """The object labels in index order."""
        return tuple(o.label for o in self.objects)

    def object(self, label: str) -> ObjectTruth:
        """The object called ``label`` (``KeyError`` if the scene has none)."""
        for o in self.objects:
            if o.label == label:
                return o
        raise KeyError(label)

    def relation(self, argument: str, referent: str) -> RelationTruth:
        """The relation of ``argument`` to ``referent`` (``KeyError`` if absent)."""
        for r in self.relations:
            if r.argument == argument and r.referent == referent:
                return r
        raise KeyError((argument, referent))


@dataclass(frozen=True)
class Dataset:
    """A generated dataset folder (see :func:`load_dataset`)."""

    path: Path
    seed: int
    objects: tuple[CatalogueObject, ...]
    scenes: tuple[Path, ...]
    complete: bool = True

    def views(self, label: str) -> tuple[Path, ...]:
        """The training views of ``label`` (images only; each has a ``*_mask.png``)."""
        d = self.path / "objects" / label
        return tuple(sorted(p for p in d.glob("view_*.png") if not p.stem.endswith("_mask")))


# --------------------------------------------------------------------------------------------
# geometry and the ground-truth rule


def _polygon_centroid(poly: NDArray[np.float64]) -> NDArray[np.float64]:
    x, y = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    c = x * y1 - x1 * y
    a = c.sum() / 2.0
    if abs(a) < 1e-15:
        return poly.mean(axis=0)
    return np.array([((x + x1) * c).sum(), ((y + y1) * c).sum()]) / (6.0 * a)


def _convex_overlap(a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """Whether two convex polygons overlap (separating-axis test; touching counts as apart)."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        for e in edges:
            n = np.array([-e[1], e[0]])
            if not np.any(n):
                continue
            pa, pb = a @ n, b @ n
            if pa.max() <= pb.min() + 1e-12 or pb.max() <= pa.min() + 1e-12:
                return False
    return True


def primary_direction(angle_deg: float) -> tuple[Direction, float]:
    """The nearest of the four directions to an angle and how far the angle is from a diagonal.

    Angles follow interfaces.md: 0° right, 90° behind, 180° left, 270° in front.

    Examples
    --------
    >>> primary_direction(100.0)
    ('behind', 35.0)
    >>> primary_direction(-40.0)
    ('right', 5.0)
    """
    a = float(angle_deg) % 360.0
    k = int(((a + 45.0) // 90.0) % 4)
    from_diagonal = abs((a % 90.0) - 45.0)
    return _DIRECTIONS[k], round(from_diagonal, 9)


def ground_truth_relations(
    footprints: Mapping[str, ArrayLike],
    visible_fraction: Mapping[str, float] | None = None,
    *,
    margin_deg: float = AMBIGUOUS_MARGIN_DEG,
    min_visible: float = AMBIGUOUS_VISIBLE_FRACTION,
) -> list[RelationTruth]:
    """The reference relation of every ordered pair of objects, from their footprints.

    The rule (documented in ``docs/scenes.md``): the direction of the vector from the
    referent's footprint centroid to the argument's, in the horizontal plane's 2-D frame, gives
    the angle; ``primary`` is the nearest of right (0°), behind (90°), left (180°) and front
    (270°). The relation is ``ambiguous`` when that angle is within ``margin_deg`` of a diagonal
    (45°, 135°, ...), when the two footprints overlap (one object stands on the other), or when
    either object is less than ``min_visible`` visible in the left image.

    Parameters
    ----------
    footprints : mapping of label to (N, 2) array
        Convex outlines in the horizontal plane.
    visible_fraction : mapping of label to float, optional
        Fraction of each object seen in the left image.

    Returns
    -------
    list of RelationTruth
        Pairs in the order of ``footprints`` (argument outer, referent inner).

    Examples
    --------
    >>> sq = lambda x, y: [[x, y], [x + 0.1, y], [x + 0.1, y + 0.1], [x, y + 0.1]]
    >>> rels = ground_truth_relations({"hat": sq(-0.5, 1.0), "mug": sq(0.0, 1.05)})
    >>> [(r.argument, r.primary, r.ambiguous) for r in rels]
    [('hat', 'left', False), ('mug', 'right', False)]
    """
    polys = {k: np.asarray(v, dtype=np.float64).reshape(-1, 2) for k, v in footprints.items()}
    cents = {k: _polygon_centroid(p) for k, p in polys.items()}
    vis = dict(visible_fraction or {})
    out: list[RelationTruth] = []
    for a in polys:
        for b in polys:
            if a == b:
                continue
            v = cents[a] - cents[b]
            angle = math.degrees(math.atan2(v[1], v[0])) % 360.0
            primary, from_diag = primary_direction(angle)
            reasons = []
            if from_diag < margin_deg:
                reasons.append(f"direction {angle:.1f} deg is within {margin_deg:g} deg of a diagonal")
            if _convex_overlap(polys[a], polys[b]):
                reasons.append("footprints overlap")
            hidden = [k for k in (a, b) if vis.get(k, 1.0) < min_visible]
            if hidden:
                reasons.append(f"{' and '.join(hidden)} less than {min_visible:.0%} visible")
            out.append(RelationTruth(a, b, primary, bool(reasons), round(angle, 6), "; ".join(reasons)))
    return out


def _outline(obj: CatalogueObject, n: int = 32) -> NDArray[np.float64]:
    """The object's outline on the floor around its own axis (N, 2), counter-clockwise."""
    w, d, _ = obj.size
    if obj.shape == "cylinder":
        t = 2 * np.pi * np.arange(n) / n
        return np.column_stack([w / 2 * np.cos(t), d / 2 * np.sin(t)])
    return np.array([[-w / 2, -d / 2], [w / 2, -d / 2], [w / 2, d / 2], [-w / 2, d / 2]])


def _world_vertices(obj: CatalogueObject, pl: Placement) -> NDArray[np.float64]:
    """Hull vertices of a placed object in world coordinates (N, 3)."""
    base = (
        _render.cylinder_vertices(obj.size, 32)
        if obj.shape == "cylinder"
        else _render.box_vertices(obj.size)
    )
    return _rotz(pl.yaw_deg) @ base.T + np.array([[pl.x], [pl.y], [pl.base + obj.size[2] / 2]])


def _rotz(deg: float) -> NDArray[np.float64]:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# --------------------------------------------------------------------------------------------
# layouts


def _rig(pitch_deg: float, camera_height: float | None, baseline: float, size, hfov):  # type: ignore[no-untyped-def]
    h = camera_height
    if h is None:
        h = PITCHED_CAMERA_HEIGHT if abs(pitch_deg) > 1e-9 else LEVEL_CAMERA_HEIGHT
    return h, _render.rig_cameras(
        height=h, pitch_deg=pitch_deg, baseline=baseline, image_size=size, hfov_deg=hfov
    )


def _hull_mask(px: NDArray[np.float64], size: tuple[int, int], scale: float) -> NDArray[np.bool_]:
    w, h = int(round(size[0] * scale)), int(round(size[1] * scale))
    hull = cv2.convexHull(((px + 0.5) * scale * 16).astype(np.int32))
    m = np.zeros((h, w), np.uint8)
    cv2.fillConvexPoly(m, hull, 1, lineType=cv2.LINE_8, shift=4)
    return m.astype(bool)


def _sample_layout(
    rng: np.random.Generator,
    objects: Sequence[CatalogueObject],
    cams: tuple[_render.Camera, _render.Camera],
    *,
    stack: bool,
    max_tries: int = 400,
) -> list[Placement]:
    """Random placements: on the floor, in both images, apart, mostly unoccluded."""
    left, right = cams
    size = (left.width, left.height)
    margin = 4.0
    half = math.radians(left.hfov_deg) / 2
    placed: list[tuple[CatalogueObject, Placement]] = []
    todo = list(objects)
    stacked_on: tuple[CatalogueObject, CatalogueObject] | None = None
    if stack and len(todo) >= 2:
        # the seed paper's mug-on-can case: the first cylinder (or last object) on the first box
        top = next((o for o in todo if o.shape == "cylinder"), todo[-1])
        bottom = next((o for o in todo if o is not top and o.shape != "card"), None)
        if bottom is not None:
            todo.remove(top)
            stacked_on = (top, bottom)
    for obj in todo:
        for _ in range(max_tries):
            rho = rng.uniform(*DISTANCE_RANGE)
            phi = rng.uniform(-half * 0.85, half * 0.85)
            pl = Placement(
                obj.label,
                float(rho * math.sin(phi)),
                float(rho * math.cos(phi)),
                float(rng.uniform(-30.0, 30.0)),
            )
            if _acceptable(obj, pl, placed, left, right, size, margin):
                placed.append((obj, pl))
                break
        else:
            raise RuntimeError(f"could not place {obj.label} after {max_tries} tries")
    if stacked_on is not None:
        top, bottom = stacked_on
        pb = next(p for o, p in placed if o is bottom)
        pl = Placement(top.label, pb.x, pb.y, float(rng.uniform(-30, 30)), bottom.size[2])
        placed.append((top, pl))
    order = {o.label: i for i, o in enumerate(objects)}
    placed.sort(key=lambda t: order[t[0].label])
    return [p for _, p in placed]


def _acceptable(
    obj: CatalogueObject,
    pl: Placement,
    placed: list[tuple[CatalogueObject, Placement]],
    left: _render.Camera,
    right: _render.Camera,
    size: tuple[int, int],
    margin: float,
) -> bool:
    V = _world_vertices(obj, pl).T
    centre = np.array([pl.x, pl.y, pl.base + obj.size[2] / 2])
    dist = float(np.linalg.norm(left.to_camera(centre[None])[0]))
    if not DISTANCE_RANGE[0] <= dist <= DISTANCE_RANGE[1]:
        return False
    for cam in (left, right):
        if np.any(cam.to_camera(V)[:, 2] < 0.1):
            return False
        px = cam.project(V)
        if (
            px[:, 0].min() < margin
            or px[:, 1].min() < margin
            or px[:, 0].max() > size[0] - 1 - margin
            or px[:, 1].max() > size[1] - 1 - margin
        ):
            return False
    fp = (_rotz(pl.yaw_deg)[:2, :2] @ _outline(obj).T).T + [pl.x, pl.y]
    scale = 0.25
    mine = _hull_mask(left.project(V), size, scale)
    area = max(int(mine.sum()), 1)
    for o2, p2 in placed:
        fp2 = (_rotz(p2.yaw_deg)[:2, :2] @ _outline(o2).T).T + [p2.x, p2.y]
        grown = fp2 + 0.03 * np.sign(fp2 - fp2.mean(axis=0))
        if _convex_overlap(fp, grown) or np.linalg.norm(_polygon_centroid(fp) - _polygon_centroid(fp2)) < 0.12:
            return False
        other = _hull_mask(left.project(_world_vertices(o2, p2).T), size, scale)
        if (mine & other).sum() / min(area, max(int(other.sum()), 1)) > 0.2:
            return False
    return True


# --------------------------------------------------------------------------------------------
# writing


def _calib_dict(
    pitch_deg: float, baseline: float, hfov_deg: float, size: tuple[int, int], left: _render.Camera
) -> tuple[dict[str, Any], list[float]]:
    a = math.radians(pitch_deg)
    up = [0.0, -math.cos(a) + 0.0, -math.sin(a) + 0.0]
    up = [round(u, 15) + 0.0 for u in up]
    if abs(pitch_deg) < 1e-9:
        return {
            "baseline": baseline,
            "hfov_deg": hfov_deg,
            "image_size": list(size),
            "up": up,
        }, up
    K = left.K.tolist()
    return {
        "image_size": list(size),
        "K_left": K,
        "K_right": K,
        "dist_left": [0.0] * 5,
        "dist_right": [0.0] * 5,
        "R": np.eye(3).tolist(),
        "T": [-baseline, 0.0, 0.0],
        "up": up,
    }, up


def _write_json(path: Path, data: Any) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def _write_assets(
    tmp: Path, objects: Iterable[CatalogueObject]
) -> dict[str, tuple[Path, Path]]:
    """Mesh and texture files of each object in ``tmp``: label -> (mesh, texture)."""
    out: dict[str, tuple[Path, Path]] = {}
    textures: dict[str, Path] = {}
    for o in objects:
        mesh = tmp / f"{o.label}.obj"
        text = _render.cylinder_obj(o.size) if o.shape == "cylinder" else _render.box_obj(o.size)
        mesh.write_text(text, encoding="utf-8")
        if o.texture not in textures:
            try:
                img = _render.texture_image(o.texture)
            except Exception as e:  # missing or undownloadable scikit-image data
                raise InputError(
                    f"texture {o.texture!r}",
                    f"skimage.data.{o.texture}() could not be loaded ({e}); pick another texture",
                ) from None
            textures[o.texture] = tmp / f"tex_{o.texture}.png"
            _render.write_png(textures[o.texture], img)
        out[o.label] = (mesh, textures[o.texture])
    return out


def _catalogue(objects: Sequence[CatalogueObject] | None) -> tuple[CatalogueObject, ...]:
    cat = tuple(CATALOGUE if objects is None else objects)
    labels = [o.label for o in cat]
    if not cat or len(set(labels)) != len(labels):
        raise InputError("objects", f"need a non-empty catalogue of unique labels, got {labels}")
    for o in cat:
        if o.shape not in ("box", "cylinder", "card"):
            raise InputError(o.label, f"shape must be box, cylinder or card, got {o.shape!r}")
        if len(o.size) != 3 or not all(math.isfinite(s) and s > 0 for s in o.size):
            raise InputError(o.label, f"size must be three positive metres, got {o.size}")
    return cat


def _check_rig_args(image_size: Sequence[int], hfov_deg: float, baseline: float) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in image_size)
    except (TypeError, ValueError):
        raise InputError("image_size", f"must be (width, height), got {image_size!r}") from None
    if w < 16 or h < 16:
        raise InputError("image_size", f"must be at least 16x16 pixels, got {w}x{h}")
    if not 1.0 < float(hfov_deg) < 170.0:
        raise InputError("hfov_deg", f"must be between 1 and 170 degrees, got {hfov_deg}")
    if not 0.0 < float(baseline) < 2.0:
        raise InputError("baseline", f"must be between 0 and 2 metres, got {baseline}")
    return w, h


def generate_scene(
    scene_dir: str | PathLike[str],
    *,
    seed: int = 0,
    index: int = 0,
    objects: Sequence[CatalogueObject] | None = None,
    layout: Sequence[Placement] | None = None,
    n_objects: int | tuple[int, int] = (3, 5),
    pitch_deg: float = 0.0,
    stack: bool = False,
    image_size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
    baseline: float = 0.12,
    camera_height: float | None = None,
) -> Path:
    """Render one scene into ``scene_dir`` (written atomically; replaced if it exists).

    A pure, picklable function: the scene depends only on its arguments, so scenes can be made
    in a process pool. Layouts are random from ``numpy.random.default_rng([seed, index])``
    unless ``layout`` gives the placements.

    Parameters
    ----------
    scene_dir : path
        The scene folder to create (its parent must exist).
    seed, index : int
        Seed of the dataset and number of the scene in it.
    objects : sequence of CatalogueObject, optional
        The catalogue to draw objects from (default :data:`CATALOGUE`); with ``layout``, the
        objects named there.
    layout : sequence of Placement, optional
        Fixed placements instead of a random layout (for hand-made scenes and tests).
    n_objects : int or (int, int)
        How many objects a random layout has (inclusive range).
    pitch_deg : float
        Downward pitch of the rig in degrees (0 = level; the calibration is then the short form).
    stack : bool
        Put one object (a cylinder if any) on top of another, like the paper's mug on the can.
    image_size, hfov_deg, baseline : see :func:`generate_dataset`.
    camera_height : float, optional
        Height of the left camera above the floor; default 0.20 m level, 0.50 m pitched.

    Returns
    -------
    Path
        ``scene_dir``.
    """
    size = _check_rig_args(image_size, hfov_deg, baseline)
    cat = _catalogue(objects)
    by_label = {o.label: o for o in cat}
    cam_h, cams = _rig(float(pitch_deg), camera_height, float(baseline), size, float(hfov_deg))
    left = cams[0]
    rng = np.random.default_rng([int(seed), int(index)])
    if layout is None:
        lo, hi = (n_objects, n_objects) if isinstance(n_objects, int) else n_objects
        k = int(rng.integers(lo, hi + 1))
        if not 1 <= k <= len(cat):
            raise InputError("n_objects", f"must be between 1 and {len(cat)}, got {k}")
        chosen = [cat[i] for i in sorted(rng.choice(len(cat), size=k, replace=False))]
        placements = _sample_layout(rng, chosen, cams, stack=stack)
    else:
        placements = list(layout)
        for pl in placements:
            if pl.label not in by_label:
                raise InputError("layout", f"{pl.label!r} is not in the catalogue {list(by_label)}")
    objs = [by_label[p.label] for p in placements]

    out = Path(scene_dir)
    tmp_scene = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    try:
        with tempfile.TemporaryDirectory(prefix="scenespeak-render-") as assets_dir:
            assets = _write_assets(Path(assets_dir), objs)
            bodies = [
                _render.Body(
                    assets[o.label][0],
                    assets[o.label][1],
                    (p.x, p.y, p.base + o.size[2] / 2),
                    math.radians(p.yaw_deg),
                )
                for o, p in zip(objs, placements, strict=True)
            ]
            (rgb_l, seg_l), (rgb_r, _) = _render.render(bodies, cams)
        ss = _render.SUPERSAMPLE
        labels = _render.downsample_labels(seg_l, ss, len(objs)).astype(np.uint8)
        _render.write_png(tmp_scene / "left.png", rgb_l)
        _render.write_png(tmp_scene / "right.png", rgb_r)
        _render.write_png(tmp_scene / "left_labels.png", labels)
        calib, up = _calib_dict(float(pitch_deg), float(baseline), float(hfov_deg), size, left)
        _write_json(tmp_scene / "calib.json", calib)
        E = ground_basis(up)
        truth_objs = []
        footprints: dict[str, NDArray[np.float64]] = {}
        visible: dict[str, float] = {}
        for i, (o, p) in enumerate(zip(objs, placements, strict=True), start=1):
            centre = np.array([p.x, p.y, p.base + o.size[2] / 2])
            c_cam = left.to_camera(centre[None])[0]
            fp_w = (_rotz(p.yaw_deg)[:2, :2] @ _outline(o).T).T + [p.x, p.y]
            fp_cam = left.to_camera(np.column_stack([fp_w, np.full(len(fp_w), p.base)]))
            fp = fp_cam @ E.T
            V = _world_vertices(o, p).T
            px = left.project(V)
            full = _hull_mask(px, size, ss)
            seen = int((seg_l == i).sum())
            vf = min(1.0, seen / max(int(full.sum()), 1))
            x0, y0 = np.floor(px.min(axis=0)).astype(int)
            x1, y1 = np.ceil(px.max(axis=0)).astype(int)
            footprints[o.label] = fp
            visible[o.label] = vf
            truth_objs.append(
                {
                    "label": o.label,
                    "index": i,
                    "shape": o.shape,
                    "size": list(o.size),
                    "centroid": [round(float(v), 6) for v in c_cam],
                    "footprint": [[round(float(a), 6), round(float(b), 6)] for a, b in fp],
                    "distance": round(float(np.linalg.norm(c_cam)), 6),
                    "visible_fraction": round(vf, 4),
                    "yaw_deg": round(p.yaw_deg, 4),
                    "base": round(p.base, 6),
                    "bbox_left": [int(x0), int(y0), int(x1), int(y1)],
                }
            )
        rels = ground_truth_relations(footprints, visible)
        truth = {
            "format": DATASET_FORMAT,
            "seed": int(seed),
            "index": int(index),
            "objects": truth_objs,
            "relations": [
                {
                    "argument": r.argument,
                    "referent": r.referent,
                    "primary": r.primary,
                    "ambiguous": r.ambiguous,
                    "angle_deg": r.angle_deg,
                    "reason": r.reason,
                }
                for r in rels
            ],
            "rig": {
                "pitch_deg": float(pitch_deg),
                "baseline": float(baseline),
                "hfov_deg": float(hfov_deg),
                "image_size": list(size),
                "camera_height": float(cam_h),
            },
            "up": up,
            "labels_image": "left_labels.png",
            "labels_legend": {str(i): o.label for i, o in enumerate(objs, start=1)},
        }
        _write_json(tmp_scene / "truth.json", truth)
        _replace_dir(tmp_scene, out)
    except BaseException:
        shutil.rmtree(tmp_scene, ignore_errors=True)
        raise
    return out


def _replace_dir(src: Path, dst: Path) -> None:
    """Move the finished folder ``src`` to ``dst``, replacing an older ``dst`` if any."""
    if dst.exists():
        old = dst.with_name(f".{dst.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        os.replace(dst, old)
        os.replace(src, dst)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(src, dst)


def generate_object_views(
    out_dir: str | PathLike[str],
    obj: CatalogueObject,
    *,
    azimuths_deg: Sequence[float] = (0.0, 30.0, -30.0),
    distance: float = 0.5,
    image_size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
) -> tuple[Path, ...]:
    """Training views of one object alone on the floor, with masks (white = object).

    Views are ``view_00.png``, ``view_00_mask.png``, ... in ``out_dir`` (created), taken from
    ``distance`` metres at each azimuth (0 = in front), slightly from above.
    """
    size = _check_rig_args(image_size, hfov_deg, 0.1)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    h = obj.size[2]
    target = np.array([0.0, 0.0, h / 2])
    cams = []
    for az in azimuths_deg:
        a = math.radians(az)
        eye = [distance * math.sin(a), -distance * math.cos(a), h / 2 + 0.12]
        cams.append(_render.look_at_camera(eye, target, size, hfov_deg))
    files = []
    with tempfile.TemporaryDirectory(prefix="scenespeak-render-") as tmp:
        mesh, tex = _write_assets(Path(tmp), [obj])[obj.label]
        images = _render.render([_render.Body(mesh, tex, (0.0, 0.0, h / 2), 0.0)], cams)
    for k, (rgb, seg) in enumerate(images):
        mask = _render.downsample_labels(seg, _render.SUPERSAMPLE, 1).astype(np.uint8) * 255
        f = out / f"view_{k:02d}.png"
        _render.write_png(f, rgb)
        _render.write_png(out / f"view_{k:02d}_mask.png", mask)
        files.append(f)
    return tuple(files)


def _is_dataset(path: Path) -> bool:
    try:
        d = json.loads((path / "dataset.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(d, dict) and str(d.get("format", "")).startswith("scenespeak-scenes/")


def generate_dataset(
    out_dir: str | PathLike[str],
    n_scenes: int = 100,
    *,
    seed: int = 0,
    pitched: bool | Literal["mixed"] = False,
    pitch_deg: float = DEFAULT_PITCH_DEG,
    image_size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
    baseline: float = 0.12,
    objects: Sequence[CatalogueObject] | None = None,
    n_objects: int | tuple[int, int] = (3, 5),
    stack: bool | Literal["some"] = False,
    views: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Render a dataset: training views of every object and ``n_scenes`` stereo scenes.

    Parameters
    ----------
    out_dir : path
        The dataset folder: created, or an existing scenespeak dataset (its scenes are
        regenerated), or an empty folder. Anything else is refused.
    n_scenes : int
        Number of scenes ``scene_000``, ``scene_001``, ...
    seed : int
        Seed of the layouts; the same seed gives identical files.
    pitched : bool or "mixed"
        Level rig, rig pitched down by ``pitch_deg``, or alternating (odd scenes pitched).
    image_size : (int, int)
        Width and height of the images in pixels.
    hfov_deg : float
        Horizontal field of view in degrees.
    baseline : float
        Distance between the cameras in metres.
    objects : sequence of CatalogueObject, optional
        The catalogue (default :data:`CATALOGUE`).
    n_objects : int or (int, int)
        Objects per scene (inclusive range).
    stack : bool or "some"
        Put one object on another in every scene, or in every fourth scene ("some").
    views : bool
        Also render the training views ``objects/<label>/view_XX.png``.
    progress : callable(done, total), optional
        Called after each scene.

    Returns
    -------
    Path
        ``out_dir``.

    Raises
    ------
    InputError
        ``out_dir`` is a non-empty folder that is not a scenespeak dataset, or a bad argument.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder; choose another output folder")
    if out.is_dir() and any(out.iterdir()) and not _is_dataset(out):
        raise InputError(
            out,
            "is not empty and is not a scenespeak dataset (no dataset.json); refusing to write "
            "into it: choose a new or empty folder",
        )
    if n_scenes < 0:
        raise InputError("n_scenes", f"must be 0 or more, got {n_scenes}")
    if pitched not in (True, False, "mixed"):
        raise InputError("pitched", f"must be True, False or 'mixed', got {pitched!r}")
    size = _check_rig_args(image_size, hfov_deg, baseline)
    cat = _catalogue(objects)
    out.mkdir(parents=True, exist_ok=True)
    names = [f"scene_{i:03d}" for i in range(n_scenes)]
    meta: dict[str, Any] = {
        "format": DATASET_FORMAT,
        "seed": int(seed),
        "objects": [o.to_dict() for o in cat],
        "scenes": [],
        "complete": False,
        "generator": {
            "pitched": pitched,
            "pitch_deg": float(pitch_deg),
            "image_size": list(size),
            "hfov_deg": float(hfov_deg),
            "baseline": float(baseline),
            "n_objects": n_objects if isinstance(n_objects, int) else list(n_objects),
            "stack": stack,
        },
    }
    _write_json(out / "dataset.json", meta)
    if views:
        for o in cat:
            tmp = Path(tempfile.mkdtemp(prefix=f".{o.label}.", suffix=".tmp", dir=out))
            try:
                generate_object_views(tmp, o, image_size=size, hfov_deg=hfov_deg)
                (out / "objects").mkdir(exist_ok=True)
                _replace_dir(tmp, out / "objects" / o.label)
            except BaseException:
                shutil.rmtree(tmp, ignore_errors=True)
                raise
    for i, name in enumerate(names):
        is_pitched = pitched is True or (pitched == "mixed" and i % 2 == 1)
        generate_scene(
            out / name,
            seed=seed,
            index=i,
            objects=cat,
            n_objects=n_objects,
            pitch_deg=pitch_deg if is_pitched else 0.0,
            stack=stack is True or (stack == "some" and i % 4 == 3),
            image_size=size,
            hfov_deg=hfov_deg,
            baseline=baseline,
        )
        if progress is not None:
            progress(i + 1, n_scenes)
    # scenes of an earlier, longer run are left alone but not listed
    meta["scenes"] = names
    meta["complete"] = True
    _write_json(out / "dataset.json", meta)
    return out


# --------------------------------------------------------------------------------------------
# loading


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(path, "does not exist; is this a scenespeak scene/dataset folder?") from None
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise InputError(path, f"cannot be read as JSON ({e})") from None


def load_truth(scene_dir: str | PathLike[str]) -> SceneTruth:
    """Read a scene's ``truth.json`` (also accepts the path of the file itself).

    Raises
    ------
    InputError
        The file is missing, not JSON, or lacks a required field.
    """
    p = Path(scene_dir)
    if p.is_file():
        p = p.parent
    f = p / "truth.json"
    d = _read_json(f)
    try:
        objs = tuple(
            ObjectTruth(
                label=str(o["label"]),
                index=int(o.get("index", i + 1)),
                centroid=tuple(float(v) for v in o["centroid"]),  # type: ignore[arg-type]
                footprint=tuple((float(a), float(b)) for a, b in o["footprint"]),
                distance=float(o["distance"]),
                visible_fraction=float(o["visible_fraction"]),
                shape=str(o.get("shape", "")),
                size=tuple(float(v) for v in o.get("size", (0, 0, 0))),  # type: ignore[arg-type]
                yaw_deg=float(o.get("yaw_deg", 0.0)),
                base=float(o.get("base", 0.0)),
                bbox_left=tuple(int(v) for v in o.get("bbox_left", (0, 0, 0, 0))),  # type: ignore[arg-type]
            )
            for i, o in enumerate(d["objects"])
        )
        rels = tuple(
            RelationTruth(
                str(r["argument"]),
                str(r["referent"]),
                r["primary"],
                bool(r["ambiguous"]),
                float(r.get("angle_deg", float("nan"))),
                str(r.get("reason", "")),
            )
            for r in d["relations"]
        )
        rg = d["rig"]
        rig = RigTruth(
            float(rg["pitch_deg"]),
            float(rg["baseline"]),
            float(rg["hfov_deg"]),
            (int(rg["image_size"][0]), int(rg["image_size"][1])),
            float(rg.get("camera_height", 0.0)),
        )
        up = d.get("up")
        if up is None:
            a = math.radians(rig.pitch_deg)
            up = [0.0, -math.cos(a), -math.sin(a)]
        up_t = (float(up[0]), float(up[1]), float(up[2]))
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise InputError(f, f"is not a scenespeak truth file (bad or missing field: {e})") from None
    return SceneTruth(p, objs, rels, rig, up_t)


def load_dataset(dataset_dir: str | PathLike[str]) -> Dataset:
    """Read ``dataset.json``: the catalogue and the scene folders (those that exist).

    Raises
    ------
    InputError
        No ``dataset.json`` or not a scenespeak dataset.
    """
    p = Path(dataset_dir)
    f = p / "dataset.json"
    d = _read_json(f)
    if not isinstance(d, dict) or not str(d.get("format", "")).startswith("scenespeak-scenes/"):
        raise InputError(f, f"is not a scenespeak dataset (format should be {DATASET_FORMAT!r})")
    try:
        objs = tuple(
            CatalogueObject(
                str(o["label"]),
                o["shape"],
                tuple(float(v) for v in o["size"]),  # type: ignore[arg-type]
                str(o["texture"]),
            )
            for o in d["objects"]
        )
        scenes = tuple(p / str(s) for s in d["scenes"] if (p / str(s) / "truth.json").is_file())
        seed = int(d["seed"])
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f, f"is not a scenespeak dataset (bad or missing field: {e})") from None
    return Dataset(p, seed, objs, scenes, bool(d.get("complete", True)))
