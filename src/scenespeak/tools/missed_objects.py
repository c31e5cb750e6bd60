"""Why a learnt object of a generated scene was not found: the diagnosis of issue 10's misses.

For every learnt (non-distractor) object of a scene's ground truth that the evaluation does not
match (:func:`scenespeak.tools.evaluation.match_objects`), this describes the scene, recomputes
geometry first's support plane and segments (:func:`scenespeak.perception.scene_regions.
scene_geometry`, the same deterministic call the pipeline makes) and reads the truth's instance
mask (``left_labels.png``, ``labels.json``) to say which stage lost it:

- ``named elsewhere`` — an object of its label was described, but too far from it to match;
- ``no depth`` — less than a fifth of its visible pixels have a dense depth (SGBM holes);
- ``no segment`` — it has depth, but less than a fifth of its pixels lie in any segment
  (below the support's height band, cut by the opening, or too small);
- ``merged`` — its main segment lies mostly on other true objects (a neighbour took it);
- ``segment, no name`` — it has a segment of its own, but nothing named it (an unknown
  object, or nothing, was reported there).

``python -m scenespeak.tools.missed_objects DATASET [--db objects.db] [--json]`` prints one
line per missed object and the count per cause.

>>> cause(depth_share=0.1, segment_share=0.0, purity=0.0, named_elsewhere=False)
'no depth'
>>> cause(depth_share=0.9, segment_share=0.8, purity=0.3, named_elsewhere=False)
'merged'
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Miss", "cause", "diagnose_dataset", "diagnose_scene", "main"]

#: Below this share of its visible pixels with depth (or in a segment) the stage lost it.
LOST_SHARE = 0.2
#: A main segment with less than this share of its pixels on the object is another's.
MIN_PURITY = 0.5


@dataclass(frozen=True)
class Miss:
    """One learnt object the chain did not find, and what each stage saw of it.

    Attributes
    ----------
    scene, name, shape : str
        The scene, the true object's name, its shape (box, cylinder, card).
    distance : float
        Its distance from the camera (metres).
    pixels : int
        Its visible pixels in the left image.
    depth_share, segment_share : float
        Shares of those pixels with a dense depth, and in any segment.
    purity : float
        Share of its main segment's pixels that lie on it (0: no segment).
    on_others, on_nothing : float
        Shares of its main segment's pixels on other true objects, and on no object (the
        floor or the background the dense map joined to it).
    keypoints, votes : int
        SIFT keypoints on it, and those whose ratio-test match voted for its label.
    detected : bool
        Whether the labelling verified a detection of its label anywhere in the scene.
    reported : str
        What the description put on its pixels (an object's name whose centroid projects
        there), or "".
    cause : str
        :func:`cause`.
    """

    scene: str
    name: str
    shape: str
    distance: float
    pixels: int
    depth_share: float
    segment_share: float
    purity: float
    on_others: float
    on_nothing: float
    keypoints: int
    votes: int
    detected: bool
    reported: str
    cause: str


def cause(*, depth_share: float, segment_share: float, purity: float, named_elsewhere: bool) -> str:
    """The stage that lost an object, from what :class:`Miss` measures (module docstring)."""
    if named_elsewhere:
        return "named elsewhere"
    if depth_share < LOST_SHARE:
        return "no depth"
    if segment_share < LOST_SHARE:
        return "no segment"
    if purity < MIN_PURITY:
        return "merged"
    return "segment, no name"


def _instance_image(scene: Path) -> NDArray[np.integer] | None:
    """The truth's instance image (``left_labels.png``: each object's ``index`` per pixel)."""
    import cv2

    lab = cv2.imread(str(scene / "left_labels.png"), cv2.IMREAD_UNCHANGED)
    return None if lab is None else np.asarray(lab)


def _reported_at(desc: Any, mask: NDArray[np.bool_]) -> str:
    """The described objects whose centroid projects onto ``mask`` grown by 10 pixels."""
    import cv2

    grown = cv2.dilate(mask.astype(np.uint8), np.ones((21, 21), np.uint8)) > 0
    k = np.asarray(desc.rig.K_left, np.float64)
    h, w = mask.shape
    out = []
    for o in desc.objects:
        c = np.asarray(o.centroid, np.float64)
        if c[2] <= 0:
            continue
        u, v, s = k @ c
        col, row = round(u / s), round(v / s)
        if 0 <= row < h and 0 <= col < w and grown[row, col]:
            out.append(str(o.name))
    return ",".join(out)


def _votes(desc: Any, mask: NDArray[np.bool_], label: str, id_to_label: dict[int, str]) -> int:
    """Keypoints on ``mask`` whose ratio-test match voted for ``label``."""
    xy = np.asarray(desc.features_left.xy, np.float64)
    matched = np.asarray(desc.labelling.matched)
    if not len(xy) or len(matched) != len(xy):
        return 0
    h, w = mask.shape
    c = np.clip(np.rint(xy[:, 0]).astype(np.intp), 0, w - 1)
    r = np.clip(np.rint(xy[:, 1]).astype(np.intp), 0, h - 1)
    on = mask[r, c]
    ids = [int(i) for i in matched[on] if i >= 0]
    return sum(id_to_label.get(i) == label for i in ids)


def diagnose_scene(scene_dir: str | Path, db: Any) -> list[Miss]:
    """Every learnt object of one generated scene that the chain misses, with its cause."""
    from scenespeak.perception.regions import RegionOptions, scene_geometry
    from scenespeak.scene_folder import describe_scene_folder
    from scenespeak.tools.evaluation import (
        load_scene_truth,
        match_objects,
        predicted_from_description,
    )

    scene = Path(scene_dir)
    truth = load_scene_truth(scene)
    desc = describe_scene_folder(scene, db)
    pred = predicted_from_description(desc, scene.name)
    found = set(match_objects(pred, truth).values())
    instances = _instance_image(scene)
    shape = (int(desc.left.shape[0]), int(desc.left.shape[1]))
    geo = None
    if desc.stereo.dense is not None:
        up = np.asarray(desc.rig.up, np.float64)
        geo = scene_geometry(desc.stereo.dense, up, shape, RegionOptions(), image=desc.left)
    id_to_label = {o.id: o.label for o in db.list_objects()}
    detected = {d.label for d in desc.labelling.detections}
    xy = np.asarray(desc.features_left.xy, np.float64)
    out = []
    for t in truth.objects:
        if t.distractor or t.key in found or instances is None:
            continue
        m = instances == t.index
        pix = int(m.sum())
        depth = seg = purity = others = nothing = 0.0
        if geo is not None and pix:
            depth = float(np.all(np.isfinite(geo.points[m]), axis=1).mean())
            labels = geo.segments.labels
            inside = labels[m]
            seg = float((inside >= 0).mean())
            if (inside >= 0).any():
                k = int(np.bincount(inside[inside >= 0]).argmax())
                size = max(int(geo.segments.sizes[k]), 1)
                purity = float((inside == k).sum() / size)
                under = instances[labels == k]
                others = float(((under != t.index) & (under != 0)).sum() / size)
                nothing = float((under == 0).sum() / size)
        h, w = m.shape
        kp = 0
        if len(xy):
            c = np.clip(np.rint(xy[:, 0]).astype(np.intp), 0, w - 1)
            r = np.clip(np.rint(xy[:, 1]).astype(np.intp), 0, h - 1)
            kp = int(m[r, c].sum())
        elsewhere = any(pred.label_of(n) == t.label for n in pred.objects)
        out.append(
            Miss(
                scene.name,
                t.key,
                t.shape,
                round(float(t.metres), 3),
                pix,
                round(depth, 3),
                round(seg, 3),
                round(purity, 3),
                round(others, 3),
                round(nothing, 3),
                kp,
                _votes(desc, m, t.label, id_to_label),
                t.label in detected,
                _reported_at(desc, m),
                cause(
                    depth_share=depth,
                    segment_share=seg,
                    purity=purity,
                    named_elsewhere=elsewhere,
                ),
            )
        )
    return out


def diagnose_dataset(root: str | Path, db_path: str | Path | None = None) -> list[Miss]:
    """:func:`diagnose_scene` over every scene of a generated dataset (a database learnt from
    its ``objects/`` when ``db_path`` is None)."""
    from scenespeak.perception.database import ObjectDatabase
    from scenespeak.pipeline import database_from_dataset
    from scenespeak.tools.evaluation import find_scenes

    with tempfile.TemporaryDirectory(prefix="scenespeak-missed-") as tmp:
        path = Path(db_path) if db_path is not None else Path(tmp) / "objects.db"
        if db_path is None:
            database_from_dataset(root, path)
        with ObjectDatabase.open(path, readonly=True) as db:
            return [m for s in find_scenes(root) for m in diagnose_scene(s, db)]


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m scenespeak.tools.missed_objects DATASET [--db FILE] [--json]``."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("dataset", type=Path)
    ap.add_argument("--db", type=Path, default=None, help="object database (default: learnt)")
    ap.add_argument("--json", action="store_true", help="one JSON object per missed object")
    args = ap.parse_args(argv)
    misses = diagnose_dataset(args.dataset, args.db)
    for m in misses:
        if args.json:
            print(json.dumps(asdict(m)))
        else:
            print(
                f"{m.scene} {m.name:<12} {m.shape:<8} {m.distance:4.2f} m {m.pixels:5d} px "
                f"depth {m.depth_share:.2f} seg {m.segment_share:.2f} pur {m.purity:.2f} "
                f"oth {m.on_others:.2f} bg {m.on_nothing:.2f} "
                f"kp {m.keypoints:3d} votes {m.votes:3d} det {int(m.detected)} "
                f"[{m.cause}] at: {m.reported or '-'}"
            )
    counts = Counter(m.cause for m in misses)
    sys.stderr.write(f"{len(misses)} missed: {dict(sorted(counts.items()))}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
