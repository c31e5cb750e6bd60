"""Evaluation of every input form of issue 11 on generated scenes, through the CLI.

For each scene of one or more generated datasets (``scenespeak scenes generate --depth-noise``)
it runs ``scenespeak describe`` (the CLI's own ``main``, in this process, reading its JSON from
stdout) in these forms and scores the output against ``truth.json``:

- ``masks``: colour + true depth + true masks;
- ``noisy``: colour + imitation depth camera (``depth_noisy.png``) + true masks;
- ``boxes``: colour + true depth + the masks' bounding boxes as COCO detections;
- ``noisy-boxes``: as ``boxes`` with the imitation depth camera;
- ``estimated-up``: as ``masks`` with ``--estimate-up`` (up from the support plane);
- ``db``: colour + true depth + the object database (no masks);
- ``stereo``: the stereo pair + the object database (the reference for ``db``);
- ``image``: the masks alone (image plane), left/right of the pairs whose image-plane
  relation is clear.

Scores: the primary direction of the truth's clear pairs (``ambiguous`` false), the objects
described, the centroid error against each object's visible surface centroid
(``visible_centroid``). Image plane: a pair is clear when the direction between the masks'
centroids is within 25° of horizontal and the masks' column ranges do not overlap.

Run ``python -m scenespeak.tools.rgbd_eval DATASET [DATASET ...] --out results.json``
(``docs/rgbd.md`` has the frozen set and its command).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

if TYPE_CHECKING:
    from scenespeak.tools.truth import SceneTruth

__all__ = ["FORMS", "evaluate_scene", "main", "summarise"]

FORMS = ("masks", "noisy", "boxes", "noisy-boxes", "estimated-up", "db", "stereo", "image")


def _cli_json(args: Sequence[str]) -> tuple[int, dict[str, Any] | None, str]:
    """Run ``scenespeak`` with ``args`` in this process; its exit code, JSON and stderr."""
    from scenespeak.cli import main as cli_main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli_main([*args, "--format", "json", "--quiet"])
    data = json.loads(out.getvalue()) if code == 0 and out.getvalue().strip() else None
    return code, data, err.getvalue().strip()


def _boxes_file(scene: Path, tmp: Path) -> Path:
    inst = np.asarray(cv2.imread(str(scene / "left_labels.png"), cv2.IMREAD_UNCHANGED))
    labels = json.loads((scene / "labels.json").read_text())
    dets = []
    for key, label in labels.items():
        ys, xs = np.nonzero(inst == int(key))
        if len(ys) == 0:
            continue
        x0, y0 = int(xs.min()), int(ys.min())
        w, h = int(xs.max()) - x0 + 1, int(ys.max()) - y0 + 1
        dets.append({"bbox": [x0, y0, w, h], "label": label, "score": 1.0})
    path = tmp / f"{scene.parent.name}_{scene.name}_boxes.json"
    path.write_text(json.dumps(dets))
    return path


def _args(form: str, scene: Path, db: Path | None, tmp: Path) -> list[str]:
    s = scene
    color = [str(s / "left.png")]
    rgbd = ["--intrinsics", str(s / "intrinsics.json")]
    masks = ["--masks", str(s / "left_labels.png"), "--labels", str(s / "labels.json")]
    if form == "masks":
        return ["describe", *color, "--depth", str(s / "depth.png"), *rgbd, *masks]
    if form == "noisy":
        return ["describe", *color, "--depth", str(s / "depth_noisy.png"), *rgbd, *masks]
    if form == "estimated-up":
        return ["describe", *color, "--depth", str(s / "depth.png"), *rgbd, *masks, "--estimate-up"]
    if form in ("boxes", "noisy-boxes"):
        boxes = ["--boxes", str(_boxes_file(s, tmp))]
        depth = s / ("depth.png" if form == "boxes" else "depth_noisy.png")
        return ["describe", *color, "--depth", str(depth), *rgbd, *boxes]
    if form == "db":
        return ["describe", *color, "--depth", str(s / "depth.png"), *rgbd, "--db", str(db)]
    if form == "stereo":
        calib = ["--calib", str(s / "calib.json"), "--db", str(db)]
        return ["describe", *color, str(s / "right.png"), *calib]
    if form == "image":
        return ["describe", *color, *masks]
    raise ValueError(form)


def _image_truth(scene: Path) -> list[tuple[str, str, str]]:
    """(argument, referent, "left"|"right") for the pairs clear in the image plane."""
    inst = np.asarray(cv2.imread(str(scene / "left_labels.png"), cv2.IMREAD_UNCHANGED))
    labels = json.loads((scene / "labels.json").read_text())
    info = {}
    for key, label in labels.items():
        ys, xs = np.nonzero(inst == int(key))
        if len(ys):
            info[label] = (xs.mean(), -ys.mean(), xs.min(), xs.max())
    out = []
    for a, (xa, ya, a0, a1) in info.items():
        for b, (xb, yb, b0, b1) in info.items():
            if a == b:
                continue
            angle = np.degrees(np.arctan2(ya - yb, xa - xb)) % 360
            horizontal = min(angle, abs(angle - 180), 360 - angle) <= 25
            apart = a1 < b0 or b1 < a0
            if horizontal and apart:
                out.append((a, b, "right" if xa > xb else "left"))
    return out


def evaluate_scene(scene: Path, form: str, db: Path | None, tmp: Path) -> dict[str, Any]:
    """Scores of one scene in one input form (counts, so scenes can be summed)."""
    from scenespeak.tools.scenes import load_truth

    code, data, err = _cli_json(_args(form, scene, db, tmp))
    truth = json.loads((scene / "truth.json").read_text())
    t = load_truth(scene)
    res: dict[str, Any] = {"scene": f"{scene.parent.name}/{scene.name}", "form": form, "exit": code}
    if data is None:
        res["error"] = err
        return res
    rels = {(r["argument"], r["referent"]): r["primary"] for r in data["relations"]}
    if form == "image":
        res.update(_image_scores(scene, rels))
    else:
        res.update(_object_scores(t, truth, data, rels))
    return res


def _image_scores(scene: Path, rels: dict[tuple[str, str], str]) -> dict[str, Any]:
    """Pairs of the picture's truth, right and wrong (image-plane form)."""
    pairs = _image_truth(scene)
    return {
        "pairs": len(pairs),
        "right": sum(rels.get((a, b)) == p for a, b, p in pairs),
        "wrong": [(a, b, p, rels.get((a, b))) for a, b, p in pairs if rels.get((a, b)) != p],
    }


