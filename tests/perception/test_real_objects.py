"""Real photos: an object learnt from one real photo without a mask is found in a real cluttered
photo, and nothing else is (OpenCV's ``box.png`` / ``box_in_scene.png``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenespeak.perception.database import ObjectDatabase
from scenespeak.perception.features import detect, load_image, to_gray
from scenespeak.perception.segmentation import object_mask

# The box's corners in box_in_scene.png (column, row): the outline carried by the homography
# fitted on 82 inliers, checked by drawing it on the photo (it follows the box's printed edges;
# the right corners lie behind the rice box that hides that side).
BOX_CORNERS = np.array([[118.5, 161.1], [285.0, 174.8], [267.8, 297.9], [88.6, 272.3]])


def test_box_is_found_in_the_real_scene_without_a_mask(real_data: Path, tmp_path: Path) -> None:
    d = real_data / "objects" / "opencv"
    with ObjectDatabase.open(tmp_path / "objects.db", create=True) as db:
        db.add_object("box", [d / "box.png"])  # no mask: the whole photo is the object
        db.add_object("graffiti", [d / "graf1.png"])  # learnt, absent from the scene
        scene = load_image(d / "box_in_scene.png", gray=False)
        labelling = db.label(detect(to_gray(scene)))
    assert [det.label for det in labelling.detections] == ["box"]  # no false object
    box = labelling.detections[0]
    assert box.score >= 30
    assert np.abs(box.outline_in_scene - BOX_CORNERS).max() < 8.0


def test_a_close_up_that_fills_the_frame_keeps_the_whole_photo(real_data: Path) -> None:
    # box.png has no plain background around the box: object_mask must not invent one
    img = load_image(real_data / "objects" / "opencv" / "box.png", gray=False)
    assert object_mask(img, detect(to_gray(img)).xy) is None
