"""tools.truth: one ground-truth family and one truth.json reader (generator and evaluation)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from scenespeak.errors import InputError
from scenespeak.tools import evaluation, scenes
from scenespeak.tools.truth import SceneTruth, TruthObject, TruthRelation, load_truth


def test_one_reader_and_one_family_everywhere() -> None:
    assert scenes.load_truth is load_truth is evaluation.load_scene_truth
    assert scenes.SceneTruth is SceneTruth is evaluation.SceneTruth
    assert scenes.TruthObject is TruthObject is evaluation.TruthObject
    assert scenes.TruthRelation is TruthRelation is evaluation.TruthRelation


def test_a_hand_labelled_truth_needs_only_labels_and_centroids(tmp_path: Path) -> None:
    (tmp_path / "truth.json").write_text(
        json.dumps(
            {
                "objects": [
                    {"label": "mug", "centroid": [0.3, 0.0, 1.0]},
                    {"label": "mug", "name": "mug 2", "centroid": [-0.3, 0.0, 1.2]},
                ],
                "relations": [{"argument": "mug", "referent": "mug 2", "primary": "right"}],
                "rig": {"pitch_deg": 25.0},
            }
        )
    )
    t = load_truth(tmp_path)
    assert t.name == tmp_path.name and t.scene_dir == tmp_path and t.pitch_deg == 25.0
    assert [o.key for o in t.objects] == ["mug", "mug 2"]
    assert [o.index for o in t.objects] == [1, 2]
    assert t.objects[0].metres == pytest.approx(math.hypot(0.3, 0.0, 1.0))
    r = t.relations[0]
    assert (r.primary, r.ambiguous, r.overlap, r.reasons, r.tags) == ("right", False, False, (), ())
    assert t.left == tmp_path / "left.png"


def test_bad_truth_files_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"truth\.json.*missing"):
        load_truth(tmp_path)
    (tmp_path / "truth.json").write_text('{"objects": [{"label": "mug", "centroid": [0, 0]}]}')
    with pytest.raises(InputError, match="three finite numbers"):
        load_truth(tmp_path)
    (tmp_path / "truth.json").write_text('{"objects": [{"label": "mug", "centroid": [0, 0, 1]}], '
                                         '"relations": [{"argument": "mug"}]}')  # fmt: skip
    with pytest.raises(InputError, match="lacks the field 'referent'"):
        load_truth(tmp_path)
    with pytest.raises(InputError, match="not read from a scene folder"):
        _ = SceneTruth("s", (), ()).left