def _object_scores(
    t: SceneTruth, truth: dict[str, Any], data: dict[str, Any], rels: dict[tuple[str, str], str]
) -> dict[str, Any]:
    """Objects described, clear pairs right and wrong, centroid errors (3-D forms)."""
    objs = {o.get("name", o["label"]): o for o in data["objects"]}
    clear = [r for r in t.relations if not r.ambiguous]
    res: dict[str, Any] = {
        "objects": len(t.objects),
        "described": sum(o.label in objs for o in t.objects),
        "pairs": len(clear),
        "right": sum(rels.get((r.argument, r.referent)) == r.primary for r in clear),
        "wrong": [
            (r.argument, r.referent, r.primary, rels.get((r.argument, r.referent)))
            for r in clear
            if rels.get((r.argument, r.referent)) != r.primary
        ],
    }
    errors = []
    for o in truth["objects"]:
        if o["label"] in objs and "visible_centroid" in o and objs[o["label"]]["centroid"]:
            c = np.asarray(objs[o["label"]]["centroid"], float)
            errors.append(float(np.linalg.norm(c - np.asarray(o["visible_centroid"], float))))
    res["centroid_errors"] = errors
    return res


def summarise(results: Sequence[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Totals per form: clear pairs right, objects described, centroid error quantiles."""
    out: dict[str, dict[str, Any]] = {}
    for form in FORMS:
        rs = [r for r in results if r["form"] == form]
        if not rs:
            continue
        pairs = sum(r.get("pairs", 0) for r in rs)
        right = sum(r.get("right", 0) for r in rs)
        row: dict[str, Any] = {
            "scenes": len(rs),
            "failed": sum(r["exit"] != 0 for r in rs),
            "pairs": pairs,
            "right": right,
            "accuracy": right / pairs if pairs else None,
        }
        if form != "image":
            row.update(_object_totals(rs))
        out[form] = row
    return out


def _object_totals(rs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Objects described and the centroid error quantiles of one 3-D form's scenes."""
    errs = np.array([e for r in rs for e in r.get("centroid_errors", [])])
    row: dict[str, Any] = {
        "objects": sum(r.get("objects", 0) for r in rs),
        "described": sum(r.get("described", 0) for r in rs),
        "scenes_all_described": sum(r.get("described", -1) == r.get("objects", 0) for r in rs),
    }
    if len(errs):
        row["centroid_error_m"] = {
            "median": float(np.median(errs)),
            "p95": float(np.quantile(errs, 0.95)),
            "max": float(errs.max()),
            "share_le_1cm": float(np.mean(errs <= 0.01)),
        }
    return row


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m scenespeak.tools.rgbd_eval DATASET ... [--forms ...] [--out FILE]``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("datasets", nargs="+", type=Path)
    ap.add_argument("--forms", nargs="+", default=list(FORMS), choices=FORMS)
    ap.add_argument("--out", type=Path, default=None, help="write per-scene results as JSON")
    ap.add_argument("--limit", type=int, default=None, help="only the first N scenes of each")
    args = ap.parse_args(argv)
    from scenespeak.pipeline import database_from_dataset
    from scenespeak.tools.scenes import load_dataset

    results: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="scenespeak-rgbd-eval-") as tmpdir:
        tmp = Path(tmpdir)
        for root in args.datasets:
            ds = load_dataset(root)
            db = None
            if {"db", "stereo"} & set(args.forms):
                db = tmp / f"{root.name}.db"
                database_from_dataset(root, db)
            scenes = ds.scenes[: args.limit] if args.limit is not None else ds.scenes
            for k, scene in enumerate(scenes):
                for form in args.forms:
                    results.append(evaluate_scene(scene, form, db, tmp))
                sys.stderr.write(f"\r{root.name}: {k + 1}/{len(scenes)} scenes")
            sys.stderr.write("\n")
    summary = summarise(results)
    if args.out is not None:
        args.out.write_text(json.dumps({"summary": summary, "scenes": results}, indent=1))
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
