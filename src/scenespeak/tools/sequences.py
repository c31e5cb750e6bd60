"""Rendered stereo *sequences* with the truth of every frame, for the working memory.

A sequence is a short scripted film of the scene generator's objects (:mod:`.scenes`): one
object slides across the table (``slide``), one appears (``appear``), one slides behind a
larger one until it is hidden (``hide``), or the camera turns until an object leaves the view
(``pan``). Every frame is rendered by pybullet's TinyRenderer with the generator's meshes,
textures and rig (one pybullet connection per sequence: the bodies are moved, not rebuilt),
and the truth of every frame is written beside the images.

Layout (``interfaces.md``, "Streams"; ``docs/live.md``)::

    SEQ/calib.json            the rig (short form: a level, rectified rig)
    SEQ/truth.json            {"script", "seed", "frames": [...], "events": [...]}
    SEQ/intrinsics.json       the left camera (RGB-D form, with up)
    SEQ/0000/left.png, SEQ/0000/right.png, ...
    SEQ/0000/depth.png        the left camera's depth, 16-bit millimetres (0 = none)
    SEQ/0000/masks.png        its instance image (k = the k-th object of "labels")
    SEQ/0000/labels.json      the instances present in this frame: {"k": label}

``truth.json["frames"][k]["objects"]`` gives, per object present, its truth ``id`` (stable over
the sequence), ``label``, ``centroid`` (left camera frame, metres), ``footprint`` (horizontal
plane), ``visible_fraction`` (unhidden share of its silhouette) and ``in_view`` (share of the
silhouette inside the image). ``truth.json["events"]`` lists the scripted changes with the
frame they happen at (``docs/live.md`` gives the rule of each kind):

- ``{"kind": "moved", "object": id, "referent": id, "relation": "behind", "frame": k}``: the
  primary ground-truth relation (:func:`scenespeak.tools.scenes.footprint_relation`) of the
  pair changed to a new unambiguous value at frame ``k``;
- ``{"kind": "appeared", "object": id, "frame": k}``;
- ``{"kind": "hidden", "object": id, "referent": id, "frame": k}``: first frame where less
  than :data:`HIDDEN_VISIBLE` of it is visible, behind ``referent``;
- ``{"kind": "out of view", "object": id, "frame": k}``: first frame where less than
  :data:`OUT_OF_VIEW_INSIDE` of its silhouette is inside the left image.

>>> import tempfile
>>> from scenespeak.tools.sequences import generate_sequence, load_sequence
>>> seq = generate_sequence(tempfile.mkdtemp() + "/s", "appear", seed=1, n_frames=4,
...                         image_size=(160, 120))  # doctest: +SKIP
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable, Sequence
from os import PathLike
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.errors import InputError
from scenespeak.tools.folders import folder_in_place
from scenespeak.tools.render import Camera, MeshSpec, capture, load_bodies
from scenespeak.tools.scenes import (
    CATALOGUE,
    SUPERSAMPLE,
    CatalogueObject,
    Placement,
    Rig,
    render_training_views,
)
from scenespeak.tools.sequence_truth import (
    HIDDEN_VISIBLE,
    OUT_OF_VIEW_INSIDE,
    FrameTruth,
    SequenceTruth,
    _frame_truth,
    _object_events,
    _relation_events,
    _Shot,
)

__all__ = [
    "HIDDEN_VISIBLE",
    "OUT_OF_VIEW_INSIDE",
    "SCRIPTS",
    "FrameTruth",
    "SequenceTruth",
    "generate_sequence",
    "generate_sequence_set",
    "load_sequence",
    "sequence_database",
]

#: Scripts a sequence can follow.
SCRIPTS = ("slide", "appear", "hide", "pan")
FORMAT = "scenespeak-sequence/1"

_BY_LABEL = {o.label: o for o in CATALOGUE}
#: Objects that hide others (tall and wide) and objects that slide (small, well textured).
_OCCLUDERS = ("box", "shoebox", "book")
_MOVERS = ("mug", "can", "tin")


# --------------------------------------------------------------------------------------------
# scripts


def _spot(
    rng: np.random.Generator, obj: CatalogueObject, x: tuple[float, float], y: tuple[float, float]
) -> Placement:
    yaw = rng.uniform(0, 360) if obj.shape == "cylinder" else rng.uniform(-15.0, 15.0)
    return Placement(obj, (float(rng.uniform(*x)), float(rng.uniform(*y)), 0.0), float(yaw))


def _moved(pl: Placement, x: float, y: float) -> Placement:
    return Placement(pl.obj, (float(x), float(y), 0.0), pl.yaw_deg)


def _pick(rng: np.random.Generator, names: Sequence[str], k: int) -> list[CatalogueObject]:
    return [_BY_LABEL[n] for n in rng.choice(list(names), k, replace=False)]


def _lerp_steps(n: int, start: int, length: int) -> NDArray[np.float64]:
    """Progress 0..1 per frame: 0 before ``start``, linear over ``length`` frames, then 1."""
    t = (np.arange(n) - start) / max(length, 1)
    return np.clip(t, 0.0, 1.0)


def _script_slide(rng: np.random.Generator, n: int) -> list[_Shot]:
    """A mover slides from one side of a static object to its other side (or behind it)."""
    mover, anchor = _pick(rng, _MOVERS, 1)[0], _pick(rng, ("box", "book", "shoebox"), 1)[0]
    other = _pick(rng, [m for m in _MOVERS if m != mover.label], 1)[0]
    a = _spot(rng, anchor, (-0.05, 0.05), (1.0, 1.15))
    side = float(rng.choice([-1.0, 1.0]))
    o = _spot(rng, other, (0.25, 0.3), (0.75, 0.85))
    o = _moved(o, -side * o.position[0], o.position[1])
    start = _moved(_spot(rng, mover, (0.22, 0.27), (0.95, 1.05)), 0, 0)
    x0, y0 = side * rng.uniform(0.22, 0.27), rng.uniform(0.95, 1.1)
    if rng.random() < 0.5:  # to the other side, passing in front of the anchor
        path = [(x0, y0), (0.0, 0.72), (-x0, y0)]
    else:  # to the front of the anchor
        path = [(x0, y0), (x0 * 0.6, 0.85), (0.0, 0.72)]
    t0, length = n // 4, n // 2
    shots = []
    for p in _lerp_steps(n, t0, length):
        seg = min(int(p * 2), 1)
        u = p * 2 - seg
        (xa, ya), (xb, yb) = path[seg], path[seg + 1]
        m = _moved(start, xa + (xb - xa) * u, ya + (yb - ya) * u)
        shots.append(_Shot((a, o, m)))
    return shots


def _script_appear(rng: np.random.Generator, n: int) -> list[_Shot]:
    """Two objects stand still; a third appears at a scripted frame."""
    objs = _pick(rng, ("mug", "can", "tin", "box", "book"), 3)
    spots = [((-0.3, -0.2), (0.8, 1.0)), ((0.15, 0.25), (1.0, 1.2)), ((-0.05, 0.05), (0.65, 0.75))]
    order = rng.permutation(3)
    placed = [_spot(rng, o, *spots[int(i)]) for o, i in zip(objs, order, strict=True)]
    t = int(rng.integers(n // 3, n // 2 + 1))
    return [_Shot((placed[0], placed[1], placed[2] if k >= t else None)) for k in range(n)]


def _script_hide(rng: np.random.Generator, n: int) -> list[_Shot]:
    """A small object slides behind a tall one until it is hidden."""
    occ = _pick(rng, ("box", "book"), 1)[0]
    mover = _pick(rng, _MOVERS, 1)[0]
    other = _pick(rng, [m for m in _MOVERS if m != mover.label], 1)[0]
    side = float(rng.choice([-1.0, 1.0]))
    b = _spot(rng, occ, (-0.02, 0.02), (0.7, 0.75))
    o = _spot(rng, other, (0.22, 0.28), (0.8, 0.9))
    o = _moved(o, -side * o.position[0], o.position[1])
    y = float(rng.uniform(1.05, 1.2))
    x0 = side * float(rng.uniform(0.3, 0.36))
    m0 = _spot(rng, mover, (0, 0), (y, y))
    t0, length = n // 4, n // 3
    return [_Shot((b, o, _moved(m0, x0 * (1 - p), y))) for p in _lerp_steps(n, t0, length)]


def _script_pan(rng: np.random.Generator, n: int) -> list[_Shot]:
    """Three objects stand still; the camera turns until one leaves the view."""
    objs = _pick(rng, ("mug", "can", "tin", "box", "book"), 3)
    side = float(rng.choice([-1.0, 1.0]))
    placed = [
        _spot(rng, objs[0], (-0.12, -0.05), (0.9, 1.0)),
        _spot(rng, objs[1], (0.08, 0.15), (1.05, 1.15)),
        _spot(rng, objs[2], (0.38, 0.42), (0.95, 1.0)),
    ]
    placed[2] = _moved(placed[2], side * placed[2].position[0], placed[2].position[1])
    t0, length = n // 4, n // 2
    pans = -side * 32.0 * _lerp_steps(n, t0, length)
    return [_Shot(tuple(placed), float(p)) for p in pans]


_SCRIPTS: dict[str, Callable[[np.random.Generator, int], list[_Shot]]] = {
    "slide": _script_slide,
    "appear": _script_appear,
    "hide": _script_hide,
    "pan": _script_pan,
}


# --------------------------------------------------------------------------------------------
# cameras and rendering


def _cameras(rig: Rig, pan_deg: float) -> tuple[Camera, Camera]:
    """The rig turned by ``pan_deg`` about the world's up (positive = to the right)."""
    a = np.radians(pan_deg)
    right = np.array([np.cos(a), -np.sin(a), 0.0])
    forward = np.array([np.sin(a), np.cos(a), 0.0])
    down = np.array([0.0, 0.0, -1.0])
    eye = np.array([0.0, 0.0, rig.height])
    size, fov = rig.image_size, rig.hfov_deg
    left = Camera(tuple(eye), tuple(right), tuple(down), tuple(forward), size, fov)
    eye_r = eye + rig.baseline * right
    return left, Camera(tuple(eye_r), tuple(right), tuple(down), tuple(forward), size, fov)


