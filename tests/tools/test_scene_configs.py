"""The generator's tuning / validation configurations: repeated instances, distractors, no
masks, disjoint texture pools, and a clear message when a texture's package is missing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenespeak.errors import InputError
from scenespeak.tools import scene_configs
from scenespeak.tools.scene_configs import CONFIGS, texture_image
from scenespeak.tools.scenes import generate_dataset, make_rig, sample_layout


def test_texture_pools_are_disjoint() -> None:
    pools = {
        name: {t for *_x, t in cfg.catalogue + cfg.distractors} for name, cfg in CONFIGS.items()
    }
    assert not pools["validation"] & pools["tuning"]
    assert not pools["validation"] & pools["default"]
    assert len(CONFIGS["validation"].catalogue) >= 12
    assert all(t.split(":")[0] in ("opencv-doc", "mpl", "solid") for t in pools["validation"])


def test_missing_opencv_doc_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(scene_configs, "OPENCV_DOC_DIRS", (str(tmp_path),))
    monkeypatch.delenv("OPENCV_SAMPLES_DATA_PATH", raising=False)
    with pytest.raises(InputError, match="apt-get install opencv-doc"):
        texture_image("opencv-doc:baboon.jpg")
    with pytest.raises(InputError, match="unknown kind"):
        texture_image("http:x.png")


def test_layouts_hold_repeats_and_distractors() -> None:
    cfg = CONFIGS["tuning"]
    rig = make_rig(False)
    counts, repeats, distractors = [], 0, 0
    for i in range(30):
        placed = sample_layout([5, i], rig, catalogue=cfg)
        labels = [p.obj.label for p in placed]
        counts.append(len(placed))
        repeats += len(set(labels)) < len(labels)
        distractors += any(p.obj.distractor for p in placed)
    assert min(counts) >= 2 and max(counts) <= 5
    assert repeats >= 3 and distractors >= 5


def test_a_tuning_dataset_has_no_masks_and_names_instances(tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    out = generate_dataset(
        tmp_path / "t", 4, seed=3, image_size=(160, 120), views=False, config="tuning"
    )
    meta = json.loads((out / "dataset.json").read_text())
    assert meta["generator"]["config"] == "tuning" and meta["distractors"]
    assert {o["label"] for o in meta["objects"]}.isdisjoint(
        {o["label"] for o in meta["distractors"]}
    )
    for scene in meta["scenes"]:
        truth = json.loads((out / scene / "truth.json").read_text())
        names = [o["name"] for o in truth["objects"]]
        assert len(set(names)) == len(names)
        assert {r["argument"] for r in truth["relations"]} <= set(names)
    with pytest.raises(InputError, match="unknown configuration"):
        generate_dataset(tmp_path / "u", 1, config="nope")
