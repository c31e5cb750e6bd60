"""The dialogue's figures (issue 13) on generated scenes, and the fit of its confidence model.

Usage (the seeds of the note: 7100 for training, 7001 frozen for evaluation):

    scenespeak scenes generate /tmp/train7100 --n 40 --seed 7100
    scenespeak scenes generate /tmp/eval7001 --n 40 --seed 7001
    python benchmarks/bench_dialogue.py fit /tmp/train7100      # writes spatial/dialogue/_fitted.py
    python benchmarks/bench_dialogue.py figures /tmp/eval7001   # yes/no, where, summary, viewer,
                                                                # reliability table and ECE

Each dataset is described once through the library (``describe --viewer --format json`` per
scene, saved in ``DATASET/described/``); the questions are asked with
``scenespeak.spatial.dialogue.ask`` and scored by ``scenespeak.tools.dialogue_eval``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from scenespeak.spatial.dialogue import _fitted, scene_from_dict
from scenespeak.spatial.dialogue.uncertainty import features
from scenespeak.tools.dialogue_eval import describe_dataset, dialogue_figures
from scenespeak.tools.scenes import load_dataset

FITTED = Path(_fitted.__file__)


def _pairs(dataset: Path, described: Path) -> tuple[list[Any], list[Any]]:
    """(scene, relation, truth primary) of every described true pair, and the depth errors."""
    rows, depth = [], []
    for scene_dir in load_dataset(dataset).scenes:
        desc = json.loads((described / f"{scene_dir.name}.json").read_text())
        truth = json.loads((scene_dir / "truth.json").read_text())
        scene = scene_from_dict(desc)
        names = set(scene.names)
        for o in truth["objects"]:
            if o["label"] in names:
                obj = scene.object(o["label"])
                z = o["centroid"][2]
                if obj.centroid is not None:
                    depth.append((obj.centroid[2] - z) * scene.focal_px * scene.baseline_m / z**2)
        for r in truth["relations"]:
            rel = scene.relation(r["argument"], r["referent"])
            if rel is not None:
                rows.append((scene, rel, rel.primary == r["primary"]))
    return rows, depth


def _logistic(x: np.ndarray, y: np.ndarray, ridge: float = 1e-2) -> np.ndarray:
    """Logistic regression by Newton's method (a small ridge keeps it finite when separable)."""
    a = np.c_[np.ones(len(x)), x]
    w = np.zeros(a.shape[1])
    for _ in range(50):
        p = 1.0 / (1.0 + np.exp(-(a @ w)))
        g = a.T @ (p - y) + ridge * np.r_[0.0, w[1:]]
        h = (a * (p * (1 - p))[:, None]).T @ a + ridge * np.eye(len(w))
        step = np.linalg.solve(h, g)
        w -= step
        if np.abs(step).max() < 1e-9:
            break
    return w


def fit(dataset: Path) -> dict[str, Any]:
    described = dataset / "described"
    describe_dataset(dataset, described)
    _, depth = _pairs(dataset, described)
    e = np.asarray(depth)
    sigma = float(1.4826 * np.median(np.abs(e - np.median(e))))
    _fitted.SIGMA_PX = sigma  # the margins below use the fitted disparity error
    rows, _ = _pairs(dataset, described)
    x = np.array([features(rel, scene) for scene, rel, _ in rows])
    y = np.array([float(ok) for _, _, ok in rows])
    w = _logistic(x, y)
    if w[3] < 0:  # a larger margin must not lower the confidence: refit without it
        w = np.r_[_logistic(x[:, :2], y), 0.0]
    text = f'''"""Fitted constants of :mod:`scenespeak.spatial.dialogue.uncertainty` (written by
``python benchmarks/bench_dialogue.py fit {dataset}``; do not edit by hand).

``SIGMA_PX``: the disparity error σ_d in pixels, from the depth errors of the objects found in
the training scenes (robust: 1.4826 × the median absolute deviation of ΔZ·f·B/Z²).
``WEIGHTS``: the logistic model (intercept, self-assessment, primary degree, margin in σ),
fitted by Newton's method on {len(y)} described pairs ({int(y.sum())} right); the margin's weight
is held at 0 when the free fit makes it negative (the confidence must not fall as the margin
grows).
"""

SIGMA_PX = {sigma:.4f}
WEIGHTS = ({", ".join(f"{v:.4f}" for v in w)})
TRAINING = "{dataset.name}: {len(load_dataset(dataset).scenes)} scenes, {len(y)} pairs"
'''
    FITTED.write_text(text, encoding="utf-8")
    return {"sigma_px": sigma, "weights": w.tolist(), "pairs": len(y), "right": int(y.sum())}


def _table(rows: list[dict[str, Any]]) -> str:
    lines = ["| confidence | pairs | mean confidence | right |", "| --- | --- | --- | --- |"]
    for b in rows:
        if b["n"]:
            lines.append(
                f"| {b['low']:.1f}–{b['high']:.1f} | {b['n']} | {b['confidence']:.3f} | "
                f"{b['accuracy']:.3f} |"
            )
    return "\n".join(lines)


def figures(dataset: Path, as_json: bool) -> dict[str, Any]:
    described = dataset / "described"
    describe_dataset(dataset, described)
    out = dialogue_figures(dataset, described)
    out.pop("_samples")
    if as_json:
        print(json.dumps(out, indent=1))
        return out

    def show(key: str) -> str:
        v = out[key]
        pct = math.nan if v["fraction"] is None else 100 * v["fraction"]
        return f"{v['right']} / {v['total']} ({pct:.1f} %)"

    print(f"dataset {dataset} ({out['scenes']} scenes)")
    print(f"is A <dir> of B?, clear pairs x 4 directions: {show('yes_no_clear')}")
    print(
        f"where is X? (X, referent or me, direction):  {show('where')}"
        f"  [referent 'me' in {out['where_referent_me']}]"
    )
    print(f"--summary <= n+1 sentences, every object:     {show('summary')}")
    print(f"--viewer left/right/front consistent:         {show('viewer')}")
    print(f"relations scored: {out['relations']} ({out['relations_right']} primary right)")
    print(f"ECE raw self-assessment: {out['ece_raw']:.4f}; calibrated: {out['ece_calibrated']:.4f}")
    print("\nraw self-assessment\n" + _table(out["reliability_raw"]))
    print("\ncalibrated confidence\n" + _table(out["reliability_calibrated"]))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("mode", choices=["fit", "figures"])
    p.add_argument("dataset", type=Path)
    p.add_argument("--json", action="store_true")
    a = p.parse_args(argv)
    if a.mode == "fit":
        print(json.dumps(fit(a.dataset)))
    else:
        figures(a.dataset, a.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