class _Renderer:
    """One pybullet connection with every object of a sequence loaded once (parked below the
    floor; :meth:`frame` moves them)."""

    def __init__(self, objects: Sequence[CatalogueObject], tmp: Path) -> None:
        import pybullet as p

        self.p = p
        self.cid = p.connect(p.DIRECT)
        parked = [MeshSpec(o.shape, o.size, o.texture, (0.0, 0.0, -5.0), 0.0) for o in objects]
        self.ids = load_bodies(p, self.cid, parked, tmp)
        self.bodies = [body for body, k in self.ids.items() if k >= 0]

    def close(self) -> None:
        self.p.disconnect(physicsClientId=self.cid)

    def frame(
        self, shot: _Shot, cams: Sequence[Camera]
    ) -> list[tuple[NDArray[np.uint8], NDArray[np.int32], NDArray[np.float32]]]:
        """Images, segmentations (-1 = floor, k = object k) and camera-frame depths (metres,
        render resolution, NaN where nothing was hit) of ``shot`` from ``cams``."""
        p = self.p
        for body, pl in zip(self.bodies, shot.placements, strict=True):
            pos = [0.0, 0.0, -5.0] if pl is None else list(pl.position)
            yaw = 0.0 if pl is None else np.radians(pl.yaw_deg)
            p.resetBasePositionAndOrientation(
                body, pos, p.getQuaternionFromEuler([0, 0, yaw]), physicsClientId=self.cid
            )
        return [capture(p, self.cid, cam, SUPERSAMPLE, self.ids) for cam in cams]


