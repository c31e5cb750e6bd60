"""The scene generator: rendered stereo pairs of photo-textured objects with their ground truth.

Scenes are rendered with pybullet's CPU TinyRenderer (the ``scenes`` extra) at 2x and area
averaged; textures are photographs shipped with scikit-image. The folder format, the
ground-truth rule and timings are in ``docs/scenes.md``.

>>> import tempfile
>>> from scenespeak.tools.scenes import generate_dataset, load_dataset, load_truth
>>> out = generate_dataset(tempfile.mkdtemp() + "/ds", 1, seed=3, image_size=(160, 120))
>>> truth = load_truth(load_dataset(out).scenes[0])
>>> 3 <= len(truth.objects) <= 5
True
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any, Literal, cast

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.perception.calibration import ground_basis
from scenespeak.tools.render import (
    Camera,
    MeshSpec,
    cylinder_outline,
    downsample_depth,
    downsample_labels,
    render,
    render_with_depth,
)
from scenespeak.tools.scene_configs import (
    GeneratorConfig,
    as_objects,
    config_catalogue,
    config_choice,
    config_yaws,
    instance_names,
)

__all__ = [
    "CATALOGUE",
    "CYLINDER_VIEW_YAWS",
    "FORMAT",
    "VIEW_YAWS",
    "CatalogueObject",
    "Dataset",
    "Placement",
    "Rig",
    "SceneTruth",
    "TruthObject",
    "TruthRelation",
    "footprint_relation",
    "generate_dataset",
    "generate_scene",
    "load_dataset",
    "load_truth",
    "make_rig",
    "sample_layout",
    "view_yaws",
]

FORMAT = "scenespeak-scenes/1"
SUPERSAMPLE = 2
DIAGONAL_TOLERANCE_DEG = 20.0
HIDDEN_THRESHOLD = 0.5
CLEARANCE = 0.03
VIEW_YAWS = (0.0, 30.0, -30.0, 180.0)
#: Training-view yaws of cylinders: every 45° (a cylinder stands at any yaw in the scenes, and
#: its wrapped photo is recognised only near the middle of a view, where it faces the camera).
CYLINDER_VIEW_YAWS = (0.0, 45.0, -45.0, 90.0, -90.0, 135.0, -135.0, 180.0)


@dataclass(frozen=True)
class CatalogueObject:
    """A catalogue object: label, shape (``box``, ``cylinder``, ``card``), size (w, d, h) in
    metres (width along its front, depth, height) and a scikit-image photograph name."""

    label: str
    shape: str
    size: tuple[float, float, float]
    texture: str
    #: Never learnt: appears in scenes of the ``tuning``/``validation`` configurations only.
    distractor: bool = False


#: The fixed catalogue: sizes of real household objects.
CATALOGUE: tuple[CatalogueObject, ...] = (
    CatalogueObject("box", "box", (0.19, 0.07, 0.27), "page"),  # cereal box, printed text
    CatalogueObject("book", "box", (0.16, 0.03, 0.23), "coffee"),  # upright book
    CatalogueObject("card", "card", (0.18, 0.012, 0.13), "chelsea"),  # photo card / frame
    CatalogueObject("can", "cylinder", (0.066, 0.066, 0.122), "astronaut"),  # drink can
    CatalogueObject("mug", "cylinder", (0.085, 0.085, 0.095), "immunohistochemistry"),
    CatalogueObject("tin", "cylinder", (0.10, 0.10, 0.16), "coins"),  # coin tin
    CatalogueObject("shoebox", "box", (0.32, 0.19, 0.11), "camera"),
)


@dataclass(frozen=True)
class Rig:
    """A parallel stereo rig in the world (Z up, floor z = 0), looking along world +Y.

    ``height`` is the left camera's height above the floor, ``pitch_deg`` the downward pitch.
    """

    pitch_deg: float = 0.0
    height: float = 0.25
    baseline: float = 0.12
    hfov_deg: float = 60.0
    image_size: tuple[int, int] = (640, 480)

    def camera(self, which: Literal["left", "right"] = "left") -> Camera:
        """The left or right camera (right = left shifted by the baseline along its X axis)."""
        a = np.radians(self.pitch_deg)
        right = np.array([1.0, 0.0, 0.0])
        forward = np.array([0.0, np.cos(a), -np.sin(a)])
        down = np.array([0.0, -np.sin(a), -np.cos(a)])
        eye = np.array([0.0, 0.0, self.height])
        if which == "right":
            eye = eye + self.baseline * right
        return Camera(
            tuple(eye), tuple(right), tuple(down), tuple(forward), self.image_size, self.hfov_deg
        )

    @property
    def up(self) -> NDArray[np.float64]:
        """World up in the left camera's OpenCV frame."""
        return self.camera().rotation @ np.array([0.0, 0.0, 1.0])

    def calibration(self) -> dict[str, Any]:
        """The calibration JSON: short form for a level rig, full form for a pitched one."""
        up = [round(float(v), 12) + 0.0 for v in self.up]
        if self.pitch_deg == 0:
            return {
                "baseline": self.baseline,
                "hfov_deg": self.hfov_deg,
                "image_size": list(self.image_size),
                "up": up,
            }
        k = self.camera().intrinsics(SUPERSAMPLE).tolist()
        return {
            "image_size": list(self.image_size),
            "K_left": k,
            "K_right": k,
            "dist_left": [0.0] * 5,
            "dist_right": [0.0] * 5,
            "R": np.eye(3).tolist(),
            "T": [-self.baseline, 0.0, 0.0],
            "up": up,
        }


