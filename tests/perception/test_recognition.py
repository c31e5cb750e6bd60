"""Recognition against the object database with the pipeline's settings: no false objects.

The small-detection rule (``PipelineOptions.min_inliers_small`` inliers at distinct positions
for an outline of at most ``small_area`` px²) finds far objects; these tests pin that it does
not find objects that are not there, in real photos full of texture, at several scales.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from skimage import data

from cardscene import photo
from scenespeak.perception.features import detect
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.pipeline import PipelineOptions

#: scikit-image photos none of the learnt objects shows (the motorcycle is the Middlebury pair)
CLUTTER = ("rocket", "brick", "grass", "gravel", "horse", "moon", "text", "hubble_deep_field")


@pytest.fixture(scope="module")
def db_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("recognition") / "objects.db"
    with ObjectDatabase.create(path) as db:
        for name in ("astronaut", "chelsea", "coffee", "camera", "coins"):
            db.add_object(name, [photo(name, (240, 240))])
    return path


def _clutter() -> list[tuple[str, np.ndarray]]:
    out = [("motorcycle", data.stereo_motorcycle()[0])]
    for name in CLUTTER:
        img = np.asarray(getattr(data, name)())
        if img.dtype == bool:
            img = img.astype(np.uint8) * 255
        out.append((name, img[..., :3] if img.ndim == 3 else img))
    return out


def _label(db: ObjectDatabase, image: np.ndarray) -> list[str]:
    opts = PipelineOptions()
    result = db.label(
        detect(image, precise_upscale=False),
        ratio=opts.label_ratio,
        min_inliers=opts.min_inliers,
        min_inliers_small=opts.min_inliers_small,
        small_area=opts.small_area,
    )
    return [d.label for d in result.detections]


@pytest.mark.parametrize("scale", [1.0, 0.5, 0.25])
def test_no_object_is_found_in_photos_of_other_things(db_path: Path, scale: float) -> None:
    found = {}
    with ObjectDatabase.open(db_path, readonly=True) as db:
        for name, img in _clutter():
            small = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
            labels = _label(db, small)
            if labels:
                found[name] = labels
    assert found == {}


def test_a_small_copy_of_a_learnt_photo_is_found(db_path: Path) -> None:
    # the other side of the same rule: a learnt photo shrunk to 40 x 40 px on a textured
    # background carries 5 inliers: the small rule finds it (and nothing else), the general
    # rule (8 inliers) and the first version of the small rule (6 under 4,000 px²) do not
    background = np.asarray(data.gravel())
    background = np.stack([background] * 3, -1)[:240, :320].copy()
    background[96:136, 136:176] = photo("coffee", (40, 40))
    with ObjectDatabase.open(db_path, readonly=True) as db:
        assert _label(db, background) == ["coffee"]
        features = detect(background, precise_upscale=False)
        assert db.label(features, min_inliers_small=6, small_area=4000.0).detections == ()
        assert db.label(features, small_area=0.0).detections == ()