# --------------------------------------------------------------------------------------------
# files


def _write_rgb(path: Path, rgb: NDArray[np.uint8]) -> None:
    if not cv2.imwrite(str(path), np.ascontiguousarray(rgb[:, :, ::-1])):
        raise InputError(path, "cannot be written")


def _write_rgbd(
    d: Path, seg: NDArray[np.int32], z: NDArray[np.float32], labels: Sequence[str]
) -> None:
    """The left camera's depth (16-bit mm), instance image and its labels for one frame."""
    from scenespeak.tools.render import downsample_depth, downsample_labels
    from scenespeak.tools.scenes import _depth_mm

    depth = downsample_depth(seg, z, SUPERSAMPLE)
    if not cv2.imwrite(str(d / "depth.png"), _depth_mm(depth)):
        raise InputError(d / "depth.png", "cannot be written")
    inst = downsample_labels(seg, SUPERSAMPLE, len(labels))
    if not cv2.imwrite(str(d / "masks.png"), inst):
        raise InputError(d / "masks.png", "cannot be written")
    present = sorted(int(k) for k in np.unique(inst) if k > 0)
    names = {str(k): labels[k - 1] for k in present}
    (d / "labels.json").write_text(json.dumps(names) + "\n")


def _intrinsics(rig: Rig) -> dict[str, Any]:
    k = rig.camera("left").intrinsics(SUPERSAMPLE)
    w, h = rig.image_size
    return {
        "fx": float(k[0, 0]), "fy": float(k[1, 1]), "cx": float(k[0, 2]), "cy": float(k[1, 2]),
        "width": int(w), "height": int(h), "up": [round(float(c), 12) + 0.0 for c in rig.up],
    }  # fmt: skip


