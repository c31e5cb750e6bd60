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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.perception.calibration import ground_basis
from scenespeak.tools.folders import folder_in_place
from scenespeak.tools.render import (
    downsample_depth,
    downsample_labels,
    render,
    render_with_depth,
)
from scenespeak.tools.scene_configs import (
    GeneratorConfig,
    as_objects,
    config_yaws,
    instance_names,
)
from scenespeak.tools.scene_layout import (
    _poly_area,
    _raster,
    _sat_gap,
    _silhouette,
    footprint_relation,
    sample_layout,
)
from scenespeak.tools.scene_model import (
    CATALOGUE,
    CYLINDER_VIEW_YAWS,
    DIAGONAL_TOLERANCE_DEG,
    FORMAT,
    HIDDEN_THRESHOLD,
    SUPERSAMPLE,
    VIEW_YAWS,
    CatalogueObject,
    DatasetOptions,
    Placement,
    Rig,
    SceneOptions,
    _size,
    make_rig,
    with_overrides,
)
from scenespeak.tools.truth import SceneTruth, TruthObject, TruthRelation, load_truth

__all__ = [
    "CATALOGUE",
    "CYLINDER_VIEW_YAWS",
    "FORMAT",
    "VIEW_YAWS",
    "CatalogueObject",
    "Dataset",
    "DatasetOptions",
    "Placement",
    "Rig",
    "SceneOptions",
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

# --------------------------------------------------------------------------------------------
# ground truth


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
    options: SceneOptions | None = None,
    layout: Sequence[Placement] | None = None,
    config: GeneratorConfig | None = None,
    **overrides: object,
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

    The knobs are :class:`~scenespeak.tools.scene_model.SceneOptions` (``options``, or single
    fields as keywords: ``pitched=True``, ``image_size=(320, 240)``, ...).

    Returns
    -------
    Path
        ``scene_dir``.
    """
    o = with_overrides(options or SceneOptions(), overrides, "generate_scene")
    pitched, image_size, hfov_deg, baseline = o.pitched, o.image_size, o.hfov_deg, o.baseline
    pitch_deg, n_objects, stacked, catalogue = o.pitch_deg, o.n_objects, o.stacked, o.catalogue
    depth_noise = o.depth_noise
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
    with folder_in_place(scene_dir) as tmp:
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
    options: DatasetOptions | None = None,
    progress: Callable[[int, int], Any] | None = None,
    **overrides: object,
) -> Path:
    """Generate a dataset of ``n_scenes`` rendered stereo scenes with ground truth.

    Parameters
    ----------
    out_dir : path
        Folder to create (or an empty one). A folder holding a dataset made with the same
        settings is completed (finished scenes are kept: an interrupted run resumes).
    n_scenes : int
        Number of scenes; scene ``i`` uses the seed ``[seed, i]``, independent of the others.
    options : DatasetOptions, optional
        Rig, stacking, training views, overwrite, depth noise, configuration
        (:class:`~scenespeak.tools.scene_model.DatasetOptions`); single fields also as
        keywords (``pitched="mixed"``, ``views=False``, ``config="validation"``, ...).
    progress : callable(done, total), optional
        Called after each object's views and each scene.

    Raises
    ------
    InputError
        If ``out_dir`` is a file, or a non-empty folder that is not a scenespeak dataset, or a
        dataset made with other settings (without ``overwrite``).
    """
    from scenespeak.tools.scene_configs import CONFIGS

    o = with_overrides(options or DatasetOptions(), overrides, "generate_dataset")
    pitched, image_size, hfov_deg, baseline = o.pitched, o.image_size, o.hfov_deg, o.baseline
    stacked, views, overwrite, depth_noise = o.stacked, o.views, o.overwrite, o.depth_noise
    config = o.config
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
