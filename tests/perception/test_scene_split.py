"""Two faces of one box are one object, not two instances (issue 10: no known object where
there is none).

The generator's renderer draws one 30 × 20 × 12 cm crate 1.5 m away, turned 30° so that its
front and its side face both show, under a rig pitched 28° down; the crate is learnt from five
rendered views without masks (the tuning configuration's). On the tuning stress set
(``--config tuning --n 60 --seed 303``, scene_033) such a crate came out as "crate" and
"crate 2": each face verified against its own training view, side by side in the image, and the
second "instance" was reported 17 cm from the crate, where there is none.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # renders a scene and five training views (~6 s idle)


@pytest.fixture(scope="module")
def turned_crate(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The rendered scene described by the whole chain, and its truth."""
    scenes = pytest.importorskip("scenespeak.tools.scenes")
    from scenespeak.perception.calibration import load_rig
    from scenespeak.perception.recognition import ObjectDatabase
    from scenespeak.pipeline import PipelineOptions, database_from_dataset
    from scenespeak.scene_folder import describe_scene_folder
    from scenespeak.tools.scene_configs import FIVE_VIEW_YAWS
    from scenespeak.tools.scene_model import CatalogueObject, Placement
    from scenespeak.tools.truth import load_truth

    root = tmp_path_factory.mktemp("split")
    crate = CatalogueObject("crate", "box", (0.30, 0.20, 0.12), "brick")
    layout = [Placement(crate, (0.45, 1.45, 0.0), 30.0)]
    scene = scenes.generate_scene(
        root / "scene", layout=layout, seed=3, pitched=True, pitch_deg=28.0
    )
    scenes.render_training_views(
        crate, root / "objects" / "crate", yaws=FIVE_VIEW_YAWS, masks=False
    )
    database_from_dataset(root, root / "objects.db")
    rig = load_rig(scene / "calib.json")
    # Since session 9 a detection with fewer than min_inliers inliers must hold at least
    # LabelOptions.small_share of its view's matches (chance inliers of a brick texture); this
    # rendering's second face is such a detection, so the join is shown with that rule off
    # ("desc") and the default chain is checked apart ("default").
    labels = dataclasses.replace(PipelineOptions().labels, small_share=0.0)
    with ObjectDatabase.open(root / "objects.db", readonly=True) as db:
        desc = describe_scene_folder(scene, db, labels=labels)  # the pipeline on the files
        default = describe_scene_folder(scene, db)
        ids = {o.id: o.label for o in db.list_objects()}
    truth = np.asarray(load_truth(scene).objects[0].centroid)
    return {"desc": desc, "default": default, "rig": rig, "ids": ids, "truth": truth}


def _region_stage(turned: dict[str, Any], share: float) -> list[Any]:
    from scenespeak.perception.scene_instances import SplitOptions
    from scenespeak.perception.scene_regions import (
        RegionStageOptions,
        SceneInputs,
        objects_from_regions,
    )

    desc = turned["desc"]
    inputs = SceneInputs(
        desc.left.shape[:2],
        desc.stereo.dense,
        desc.points,
        desc.labelling,
        np.asarray(desc.features_left.xy, dtype=np.float64),
        turned["rig"].up,
        turned["ids"],
    )
    opts = dataclasses.replace(RegionStageOptions(), split=SplitOptions(share=share))
    objects, _skipped, _geo = objects_from_regions(inputs, opts)
    return [o for o in objects if o.label == "crate"]


def test_two_faces_of_one_crate_are_one_object(turned_crate: dict[str, Any]) -> None:
    desc, truth = turned_crate["desc"], turned_crate["truth"]
    crates = [o for o in desc.objects if o.label == "crate"]
    assert len(crates) == 1, [(o.name, o.centroid.round(3).tolist()) for o in crates]
    assert np.linalg.norm(crates[0].centroid - truth) < 0.05, crates[0].centroid
    assert any("joined with 1 other detection" in n for n in crates[0].notes)


def test_the_default_chain_reports_one_crate_where_it_stands(turned_crate: dict[str, Any]) -> None:
    """With the default options (the second face refused as chance inliers, or joined), one
    crate, at the crate."""
    crates = [o for o in turned_crate["default"].objects if o.label == "crate"]
    assert len(crates) == 1, [(o.name, o.centroid.round(3).tolist()) for o in crates]
    assert np.linalg.norm(crates[0].centroid - turned_crate["truth"]) < 0.05, crates[0].centroid


def test_without_the_join_the_faces_were_two_instances(turned_crate: dict[str, Any]) -> None:
    """The scene does show the mechanism: two detections of the crate, and with the join
    switched off (share 0) the region stage reports a second crate where there is none."""
    dets = [d for d in turned_crate["desc"].labelling.detections if d.label == "crate"]
    if len(dets) < 2:
        pytest.skip("this rendering verified only one face of the crate")
    apart = _region_stage(turned_crate, share=0.0)
    assert len(apart) == 2
    far = max(float(np.linalg.norm(o.centroid - turned_crate["truth"])) for o in apart)
    assert far > 0.1  # the second "crate" stands where no crate is
    assert len(_region_stage(turned_crate, share=0.8)) == 1


def test_the_join_needs_one_segment(tmp_path: Path) -> None:
    """Two detections in different segments (a depth jump between them) stay two objects,
    however close: the pair of crates one behind the other on the stress set is kept."""
    from scenespeak.perception.objects import make_object
    from scenespeak.perception.scene_instances import merge_split_instances

    up = np.array([0.0, -1.0, 0.0])
    g = np.stack(np.meshgrid(np.linspace(-0.1, 0.1, 8), np.linspace(0, 0.1, 5)), -1).reshape(-1, 2)
    near = make_object("crate", np.c_[g[:, 0], g[:, 1], np.full(40, 1.0)], up)
    far = make_object("crate", np.c_[g[:, 0] + 0.05, g[:, 1], np.full(40, 1.2)], up)
    outline = np.array([[0.0, 0.0], [150.0, 0.0], [150.0, 60.0], [0.0, 60.0]])
    placed = [(near, outline, 1), (far, outline, 2)]
    assert len(merge_split_instances(placed, up, 500.0, {})) == 2  # type: ignore[arg-type]
    same = [(near, outline, 1), (far, outline, 1)]
    assert len(merge_split_instances(same, up, 500.0, {})) == 1  # type: ignore[arg-type]