def generate_sequence(
    out_dir: str | PathLike[str],
    script: str,
    *,
    seed: int = 0,
    n_frames: int = 32,
    image_size: tuple[int, int] = (640, 480),
    progress: Callable[[int, int], Any] | None = None,
) -> SequenceTruth:
    """Render one scripted sequence into ``out_dir`` (replaced if it exists).

    A pure function of its arguments. The frames are written into a temporary sibling folder
    renamed into place at the end, so an interrupted call leaves nothing half-written.

    Parameters
    ----------
    out_dir : path
        The sequence folder.
    script : {"slide", "appear", "hide", "pan"}
        What happens (module docstring).
    seed : int
        Fixes the objects, their places and the timing.
    n_frames : int
        Frames (at least 8: the scripts keep still stretches before and after the change).
    image_size : (int, int)
        Width and height of the images.
    progress : callable(done, total), optional
        Called after each frame.

    Returns
    -------
    SequenceTruth
    """
    if script not in _SCRIPTS:
        raise InputError("script", f"unknown script {script!r}; choose one of {SCRIPTS}")
    if n_frames < 8:
        raise InputError("n_frames", f"must be at least 8, got {n_frames}")
    out = Path(out_dir)
    rng = np.random.default_rng([int(seed), SCRIPTS.index(script)])
    shots = _SCRIPTS[script](rng, n_frames)
    full = next(s for s in shots if None not in s.placements).placements
    objects = [pl.obj for pl in full if pl is not None]
    labels = [o.label for o in objects]
    rig = Rig(0.0, 0.25, 0.12, 60.0, (int(image_size[0]), int(image_size[1])))
    with folder_in_place(out) as tmp:
        frames = _render_all(tmp, shots, objects, rig, labels, progress)
        events = sorted(_relation_events(frames) + _object_events(frames), key=lambda e: e["frame"])
        data = {
            "format": FORMAT,
            "script": script,
            "seed": int(seed),
            "labels": {str(k + 1): lab for k, lab in enumerate(labels)},
            "frames": [
                {"frame": f.index, "pan_deg": f.pan_deg, "objects": list(f.objects)} for f in frames
            ],
            "events": events,
        }
        (tmp / "calib.json").write_text(json.dumps(rig.calibration(), indent=1) + "\n")
        (tmp / "intrinsics.json").write_text(json.dumps(_intrinsics(rig), indent=1) + "\n")
        (tmp / "truth.json").write_text(json.dumps(data, indent=1) + "\n")
    return load_sequence(out)