def make_rig(
    pitched: bool,
    *,
    image_size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
    baseline: float = 0.12,
    pitch_deg: float = 25.0,
) -> Rig:
    """The level rig (0.25 m high) or the pitched rig (0.45 m high, ``pitch_deg`` down)."""
    if pitched:
        return Rig(pitch_deg, 0.45, baseline, hfov_deg, _size(image_size))
    return Rig(0.0, 0.25, baseline, hfov_deg, _size(image_size))


@dataclass(frozen=True)
class Placement:
    """A catalogue object placed in the world: base centre ``position`` (x, y, z) and yaw."""

    obj: CatalogueObject
    position: tuple[float, float, float]
    yaw_deg: float
    on: str | None = None

    def footprint_world(self) -> NDArray[np.float64]:
        """Outline of the base in world (x, y), counter-clockwise."""
        w, d, _ = self.obj.size
        if self.obj.shape == "cylinder":
            local = cylinder_outline(w / 2)
        else:
            local = np.array([[-w / 2, -d / 2], [w / 2, -d / 2], [w / 2, d / 2], [-w / 2, d / 2]])
        a = np.radians(self.yaw_deg)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        return local @ rot.T + np.asarray(self.position[:2])

    def corners_world(self) -> NDArray[np.float64]:
        """Vertices of the object's (prism) hull in the world, ``(2n, 3)``."""
        fp = self.footprint_world()
        z0 = self.position[2]
        z1 = z0 + self.obj.size[2]
        return np.vstack([np.c_[fp, np.full(len(fp), z0)], np.c_[fp, np.full(len(fp), z1)]])

    def centroid_world(self) -> NDArray[np.float64]:
        """Centre of the object's volume."""
        x, y, z = self.position
        return np.array([x, y, z + self.obj.size[2] / 2])

    def mesh(self) -> MeshSpec:
        shape = "cylinder" if self.obj.shape == "cylinder" else "box"
        return MeshSpec(shape, self.obj.size, self.obj.texture, self.position, self.yaw_deg)


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
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


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
    ca, cr = _poly_centroid(argument), _poly_centroid(referent)
    v = ca - cr
    angle = float(np.degrees(np.arctan2(v[1], v[0])) % 360.0)
    names = ("right", "behind", "left", "front")
    primary = names[int(np.round(angle / 90.0)) % 4]
    off = abs(((angle - 45.0) % 90.0) - 45.0)  # distance to the nearest axis, 0..45
    diagonal = off > 45.0 - DIAGONAL_TOLERANCE_DEG
    overlap = _sat_gap(np.asarray(argument, float), np.asarray(referent, float)) <= 0
    return primary, angle, bool(diagonal or overlap)


def _poly_centroid(poly: NDArray[np.float64]) -> NDArray[np.float64]:
    p = np.asarray(poly, float)
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    a = cross.sum() / 2
    if abs(a) < 1e-15:
        return p.mean(axis=0)
    return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6 * a)


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


# --------------------------------------------------------------------------------------------
# ground truth


@dataclass(frozen=True)
class TruthObject:
    """One object of ``truth.json`` (see ``docs/scenes.md``)."""

    label: str
    centroid: tuple[float, float, float]
    footprint: tuple[tuple[float, float], ...]
    distance: float
    visible_fraction: float
    index: int = 0
    shape: str = ""
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    on: str | None = None


