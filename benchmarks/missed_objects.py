"""Why each learnt object of a generated set was missed: matches, inliers, segment, cue distances.

For every true, learnt object of each scene that ``scenespeak evaluate`` would count as missed
(no described object of its label within the match gate), this prints what the chain had of it,
read from the scene's truth mask (``left_labels.png``):

- ``kp``: the left image's SIFT keypoints on its pixels, ``right`` / ``wrong``: those that
  passed the ratio test into it / into another object, ``inliers``: the verified inliers of
  detections of its label on its pixels;
- ``cover``: each described object whose points fall mostly (``> --share``) on its pixels —
  for an unknown one, the colour cue's and the grey cue's three nearest learnt objects
  (Hellinger distances, :mod:`scenespeak.perception.recognition.colour` and ``grey``) and the
  grey pixels left after the floor-like ones;
- ``skipped``: why a detection of its label was not placed.

Objects with ``cover`` empty have no segment at all (the region stage never proposed them);
those with an unknown segment and no name are the naming stage's to mend. Run::

    python benchmarks/missed_objects.py /tmp/sets/tune40 [--db objects.db] [--json]

Without ``--db`` the database is learnt from the set's ``objects/`` into a temporary file, as
``scenespeak evaluate`` does. Generated sets only (they carry the truth masks).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.recognition import colour as cues
from scenespeak.perception.recognition.grey import (
    GreyOptions,
    floor_like,
    gradient_strength,
    grey_signature,
    hellinger,
)
from scenespeak.pipeline import database_from_dataset
from scenespeak.scene_folder import describe_scene_folder
from scenespeak.tools.evaluation import find_scenes, load_scene_truth, predicted_from_description
from scenespeak.tools.evaluation_match import match_objects


@dataclass(frozen=True)
class Missed:
    """One missed object and what the chain had of it (module docstring)."""

    scene: str
    name: str
    shape: str
    distance: float
    visible: float
    pixels: int
    kp: int
    right: int
    wrong: int
    inliers: list[int]
    cover: list[str]
    skipped: list[str]


def _ranked(sig: NDArray[np.float64], views: dict[str, NDArray[np.float64]]) -> str:
    near = sorted((float(hellinger(sig, v).min()), lab) for lab, v in views.items())
    return " ".join(f"{lab} {d:.2f}" for d, lab in near[:3])


def _cue_distances(obj: Any, image: NDArray[np.uint8], camera: NDArray[np.float64], db: Any) -> str:
    """The colour and grey cues' nearest learnt objects for one unknown object."""
    models = db.colour_models()
    rgb, uv, _ = cues._object_pixels(obj, image, camera)
    if len(uv) < 3 or not models:
        return "no pixels"
    query, share = cues._chroma(cues.colour_signature(rgb))
    colour = _ranked(query, {lab: cues._chroma(m.signatures)[0] for lab, m in models.items()})
    gray = np.asarray(cv2.cvtColor(image[..., :3], cv2.COLOR_RGB2GRAY), np.uint8)
    at = uv.astype(np.intp)
    strength = gradient_strength(gray)[at[:, 1], at[:, 0]]
    own = ~floor_like(gray, at, strength, GreyOptions().floor_tolerance)
    chroma = cues.chromatic_pixels(rgb)
    text = f"chromatic {float(share):.2f}: {colour}; grey pixels {int(own.sum())}"
    greys = {lab: m.greys for lab, m in models.items() if m.greys is not None}
    if int(own.sum()) >= 3 and greys:
        u = at[own]
        sig = grey_signature(gray[u[:, 1], u[:, 0]], strength[own], chroma[own])
        text += f": {_ranked(sig, greys)}"
    return text


def missed_in_scene(scene: Path, db: Any, share: float = 0.3) -> list[Missed]:
    """The missed learnt objects of one generated scene folder (module docstring)."""
    truth = load_scene_truth(scene)
    raw = json.loads((scene / "truth.json").read_text())["objects"]
    desc = describe_scene_folder(scene, db)
    pred = predicted_from_description(desc, scene.name)
    found = set(match_objects(pred, truth).values())
    labels_img = cv2.imread(str(scene / "left_labels.png"), cv2.IMREAD_UNCHANGED)
    ids = {o.label: o.id for o in db.list_objects()}
    image = np.asarray(desc.left, np.uint8)
    camera = np.asarray(desc.rig.K_left, np.float64)
    xy = np.asarray(desc.features_left.xy)
    h, w = labels_img.shape[:2]
    under = labels_img[
        np.clip(np.rint(xy[:, 1]).astype(np.intp), 0, h - 1),
        np.clip(np.rint(xy[:, 0]).astype(np.intp), 0, w - 1),
    ]
    lab = desc.labelling
    out = []
    for o, t in zip(raw, truth.objects, strict=True):
        if o["distractor"] or t.name in found or o["label"] not in ids:
            continue
        mask = labels_img == o["index"]
        on = under == o["index"]
        oid = ids[o["label"]]
        cover = []
        for obj in desc.objects:
            _, uv, _ = cues._object_pixels(obj, image, camera)
            at = uv.astype(np.intp)
            part = float(mask[at[:, 1], at[:, 0]].mean()) if len(at) else 0.0
            if part > share:
                text = f"{obj.name} [{obj.source}] {part:.2f} of its points"
                if obj.label.startswith("unknown"):
                    text += " - " + _cue_distances(obj, image, camera, db)
                cover.append(text)
        on_idx = np.flatnonzero(on)
        out.append(
            Missed(
                scene.name,
                t.name,
                str(o["shape"]),
                round(float(o["distance"]), 2),
                round(float(o["visible_fraction"]), 2),
                int(mask.sum()),
                int(on.sum()),
                int(((lab.matched == oid) & on).sum()),
                int(((lab.matched >= 0) & (lab.matched != oid) & on).sum()),
                [
                    int(np.isin(d.inliers, on_idx).sum())
                    for d in lab.detections
                    if d.label == o["label"]
                ],
                cover,
                [s.reason for s in desc.skipped if s.label == t.label],
            )
        )
    return out


def main(argv: list[str] | None = None) -> None:
    """Print every missed object of a generated set (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset", type=Path)
    ap.add_argument("--db", type=Path, help="object database (default: learnt from the set)")
    ap.add_argument("--share", type=float, default=0.3, help="least share of an object's points")
    ap.add_argument("--json", action="store_true", help="one JSON object per line")
    ap.add_argument("--scenes", help="only these scene folders (comma-separated names)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = args.db
        if path is None:
            path = Path(tmp) / "objects.db"
            database_from_dataset(args.dataset, path)
        with ObjectDatabase.open(path, readonly=True) as db:
            total = 0
            only = set(args.scenes.split(",")) if args.scenes else None
            for scene in find_scenes(args.dataset):
                if only is not None and scene.name not in only:
                    continue
                for m in missed_in_scene(scene, db, args.share):
                    total += 1
                    if args.json:
                        print(json.dumps(asdict(m)), flush=True)
                        continue
                    seg = "; ".join(m.cover) if m.cover else "no segment"
                    print(
                        f"{m.scene} {m.name} ({m.shape}, {m.distance} m, {m.pixels} px, visible "
                        f"{m.visible}): kp {m.kp}, right {m.right}, wrong {m.wrong}, inliers "
                        f"{m.inliers}; {seg}"
                        + (f"; skipped: {' / '.join(m.skipped)}" if m.skipped else ""),
                        flush=True,
                    )
    if not args.json:
        print(f"{total} missed object(s)")


if __name__ == "__main__":
    main()