def _render_all(
    tmp: Path,
    shots: Sequence[_Shot],
    objects: Sequence[CatalogueObject],
    rig: Rig,
    labels: Sequence[str],
    progress: Callable[[int, int], Any] | None,
) -> list[FrameTruth]:
    frames = []
    with tempfile.TemporaryDirectory(prefix="scenespeak-seq-") as meshes:
        renderer = _Renderer(objects, Path(meshes))
        try:
            for k, shot in enumerate(shots):
                cams = _cameras(rig, shot.pan_deg)
                (img_l, seg_l, z_l), (img_r, _, _) = renderer.frame(shot, cams)
                d = tmp / f"{k:04d}"
                d.mkdir()
                _write_rgb(d / "left.png", img_l)
                _write_rgb(d / "right.png", img_r)
                _write_rgbd(d, seg_l, z_l, labels)
                frames.append(_frame_truth(k, shot, cams[0], seg_l, labels))
                if progress is not None:
                    progress(k + 1, len(shots))
        finally:
            renderer.close()
    return frames


def load_sequence(seq_dir: str | PathLike[str]) -> SequenceTruth:
    """Read a sequence folder written by :func:`generate_sequence`.

    Raises
    ------
    InputError
        If ``truth.json`` is missing or not a sequence's truth.
    """
    root = Path(seq_dir)
    path = root / "truth.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise InputError(path, "missing: not a generated sequence") from exc
    except (OSError, ValueError) as exc:
        raise InputError(path, f"cannot be read as JSON ({exc})") from exc
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputError(path, f"not a {FORMAT} truth file")
    frames = tuple(
        FrameTruth(int(f["frame"]), float(f.get("pan_deg", 0.0)), tuple(f["objects"]))
        for f in data["frames"]
    )
    labels = {int(k): str(v) for k, v in data.get("labels", {}).items()}
    return SequenceTruth(
        root, str(data["script"]), int(data["seed"]), frames, tuple(data["events"]), labels
    )


def sequence_database(
    out_dir: str | PathLike[str],
    *,
    image_size: tuple[int, int] = (640, 480),
    labels: Sequence[str] | None = None,
) -> Path:
    """Render the training views of the catalogue objects the scripts use (or of ``labels``)
    into ``out_dir/objects/<label>/`` (the dataset layout that
    :func:`scenespeak.pipeline.database_from_dataset` reads); existing views are kept."""
    out = Path(out_dir)
    used = sorted(set(_OCCLUDERS) | set(_MOVERS)) if labels is None else sorted(set(labels))
    for label in used:
        d = out / "objects" / label
        if not (d / "view_00_mask.png").exists():
            render_training_views(_BY_LABEL[label], d, image_size=image_size)
    return out


def generate_sequence_set(
    out_dir: str | PathLike[str],
    seeds: Sequence[int],
    *,
    scripts: Sequence[str] = SCRIPTS,
    n_frames: int = 32,
    image_size: tuple[int, int] = (640, 480),
    progress: Callable[[str], Any] | None = None,
) -> list[SequenceTruth]:
    """Every script with every seed, as ``out_dir/<script>_<seed>/`` (kept when present)."""
    out = Path(out_dir)
    done = []
    for seed in seeds:
        for script in scripts:
            d = out / f"{script}_{seed}"
            try:
                seq = load_sequence(d)
                if len(seq.frames) != n_frames:
                    raise InputError(d, "other length")
            except InputError:
                seq = generate_sequence(
                    d, script, seed=seed, n_frames=n_frames, image_size=image_size
                )
            if progress is not None:
                progress(d.name)
            done.append(seq)
    return done