@dataclass(frozen=True)
class TruthRelation:
    """One ordered pair of ``truth.json``."""

    argument: str
    referent: str
    primary: str
    ambiguous: bool
    angle_deg: float = float("nan")
    reasons: tuple[str, ...] = ()


@dataclass(frozen=True)
class SceneTruth:
    """The ground truth of one scene, mirroring ``truth.json``."""

    scene_dir: Path
    objects: tuple[TruthObject, ...]
    relations: tuple[TruthRelation, ...]
    rig: dict[str, Any] = field(default_factory=dict)
    legend: dict[int, str] = field(default_factory=dict)

    @property
    def left(self) -> Path:
        return self.scene_dir / "left.png"

    @property
    def right(self) -> Path:
        return self.scene_dir / "right.png"

    @property
    def calib(self) -> Path:
        return self.scene_dir / "calib.json"

    def object(self, label: str) -> TruthObject:
        """The object called ``label``."""
        for o in self.objects:
            if o.label == label:
                return o
        raise KeyError(label)


def _truth_dict(placed: Sequence[Placement], rig: Rig, seg: NDArray[np.int32]) -> dict[str, Any]:
    left = rig.camera("left")
    basis = ground_basis(rig.up)
    s = SUPERSAMPLE
    objects: list[dict[str, Any]] = []
    sil = [_silhouette(left, p) for p in placed]
    names = instance_names([p.obj.label for p in placed])
    for k, pl in enumerate(placed):
        c = left.to_camera(pl.centroid_world()[None])[0]
        fp = left.to_camera(np.c_[pl.footprint_world(), np.full(len(pl.footprint_world()), 0)])
        fp2 = fp @ basis.T
        pixels = int((seg == k).sum())
        vis = min(1.0, pixels / max(_poly_area(sil[k]) * s * s, 1e-9))
        objects.append(
            {
                "label": pl.obj.label,
                "name": names[k],
                "distractor": pl.obj.distractor,
                "index": k + 1,
                "shape": pl.obj.shape,
                "size": list(pl.obj.size),
                "texture": pl.obj.texture,
                "centroid": [float(v) for v in c],
                "footprint": [[float(a), float(b)] for a, b in fp2],
                "distance": float(np.linalg.norm(c)),
                "visible_fraction": round(vis, 4),
                "pixels": pixels // (s * s),
                "on": pl.on,
            }
        )
    relations = []
    for i in range(len(placed)):
        for j in range(len(placed)):
            if i == j:
                continue
            fa = np.array(objects[i]["footprint"])
            fb = np.array(objects[j]["footprint"])
            primary, angle, _ = footprint_relation(fa, fb)
            reasons = []
            off = abs(((angle - 45.0) % 90.0) - 45.0)
            if off > 45.0 - DIAGONAL_TOLERANCE_DEG:
                reasons.append("diagonal")
            if _sat_gap(fa, fb) <= 0:
                reasons.append("overlap")
            # one hides the other: the farther one's silhouette covered by the nearer one
            far, near = (i, j) if objects[i]["distance"] > objects[j]["distance"] else (j, i)
            mf = _raster(sil[far], rig.image_size, 1.0)
            mn = _raster(sil[near], rig.image_size, 1.0)
            hidden = float((mf & mn).sum()) / max(int(mf.sum()), 1)
            if hidden >= HIDDEN_THRESHOLD and placed[far].on is None:
                reasons.append("hidden")
            relations.append(
                {
                    "argument": names[i],
                    "referent": names[j],
                    "primary": primary,
                    "ambiguous": bool(reasons),
                    "angle_deg": round(angle, 3),
                    "reasons": reasons,
                }
            )
    return {
        "objects": objects,
        "relations": relations,
        "rig": {
            "pitch_deg": rig.pitch_deg,
            "baseline": rig.baseline,
            "hfov_deg": rig.hfov_deg,
            "image_size": list(rig.image_size),
            "height": rig.height,
            "up": [float(v) for v in rig.up],
        },
        "labels": {
            "file": "left_labels.png",
            "legend": {str(k + 1): p.obj.label for k, p in enumerate(placed)},
        },
    }


# --------------------------------------------------------------------------------------------
# writing


