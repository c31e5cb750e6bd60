"""An occluder never lends its depth (issue 10): a far box half hidden behind a near book.

The scene is rendered by the generator's renderer with a fixed layout (a book 0.75 m away, a
box 1.9 m away whose carried outline covers the book's edge), and both objects are learnt from
one rendered view each, without masks. On the generated default set three far objects like
this box were recognised from 3-5 keypoints with no stereo depth and no segment of their own,
and the region stage placed them on their occluder (0.4-1.2 m too near). Here the box's own
evidence is thinned the same way, on the real stereo stage's output.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenespeak.perception.objects import SceneObject

pytestmark = pytest.mark.slow  # renders a scene and two training views (~5 s idle, ~40 s loaded)

BOOK_Z, BOX_Z = 0.75, 1.9


@pytest.fixture(scope="module")
def occluded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The rendered scene described by the whole chain, with what the region stage read."""
    scenes = pytest.importorskip("scenespeak.tools.scenes")
    from scenespeak.perception.calibration import load_rig
    from scenespeak.perception.recognition import ObjectDatabase
    from scenespeak.pipeline import database_from_dataset
    from scenespeak.scene_folder import describe_scene_folder
    from scenespeak.tools.scene_model import CATALOGUE, Placement

    root = tmp_path_factory.mktemp("occluded")
    cat = {o.label: o for o in CATALOGUE}
    layout = [
        Placement(cat["book"], (0.0, BOOK_Z, 0.0), 0.0),
        Placement(cat["box"], (0.16, BOX_Z, 0.0), 0.0),
    ]
    scene = scenes.generate_scene(root / "scene", layout=layout, seed=3)
    for p in layout:
        scenes.render_training_views(
            p.obj, root / "objects" / p.obj.label, yaws=(0.0,), masks=False
        )
    database_from_dataset(root, root / "objects.db")
    rig = load_rig(scene / "calib.json")
    with ObjectDatabase.open(root / "objects.db", readonly=True) as db:
        desc = describe_scene_folder(scene, db)  # the pipeline on the folder's files
        ids = {o.id: o.label for o in db.list_objects()}
    truth = {o["label"]: np.asarray(o["centroid"]) for o in _truth(scene)["objects"]}
    return {"desc": desc, "rig": rig, "ids": ids, "truth": truth}


def _truth(scene: Path) -> dict[str, Any]:
    import json

    return dict(json.loads((scene / "truth.json").read_text()))


def _box(objects: list[SceneObject]) -> list[SceneObject]:
    return [o for o in objects if o.label == "box"]


def test_the_whole_chain_places_the_far_box_at_its_own_depth(occluded: dict[str, Any]) -> None:
    desc, truth = occluded["desc"], occluded["truth"]
    book = [o for o in desc.objects if o.label == "book"]
    assert len(book) == 1 and np.linalg.norm(book[0].centroid - truth["book"]) < 0.05
    for box in _box(list(desc.objects)):  # found here from its own stereo keypoints
        _at_own_depth(box, truth["box"])


def _at_own_depth(box: SceneObject, true_centroid: np.ndarray) -> None:
    """Within the evaluation's match gate (0.25 m) and at the box's depth: only its upper
    part is visible, so the centre of what is seen sits ~10 cm above the volume's."""
    assert abs(float(box.centroid[2] - true_centroid[2])) < 0.1, box.centroid
    assert np.linalg.norm(box.centroid - true_centroid) < 0.25, box.centroid


def _thinned(occluded: dict[str, Any]) -> Any:
    """The region stage's inputs with the box's evidence as thin as on the default set's
    misses: the dense map empty round its keypoints (no segment holds them) and none of them
    with a stereo depth (at 1.9 m the stereo stage matched none of them here anyway)."""
    from scenespeak.perception.scene_regions import SceneInputs

    desc = occluded["desc"]
    lab = desc.labelling
    far = [i for i, d in enumerate(lab.detections) if d.label == "box"]
    if not far:
        pytest.skip("the box was not recognised in this rendering")
    det = lab.detections[far[0]]
    xy = np.asarray(desc.features_left.xy, dtype=np.float64)
    dense = desc.stereo.dense
    disp = dense.disparity.copy()
    for x, y in np.rint(xy[det.inliers]).astype(int):
        disp[max(y - 6, 0) : y + 7, max(x - 6, 0) : x + 7] = np.nan
    points = desc.points.subset(np.flatnonzero(~np.isin(desc.points.left_index, det.inliers)))
    return SceneInputs(
        desc.left.shape[:2],
        dataclasses.replace(dense, disparity=disp),
        points,
        lab,
        xy,
        occluded["rig"].up,
        occluded["ids"],
    )


def test_a_far_box_without_its_own_depth_is_not_placed_on_its_occluder(
    occluded: dict[str, Any],
) -> None:
    from scenespeak.perception.scene_regions import objects_from_regions

    objects, skipped, _geo = objects_from_regions(_thinned(occluded))
    truth = occluded["truth"]
    # its own depth or not at all: before the fix it came out 1.1 m too near, on the book
    for box in _box(objects):
        _at_own_depth(box, truth["box"])
    if not _box(objects):
        (why,) = [s.reason for s in skipped if s.label == "box"]
        assert "stereo depth" in why and "not placed" in why
    book = [o for o in objects if o.label == "book"]
    assert len(book) == 1 and np.linalg.norm(book[0].centroid - truth["book"]) < 0.05
