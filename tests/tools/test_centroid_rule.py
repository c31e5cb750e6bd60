"""The centroid-vector rule and the second truth it is scored against (issue 13): the direction
most point pairs of the true footprints agree on, which is not the centroid rule."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from scenespeak.tools.centroid_rule import (
    OPPOSITE,
    centroid_primary,
    point_pairs_direction,
    point_pairs_truth,
    score_point_pairs,
)
from scenespeak.tools.evaluation import (
    EvaluationResult,
    PredictedScene,
    format_table,
    load_scene_truth,
    score_scene,
    summarize,
)
from scenespeak.tools.evaluation_truth import TruthRelation
from scenespeak.tools.scenes import footprint_relation

BOX = ((-0.05, -0.05), (0.05, -0.05), (0.05, 0.05), (-0.05, 0.05))


def _rect(x0: float, x1: float, y0: float, y1: float) -> tuple[tuple[float, float], ...]:
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def _moved(dx: float, dy: float) -> tuple[tuple[float, float], ...]:
    return tuple((x + dx, y + dy) for x, y in BOX)


@pytest.mark.parametrize(
    ("offset", "direction"),
    [((0.5, 0.0), "right"), ((0.0, 0.5), "behind"), ((-0.5, 0.1), "left"), ((0.1, -0.5), "front")],
)
def test_separated_boxes_agree_with_every_rule(offset: tuple[float, float], direction: str) -> None:
    a = _moved(*offset)
    assert point_pairs_direction(a, BOX) == (direction, 1.0)
    assert centroid_primary(np.mean(a, axis=0), (0.0, 0.0)) == direction
    reverse, share = point_pairs_direction(BOX, a)
    assert reverse == OPPOSITE[direction] and share == 1.0


def test_a_diagonal_pair_is_not_clear() -> None:
    a = {"footprint": _moved(0.4, 0.4)}
    _, clear = point_pairs_truth(a, {"footprint": BOX})
    assert not clear
    assert point_pairs_direction(a["footprint"], BOX)[1] < 0.5


def test_the_truths_differ_on_an_elongated_object() -> None:
    """A wide shelf behind a small box: its centroid is clearly behind (67°, outside the
    generator's ±20° diagonal band), but most point pairs lie to the left or right front of
    the box, in no one direction — the second truth calls it unclear."""
    shelf = _rect(-1.0, 1.5, 0.55, 0.65)
    primary, angle, ambiguous = footprint_relation(np.array(shelf), np.array(BOX))
    assert (primary, ambiguous) == ("behind", False) and 60 < angle < 70
    direction, share = point_pairs_direction(shelf, BOX)
    assert share < 0.3
    assert point_pairs_truth({"footprint": shelf}, {"footprint": BOX}) == (direction, False)


def test_overlapping_or_missing_footprints_are_not_clear() -> None:
    a, b = {"footprint": _moved(0.5, 0.0)}, {"footprint": BOX}
    assert point_pairs_truth(a, b) == ("right", True)
    assert point_pairs_truth(a, b, ["overlap"]) == ("right", False)
    assert point_pairs_truth({"footprint": []}, b) == ("", False)


def test_score_point_pairs_counts_only_clear_described_pairs() -> None:
    truth = [
        TruthRelation("a", "b", "left", tags=("close",), pairs_primary="left", pairs_clear=True),
        TruthRelation("b", "a", "right", tags=("close",), pairs_primary="right", pairs_clear=True),
        TruthRelation("a", "c", "left", pairs_primary="behind", pairs_clear=False),
        TruthRelation("c", "a", "front", pairs_primary="front", pairs_clear=True),  # not said
    ]
    said = {("a", "b"): "left", ("b", "a"): "behind", ("a", "c"): "left"}
    centroid = {("a", "b"): "front", ("b", "a"): "right", ("a", "c"): "left"}
    got = score_point_pairs(said, centroid, truth)
    assert got == {"close": [1, 1, 2], "all": [1, 1, 2]}


def _truth_file(root: Path) -> Path:
    """A scene whose pair a/b is clear on both truths and a/shelf only on the centroid's."""
    objects = [
        {"label": "a", "centroid": [0.0, 0.1, 1.0], "footprint": [list(p) for p in BOX]},
        {"label": "b", "centroid": [0.5, 0.1, 1.0], "footprint": [list(p) for p in _moved(0.5, 0)]},
        {"label": "shelf", "centroid": [0.25, 0.1, 1.6],
         "footprint": [list(p) for p in _rect(-1.0, 1.5, 0.55, 0.65)], "size": [2.5, 0.1, 0.3]},
    ]  # fmt: skip
    relations = []
    for x in objects:
        for y in objects:
            if x is y:
                continue
            primary, _, amb = footprint_relation(np.array(x["footprint"]), np.array(y["footprint"]))
            relations.append({"argument": x["label"], "referent": y["label"],
                              "primary": primary, "ambiguous": amb, "reasons": []})  # fmt: skip
    folder = root / "scene_000"
    folder.mkdir()
    (folder / "truth.json").write_text(json.dumps({"objects": objects, "relations": relations}))
    return folder


def test_evaluation_scores_both_truths_and_prints_both_tables(tmp_path: Path) -> None:
    truth = load_scene_truth(_truth_file(tmp_path))
    rel = {(r.argument, r.referent): r for r in truth.relations}
    assert rel[("b", "a")].pairs_primary == "right" and rel[("b", "a")].pairs_clear
    assert rel[("a", "b")].pairs_primary == "left" and rel[("a", "b")].pairs_clear
    assert rel[("shelf", "a")].primary == "behind" and not rel[("shelf", "a")].ambiguous
    assert not rel[("shelf", "a")].pairs_clear and not rel[("a", "shelf")].pairs_clear
    centres = {"a": (0.0, 0.0), "b": (0.5, 0.0), "shelf": (0.25, 0.6)}
    said = {k: r.primary for k, r in rel.items()}
    said[("a", "b")] = "front"  # the forces get one pair wrong
    pred = PredictedScene(
        "scene_000",
        {o.key: o.centroid for o in truth.objects},
        said,
        centroid_relations={k: centroid_primary(centres[k[0]], centres[k[1]]) for k in said},
    )
    score = score_scene(pred, truth)
    pairs_truth = score.by_tag_point_pairs["all"]
    assert pairs_truth == [1, 2, 2]  # only a/b and b/a are clear on the point pairs
    assert score.by_tag["all"][2] == sum(not r.ambiguous for r in truth.relations)
    result = summarize([score], dataset="t")
    rule = result.centroid_rule()
    assert rule["by_tag_point_pairs"]["all"] == {"forces": 1, "centroid": 2, "pairs": 2}
    table = format_table(result)
    assert "truth: centroid direction of the true footprints" in table
    assert "truth: point pairs of the true footprints" in table
    assert EvaluationResult.from_dict(result.to_dict()) == result


def test_rules_are_scored_on_matched_objects_not_on_names(tmp_path: Path) -> None:
    """Instances named the other way round by the chain ("box 2" where the truth has "box")
    are matched by position first; both rules are scored on the matched pairs, as the main
    table is."""
    objects = [
        {"label": "box", "name": "box", "centroid": [-0.5, 0.1, 1.0],
         "footprint": [list(p) for p in _moved(-0.5, 1.0)]},
        {"label": "box", "name": "box 2", "centroid": [0.5, 0.1, 1.0],
         "footprint": [list(p) for p in _moved(0.5, 1.0)]},
    ]  # fmt: skip
    relations = [
        {"argument": "box", "referent": "box 2", "primary": "left", "ambiguous": False},
        {"argument": "box 2", "referent": "box", "primary": "right", "ambiguous": False},
    ]
    folder = tmp_path / "scene_000"
    folder.mkdir()
    (folder / "truth.json").write_text(json.dumps({"objects": objects, "relations": relations}))
    truth = load_scene_truth(folder)
    swapped = {"box 2": (-0.5, 0.1, 1.0), "box": (0.5, 0.1, 1.0)}  # the chain's names
    said = {("box 2", "box"): "left", ("box", "box 2"): "right"}  # right, in its names
    pred = PredictedScene(
        "scene_000", swapped, said, centroid_relations=dict(said),
        labels={"box": "box", "box 2": "box"},
    )  # fmt: skip
    score = score_scene(pred, truth)
    assert (score.clear_correct, score.clear_total) == (2, 2)
    assert score.centroid_clear_correct == 2
    assert score.by_tag["all"] == [2, 2, 2]
    assert score.by_tag_point_pairs["all"] == [2, 2, 2]