def _write_rgb(path: Path, rgb: NDArray[np.uint8]) -> None:
    if not cv2.imwrite(str(path), np.ascontiguousarray(rgb[:, :, ::-1])):
        raise InputError(path, "cannot be written")


def _dump(path: Path, obj: Any) -> None:
    """Write JSON atomically (a temporary sibling renamed into place)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(obj, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def generate_scene(
    scene_dir: str | PathLike[str],
    *,
    seed: int | Sequence[int] = 0,
    pitched: bool = False,
    image_size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
    baseline: float = 0.12,
    pitch_deg: float = 25.0,
    n_objects: int | None = None,
    stacked: bool = False,
    catalogue: Sequence[CatalogueObject] = CATALOGUE,
    layout: Sequence[Placement] | None = None,
    depth_noise: bool = False,
    config: GeneratorConfig | None = None,
) -> Path:
    """Render one scene into ``scene_dir`` (left/right images, calib, truth, labels).

    Also the left camera's RGB-D view (``docs/rgbd.md``): ``depth.png`` (16-bit, millimetres,
    0 = none), ``intrinsics.json``, ``labels.json`` for the instance image ``left_labels.png``,
    each object's ``visible_centroid`` in ``truth.json``; with ``depth_noise`` also
    ``depth_noisy.png``, the depth as a structured-light / stereo depth camera would give it
    (:func:`scenespeak.tools.depthnoise.imitate_depth_camera`, seeded by the scene).

    A pure function of its arguments (safe in a process pool). The scene is written to a
    temporary sibling folder and renamed into place, so an interrupted call leaves nothing
    half-written. An existing ``scene_dir`` is replaced. ``layout`` overrides the random one.

    Returns
    -------
    Path
        ``scene_dir``.
    """
    scene_dir = Path(scene_dir)
    if config is not None and pitched and config.pitch_range[0] != config.pitch_range[1]:
        seq = [seed] if isinstance(seed, int) else list(seed)  # the pitch: seed + [1]
        pitch_deg = float(np.random.default_rng([*seq, 1]).uniform(*config.pitch_range))
    rig = make_rig(
        pitched, image_size=image_size, hfov_deg=hfov_deg, baseline=baseline, pitch_deg=pitch_deg
    )
    placed = (
        tuple(layout)
        if layout is not None
        else sample_layout(
            seed,
            rig,
            catalogue=config if config is not None else catalogue,
            n_objects=n_objects,
            stacked=stacked,
        )
    )
    (img_l, seg_l, z_l), (img_r, _, _) = render_with_depth(
        [p.mesh() for p in placed], [rig.camera("left"), rig.camera("right")], SUPERSAMPLE
    )
    truth = _truth_dict(placed, rig, seg_l)
    rgbd = _rgbd_files(placed, rig, seg_l, z_l, truth, seed if depth_noise else None)
    scene_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{scene_dir.name}-", dir=scene_dir.parent))
    try:
        _write_rgb(tmp / "left.png", img_l)
        _write_rgb(tmp / "right.png", img_r)
        cv2.imwrite(
            str(tmp / "left_labels.png"), downsample_labels(seg_l, SUPERSAMPLE, len(placed))
        )
        _dump(tmp / "calib.json", rig.calibration())
        _dump(tmp / "truth.json", truth)
        for name, data in rgbd.items():
            if isinstance(data, np.ndarray):
                cv2.imwrite(str(tmp / name), data)
            else:
                _dump(tmp / name, data)
        # mkdtemp makes the folder private (0700); a scene is ordinary output, readable by all
        tmp.chmod(0o755)
        if scene_dir.exists():
            shutil.rmtree(scene_dir)
        os.replace(tmp, scene_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return scene_dir


def _rgbd_files(
    placed: Sequence[Placement],
    rig: Rig,
    seg: NDArray[np.int32],
    z: NDArray[np.float32],
    truth: dict[str, Any],
    noise_seed: int | Sequence[int] | None,
) -> dict[str, Any]:
    """The left camera's RGB-D files; adds ``visible_centroid`` to ``truth``'s objects.

    The visible centroid is the mean of the back-projected render-resolution pixels of each
    object (the surface the camera sees), the target of the RGB-D path's centroids.
    """
    s = SUPERSAMPLE
    k = rig.camera("left").intrinsics(s)
    fx, fy, cx, cy = float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2])
    rows, cols = np.nonzero(seg >= 0)
    zz = z[rows, cols].astype(np.float64)
    u, v = (cols + 0.5) / s - 0.5, (rows + 0.5) / s - 0.5
    xyz = np.column_stack([(u - cx) * zz / fx, (v - cy) * zz / fy, zz])
    ids = seg[rows, cols]
    for i, obj in enumerate(truth["objects"]):
        sel = (ids == i) & np.isfinite(zz)
        if sel.any():
            obj["visible_centroid"] = [float(c) for c in xyz[sel].mean(axis=0)]
    depth = downsample_depth(seg, z, s)
    out: dict[str, Any] = {
        "depth.png": _depth_mm(depth),
        "intrinsics.json": {
            "fx": fx,
            "fy": fy,
            "cx": cx,
            "cy": cy,
            "width": rig.image_size[0],
            "height": rig.image_size[1],
            "up": [round(float(c), 12) + 0.0 for c in rig.up],
        },
        "labels.json": {str(i + 1): p.obj.label for i, p in enumerate(placed)},
    }
    if noise_seed is not None:
        from scenespeak.tools.depthnoise import imitate_depth_camera

        seq = [int(noise_seed)] if isinstance(noise_seed, int) else [int(x) for x in noise_seed]
        noisy = imitate_depth_camera(
            depth, fx=fx, seed=int(np.random.SeedSequence(seq).generate_state(1)[0])
        )
        out["depth_noisy.png"] = _depth_mm(noisy)
    return out


def _depth_mm(depth: NDArray[np.float32]) -> NDArray[np.uint16]:
    """Metres (NaN = none) to the 16-bit millimetre PNG convention (0 = none)."""
    mm = np.where(np.isfinite(depth), np.round(depth * 1000.0), 0.0)
    return np.clip(mm, 0, 65535).astype(np.uint16)


def view_yaws(obj: CatalogueObject) -> tuple[float, ...]:
    """The yaws (degrees) of ``obj``'s training views.

    Boxes and cards face the camera within ±35° in the scenes, so front, ±30° and back
    (:data:`VIEW_YAWS`) cover them; a cylinder stands at any yaw and its wrapped photo is
    recognised only near the middle of a view, so it gets eight views, 45° apart
    (:data:`CYLINDER_VIEW_YAWS`).

    Examples
    --------
    >>> len(view_yaws(CATALOGUE[0])), len(view_yaws(CATALOGUE[3]))
    (4, 8)
    """
    return CYLINDER_VIEW_YAWS if obj.shape == "cylinder" else VIEW_YAWS


def render_training_views(
    obj: CatalogueObject,
    out_dir: str | PathLike[str],
    *,
    image_size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
    yaws: Sequence[float] | None = None,
    distance: float = 0.5,
    masks: bool = True,
) -> list[Path]:
    """Render ``obj`` alone from a few viewpoints about ``distance`` metres away, writing
    ``view_XX.png`` and (with ``masks``) ``view_XX_mask.png``.

    ``yaws`` defaults to :func:`view_yaws` (front, ±30° and back for boxes and cards; every
    45° for cylinders)."""
    if yaws is None:
        yaws = view_yaws(obj)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cam_h = obj.size[2] / 2 + 0.15
    a = np.arctan2(0.15, distance)
    rig = Rig(float(np.degrees(a)), cam_h, 0.0, hfov_deg, _size(image_size))
    cam = rig.camera()
    written = []
    for k, yaw in enumerate(yaws):
        pl = Placement(obj, (0.0, distance * np.cos(a), 0.0), float(yaw))
        ((img, seg),) = render([pl.mesh()], [cam], SUPERSAMPLE)
        mask = downsample_labels(seg, SUPERSAMPLE, 1) * 255
        _write_rgb(out / f"view_{k:02d}.png", img)
        if masks:
            cv2.imwrite(str(out / f"view_{k:02d}_mask.png"), mask)
        written.append(out / f"view_{k:02d}.png")
    return written


# --------------------------------------------------------------------------------------------
# datasets


@dataclass(frozen=True)
class Dataset:
    """A generated (or hand-labelled) dataset folder."""

    root: Path
    seed: int
    objects: tuple[CatalogueObject, ...]
    scenes: tuple[Path, ...]
    meta: dict[str, Any] = field(default_factory=dict)

    def views(self, label: str) -> list[Path]:
        """Training views of ``label`` (masks excluded), sorted."""
        return sorted(
            p for p in (self.root / "objects" / label).glob("view_*.png") if "_mask" not in p.name
        )


def _scene_seed(seed: int, index: int) -> list[int]:
    return [int(seed), int(index)]


def generate_dataset(
    out_dir: str | PathLike[str],
    n_scenes: int = 100,
    *,
    seed: int = 0,
    pitched: bool | Literal["mixed"] = False,
    image_size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
    baseline: float = 0.12,
    stacked: bool = False,
    views: bool = True,
    overwrite: bool = False,
    progress: Callable[[int, int], Any] | None = None,
    depth_noise: bool = False,
    config: str = "default",
) -> Path:
    """Generate a dataset of ``n_scenes`` rendered stereo scenes with ground truth.

    Parameters
    ----------
    out_dir : path
        Folder to create (or an empty one). A folder holding a dataset made with the same
        settings is completed (finished scenes are kept: an interrupted run resumes).
    n_scenes : int
        Number of scenes; scene ``i`` uses the seed ``[seed, i]``, independent of the others.
    pitched : bool or "mixed"
        Level rig, rig pitched 25° down, or both alternately (odd scenes pitched).
    stacked : bool
        Put one object on another in every scene where one fits (the paper's mug on a can).
    views : bool
        Render the training views into ``objects/<label>/``.
    overwrite : bool
        Replace a dataset made with other settings instead of refusing.
    progress : callable(done, total), optional
        Called after each object's views and each scene.
    depth_noise : bool
        Also write each scene's ``depth_noisy.png`` (see :func:`generate_scene`).
    config : str
        ``"default"``, ``"tuning"`` or ``"validation"`` (``scene_configs.CONFIGS``; docs/scenes.md).

    Raises
    ------
    InputError
        If ``out_dir`` is a file, or a non-empty folder that is not a scenespeak dataset, or a
        dataset made with other settings (without ``overwrite``).
    """
    from scenespeak.tools.scene_configs import CONFIGS

    out = Path(out_dir)
    if config not in CONFIGS:
        raise InputError(
            "config", f"unknown configuration {config!r} (one of {', '.join(CONFIGS)})"
        )
    cfg = CONFIGS[config]
    catalogue = CATALOGUE if config == "default" else tuple(as_objects(cfg.catalogue))
    if config != "default" and pitched is False:
        pitched = cfg.pitched
    if n_scenes < 0:
        raise InputError("n_scenes", f"must be >= 0, got {n_scenes}")
    if pitched not in (True, False, "mixed"):
        raise InputError("pitched", f"must be True, False or 'mixed', got {pitched!r}")
    settings: dict[str, Any] = {
        "n_scenes": int(n_scenes),
        "pitched": pitched,
        "image_size": [int(v) for v in image_size],
        "hfov_deg": float(hfov_deg),
        "baseline": float(baseline),
        "stacked": bool(stacked),
        "views": bool(views),
    }
    if depth_noise:  # only when set, so that datasets made before the option still match
        settings["depth_noise"] = True
    if config != "default":
        settings["config"] = config
    names = [f"scene_{i:03d}" for i in range(n_scenes)]
    meta = {
        "format": FORMAT,
        "seed": int(seed),
        "objects": [
            {"label": o.label, "shape": o.shape, "size": list(o.size), "texture": o.texture}
            for o in catalogue
        ],
        "scenes": names,
        "generator": settings,
        "complete": False,
    }
    if out.exists() and not out.is_dir():
        raise InputError(out, "is a file; give a folder for the dataset")
    if out.is_dir() and any(out.iterdir()):
        old = _read_meta(out)
        if old is None:
            raise InputError(
                out, "is not empty and not a scenespeak dataset; choose an empty or new folder"
            )
        if old.get("generator") != settings or old.get("seed") != seed:
            if not overwrite:
                raise InputError(
                    out,
                    "holds a dataset made with other settings; choose another folder "
                    "or pass overwrite=True",
                )
            for p in out.iterdir():
                if p.is_dir() and (p.name.startswith("scene_") or p.name == "objects"):
                    shutil.rmtree(p)
    out.mkdir(parents=True, exist_ok=True)
    # temporary scene folders left by an interrupted run (see generate_scene)
    for p in out.glob(".scene_*-*"):
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
    if config != "default":
        meta["distractors"] = [
            {"label": o.label, "shape": o.shape, "size": list(o.size), "texture": o.texture}
            for o in as_objects(cfg.distractors, True)
        ]
    _dump(out / "dataset.json", meta)
    total = (len(catalogue) if views else 0) + n_scenes
    done = 0
    if views:
        for obj in catalogue:
            d = out / "objects" / obj.label
            yaws = config_yaws(obj, cfg)
            last = f"view_{len(yaws) - 1:02d}" + ("_mask.png" if cfg.masks else ".png")
            if not (d / last).exists():
                render_training_views(
                    obj, d, image_size=image_size, hfov_deg=hfov_deg, yaws=yaws, masks=cfg.masks
                )
            done += 1
            if progress is not None:
                progress(done, total)
    for i, name in enumerate(names):
        if not (out / name / "truth.json").exists():
            tilt = pitched if pitched != "mixed" else bool(i % 2)
            generate_scene(
                out / name,
                seed=_scene_seed(seed, i),
                pitched=bool(tilt),
                image_size=image_size,
                hfov_deg=hfov_deg,
                baseline=baseline,
                stacked=stacked,
                depth_noise=depth_noise,
                config=None if config == "default" else cfg,
            )
        done += 1
        if progress is not None:
            progress(done, total)
    meta["complete"] = True
    _dump(out / "dataset.json", meta)
    return out


def _read_meta(root: Path) -> dict[str, Any] | None:
    try:
        meta = json.loads((root / "dataset.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        return None
    return meta


def load_dataset(dataset_dir: str | PathLike[str]) -> Dataset:
    """Open a dataset folder: its catalogue and the scenes that exist (with a truth.json).

    Raises
    ------
    InputError
        If ``dataset_dir/dataset.json`` is missing or not of format ``scenespeak-scenes/1``.
    """
    root = Path(dataset_dir)
    meta = _read_meta(root)
    if meta is None:
        raise InputError(
            root / "dataset.json", f"missing or not a {FORMAT} dataset; see docs/scenes.md"
        )
    try:
        objects = tuple(
            CatalogueObject(
                str(o["label"]),
                str(o.get("shape", "")),
                tuple(o.get("size", (0, 0, 0))),
                str(o.get("texture", "")),
            )
            for o in meta.get("objects", [])
        )
    except (KeyError, TypeError) as exc:
        raise InputError(root / "dataset.json", f"an object lacks the field {exc}") from exc
    scenes = tuple(
        root / str(s) for s in meta.get("scenes", []) if (root / str(s) / "truth.json").exists()
    )
    return Dataset(root, int(meta.get("seed", 0)), objects, scenes, meta)


def _size(image_size: Sequence[int]) -> tuple[int, int]:
    w, h = image_size
    return int(w), int(h)


def _xyz(values: Sequence[float]) -> tuple[float, float, float]:
    x, y, z = values
    return float(x), float(y), float(z)


def load_truth(scene_dir: str | PathLike[str]) -> SceneTruth:
    """Read ``scene_dir/truth.json`` into a :class:`SceneTruth`.

    Raises
    ------
    InputError
        If the file is missing, not JSON, or lacks required fields.
    """
    d = Path(scene_dir)
    path = d / "truth.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise InputError(path, "missing: every scene needs a truth.json") from exc
    except (OSError, ValueError) as exc:
        raise InputError(path, f"cannot be read as JSON ({exc})") from exc
    try:
        objects = tuple(
            TruthObject(
                label=str(o["label"]),
                centroid=_xyz(o["centroid"]),
                footprint=tuple((float(a), float(b)) for a, b in o.get("footprint", [])),
                distance=float(o.get("distance", np.linalg.norm(o["centroid"]))),
                visible_fraction=float(o.get("visible_fraction", 1.0)),
                index=int(o.get("index", k + 1)),
                shape=str(o.get("shape", "")),
                size=_xyz(o.get("size", (0, 0, 0))),
                on=o.get("on"),
            )
            for k, o in enumerate(data["objects"])
        )
        relations = tuple(
            TruthRelation(
                str(r["argument"]),
                str(r["referent"]),
                str(r["primary"]),
                bool(r.get("ambiguous", False)),
                float(r.get("angle_deg", float("nan"))),
                tuple(r.get("reasons", ())),
            )
            for r in data.get("relations", [])
        )
        legend = {int(k): str(v) for k, v in data.get("labels", {}).get("legend", {}).items()}
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(path, f"an object or relation lacks or mangles the field {exc}") from exc
    return SceneTruth(d, objects, relations, dict(data.get("rig", {})), legend)
