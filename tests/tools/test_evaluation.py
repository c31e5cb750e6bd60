"""The evaluation: metrics computed by hand on hand-made cases, then the whole experiment on a
tiny labelled dataset (photo cards before a textured wall, in the scene folder format) whose
answer is known, then (when the scene generator is installed) on a tiny generated set.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from cardscene import BASELINE, HFOV, H, W, card_pair, photo
from scenespeak.errors import InputError
from scenespeak.tools.evaluation import (
    EvaluationResult,
    LearnSplit,
    PredictedScene,
    SceneTruth,
    TruthObject,
    TruthRelation,
    evaluate,
    find_scenes,
    format_table,
    load_scene_truth,
    score_scene,
    summarize,
)
from scenespeak.tools.evaluation_split import FALSE_KNOWN_KINDS, choose_learnt, with_unlearnt

# --- the metrics, by hand ---------------------------------------------------------------------

HAT, MUG, CAN = (
    TruthObject("hat", (-0.3, 0.0, 1.0)),
    TruthObject("mug", (0.2, 0.0, 1.0)),
    TruthObject("can", (0.0, 0.0, 1.8)),
)
RELATIONS = (
    TruthRelation("hat", "mug", "left"),
    TruthRelation("mug", "hat", "right"),
    TruthRelation("can", "hat", "behind", ambiguous=True),
    TruthRelation("hat", "can", "front", ambiguous=True),
    TruthRelation("can", "mug", "behind"),
    TruthRelation("mug", "can", "front"),
)
TRUTH = SceneTruth("scene_a", (HAT, MUG, CAN), RELATIONS)


def test_a_perfect_scene() -> None:
    pred = PredictedScene(
        "scene_a",
        {"hat": (-0.3, 0.0, 1.0), "mug": (0.2, 0.0, 1.0), "can": (0.0, 0.0, 1.8)},
        {(r.argument, r.referent): r.primary for r in RELATIONS},
        seconds=1.5,
    )
    s = score_scene(pred, TRUTH)
    assert s.usable and (s.n_objects, s.n_found, s.n_extra) == (3, 3, 0)
    assert (s.pairs_total, s.pairs_described) == (6, 6)
    assert (s.clear_correct, s.clear_total, s.ambiguous_correct, s.ambiguous_total) == (4, 4, 2, 2)
    assert s.centroid_errors == (0.0, 0.0, 0.0) and s.seconds == 1.5


def test_hand_computed_two_scenes() -> None:
    # scene a: everything found; the hat 3-4-0 cm off (5 cm), the mug 12 cm deep (12 cm);
    # mug->hat said "behind" (wrong, clear), can->hat said "left" (wrong, ambiguous).
    a = PredictedScene(
        "scene_a",
        {"hat": (-0.27, 0.04, 1.0), "mug": (0.2, 0.0, 1.12), "can": (0.0, 0.0, 1.8)},
        {
            ("hat", "mug"): "left",
            ("mug", "hat"): "behind",
            ("can", "hat"): "left",
            ("hat", "can"): "front",
            ("can", "mug"): "behind",
            ("mug", "can"): "front",
        },
        seconds=2.0,
    )
    # scene b: the can got no hull, so only hat<->mug are described; an unknown cluster too.
    b = PredictedScene(
        "scene_b",
        {"hat": (-0.3, 0.0, 1.0), "mug": (0.2, 0.0, 1.0), "unknown 1": (1.0, 0.0, 3.0)},
        {("hat", "mug"): "left", ("mug", "hat"): "right"},
        seconds=4.0,
    )
    # scene c: the chain failed outright (no texture).
    c = PredictedScene("scene_c", {}, {}, seconds=0.5, error="left.png: no stereo match")
    truth_b = SceneTruth("scene_b", TRUTH.objects, TRUTH.relations)
    truth_c = SceneTruth("scene_c", TRUTH.objects, TRUTH.relations)
    scores = [score_scene(b, truth_b), score_scene(c, truth_c), score_scene(a, TRUTH)]

    result = summarize(scores, dataset="hand", workers=1, wall_seconds=7.0)
    assert [s.name for s in result.scenes] == ["scene_a", "scene_b", "scene_c"]
    assert [s.usable for s in result.scenes] == [True, False, False]
    assert (result.n_scenes, result.n_usable, result.n_failed) == (3, 1, 1)
    assert (result.objects_found, result.objects_total, result.objects_extra) == (5, 9, 1)
    assert (result.pairs_described, result.pairs_total) == (8, 18)
    # clear pairs described: a: 4 (3 right), b: 2 (2 right) -> 5 / 6; ambiguous: a: 1 of 2
    assert result.clear == (5, 6) and result.ambiguous == (1, 2)
    assert result.usable_clear == (3, 4)
    assert result.centroid_errors == pytest.approx([0.05, 0.12, 0.0, 0.0, 0.0])

    d = result.to_dict()
    assert d["usable"] == 1 and d["usable_fraction"] == pytest.approx(1 / 3)
    assert d["primary_accuracy"] == pytest.approx(5 / 6)
    assert d["ambiguous_accuracy"] == pytest.approx(0.5)
    assert d["centroid_error_m"]["median"] == pytest.approx(0.0)
    assert d["centroid_error_m"]["mean"] == pytest.approx(0.034)
    assert d["seconds_per_scene"] == {"median": 2.0, "mean": pytest.approx(6.5 / 3)}
    assert d["paper"]["usable"] == 76 and d["paper"]["scenes"] == 100
    assert json.loads(json.dumps(d)) == d  # JSON-ready

    table = format_table(result)
    usable = "| scenes usable (every object a hull, every pair a sentence) |"
    assert f"{usable} 1 / 3 (33 %) | 76 / 100 (76 %) |" in table
    assert "| primary direction right, clear pairs | 5 / 6 (83 %) |" in table
    assert "| primary direction right, ambiguous pairs | 1 / 2 (50 %) | – |" in table
    assert "| centroid error, median / mean | 0.0 / 3.4 cm | – |" in table
    assert "- scene_c: left.png: no stereo match" in table
    assert [s.missing for s in result.scenes] == [(), ("can",), ("hat", "mug", "can")]
    assert "Objects found by label: can 1/3, hat 2/3, mug 2/3." in table
    assert format_table(EvaluationResult.from_dict(json.loads(json.dumps(d)))) == table


def test_an_empty_result_prints_dashes() -> None:
    d = summarize([]).to_dict()
    assert d["primary_accuracy"] is None and d["centroid_error_m"]["median"] is None
    assert "| objects found (with a hull) | – | – |" in format_table(summarize([]))


# --- the whole experiment on a hand-labelled card dataset ------------------------------------

CARDS = {"astronaut": (-0.25, 1.2, 0.2), "chelsea": (0.22, 1.0, 0.2), "coffee": (0.0, 1.8, 0.25)}
LAYOUT = [  # argument, referent, primary from the layout, ambiguous
    ("astronaut", "chelsea", "left", False),
    ("chelsea", "astronaut", "right", False),
    ("coffee", "chelsea", "behind", False),
    ("chelsea", "coffee", "front", False),
    ("coffee", "astronaut", "behind", True),
    ("astronaut", "coffee", "front", True),
]


_photo = photo


def _write_rgb(path: Path, img: np.ndarray) -> None:
    assert cv2.imwrite(str(path), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))


def _card_pair() -> tuple[np.ndarray, np.ndarray]:
    return card_pair(CARDS)


@pytest.fixture(scope="module")
def card_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two scenes of the same pair. scene_000 is labelled right. scene_001's label has an
    extra object ("ghost", not in the images) and one wrong clear direction (a labelling
    slip: chelsea -> astronaut "left"), so by hand: 1 of 2 usable, 6 of 7 objects found, 12 of
    18 pairs described, clear pairs 7 of 8 right, ambiguous 4 of 4."""
    root = tmp_path_factory.mktemp("cards")
    for name in CARDS:
        (root / "objects" / name).mkdir(parents=True)
        _write_rgb(root / "objects" / name / "view_00.png", _photo(name, 240))
    left, right = _card_pair()
    for i in range(2):
        scene = root / f"scene_{i:03d}"
        scene.mkdir()
        _write_rgb(scene / "left.png", left)
        _write_rgb(scene / "right.png", right)
        (scene / "calib.json").write_text(
            json.dumps({"baseline": BASELINE, "hfov_deg": HFOV, "image_size": [W, H]})
        )
        objects = [
            {"label": n, "centroid": [x, 0.0, z], "footprint": [], "distance": z}
            for n, (x, z, _) in CARDS.items()
        ]
        relations = [
            {"argument": a, "referent": b, "primary": p, "ambiguous": amb}
            for a, b, p, amb in LAYOUT
        ]
        if i == 1:
            objects.append({"label": "ghost", "centroid": [0.5, 0.0, 3.0]})
            relations[1]["primary"] = "left"
        (scene / "truth.json").write_text(json.dumps({"objects": objects, "relations": relations}))
    (root / "dataset.json").write_text(
        json.dumps(
            {"format": "scenespeak-scenes/1", "seed": 0, "scenes": ["scene_000", "scene_001"]}
        )
    )
    return root


def test_evaluate_a_labelled_dataset(card_dataset: Path) -> None:
    calls: list[tuple[int, int]] = []
    result = evaluate(card_dataset, workers=1, progress=lambda i, n: calls.append((i, n)))
    assert calls == [(1, 2), (2, 2)]
    assert [s.name for s in result.scenes] == ["scene_000", "scene_001"]
    assert (result.n_scenes, result.n_usable, result.n_failed) == (2, 1, 0)
    assert (result.objects_found, result.objects_total) == (6, 7)
    assert (result.pairs_described, result.pairs_total) == (12, 18)
    assert result.clear == (7, 8) and result.ambiguous == (4, 4)
    # the card centres are where they were put: within 3 cm in the median, 4.5 cm at worst.
    # (Before session 9 every card was within 3 cm. The dense map's reach beyond the keypoints'
    # range, perception/stereo/reach.py, lets a piece of the far background into the coffee
    # card's and the chelsea card's segments: 2.4 -> 3.9 cm and 1.9 -> 2.6 cm; docs/evaluation.md,
    # session 9, "left open".)
    errors = result.centroid_errors
    assert len(errors) == 6 and float(np.median(errors)) < 0.03 and max(errors) < 0.045
    assert all(s > 0 for s in result.seconds)
    table = format_table(result)
    assert "| scenes usable (every object a hull, every pair a sentence) | 1 / 2 (50 %)" in table


def test_two_processes_give_the_same_scores(card_dataset: Path, tmp_path: Path) -> None:
    from scenespeak.pipeline import database_from_dataset

    db = tmp_path / "objects.db"
    database_from_dataset(card_dataset, db)
    one = evaluate(card_dataset, db=db, workers=1)
    two = evaluate(card_dataset, db=db, workers=2)
    strip = [(s.name, s.usable, s.n_found, s.clear_correct, s.centroid_errors) for s in one.scenes]
    assert strip == [
        (s.name, s.usable, s.n_found, s.clear_correct, s.centroid_errors) for s in two.scenes
    ]
    assert two.workers == 2 and two.to_dict()["workers"] == 2


def test_a_single_scene_folder_and_its_truth(card_dataset: Path, tmp_path: Path) -> None:
    scene = card_dataset / "scene_000"
    assert find_scenes(scene) == [scene]
    truth = load_scene_truth(scene)
    assert [o.label for o in truth.objects] == list(CARDS) and len(truth.relations) == 6
    assert truth.relations[4].ambiguous


def test_unusable_inputs_are_input_errors(card_dataset: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not a folder"):
        evaluate(tmp_path / "nowhere")
    with pytest.raises(InputError, match="holds no scene"):
        evaluate(tmp_path)
    with pytest.raises(InputError, match="workers"):
        evaluate(card_dataset, workers=0)
    with pytest.raises(InputError, match="no such object database"):
        evaluate(card_dataset, db=tmp_path / "missing.db")
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "truth.json").write_text('{"objects": [{"label": "mug"}]}')
    with pytest.raises(InputError, match="lacks the field 'centroid'"):
        load_scene_truth(bad)
    (bad / "truth.json").write_text("{")
    with pytest.raises(InputError, match="cannot be read as JSON"):
        load_scene_truth(bad)
    (tmp_path / "dataset.json").write_text('{"scenes": ["scene_009"]}')
    with pytest.raises(InputError, match="scene_009"):
        find_scenes(tmp_path)


# --- leave-part-out: where false known objects are put ------------------------------------------


def test_false_known_objects_are_told_apart_by_where_they_are() -> None:
    """By hand, with hat and mug learnt (the can not): a 'hat' named on the can (unlearnt),
    'mug 2' 3 cm from the found mug (duplicate), 'hat 2' on the mug (neighbour), 'mug 3' 1 m
    from everything (background); the true hat is missed, the unknown object is fine."""
    truth = with_unlearnt(TRUTH, {"hat", "mug"})
    assert [o.distractor for o in truth.objects] == [False, False, True]
    pred = PredictedScene(
        "scene_a",
        {"mug": (0.2, 0.0, 1.0), "hat": (0.02, 0.0, 1.8), "mug 2": (0.23, 0.0, 1.0),
         "hat 2": (0.18, 0.0, 1.05), "mug 3": (1.5, 0.0, 1.0), "unknown object 1": (-0.3, 0, 1)},
        {},
        labels={"mug 2": "mug", "mug 3": "mug", "hat 2": "hat"},
    )  # fmt: skip
    s = score_scene(pred, truth)
    assert (s.n_objects, s.n_found, s.missing) == (2, 1, ("hat",))
    assert s.false_known == 4
    assert s.false_known_detail == (
        ("hat", "unlearnt", "can"),
        ("mug 2", "duplicate", "mug"),
        ("hat 2", "neighbour", "mug"),
        ("mug 3", "background", ""),
    )
    d = summarize([s]).to_dict()
    assert (d["false_known_unlearnt"], d["false_known_elsewhere"]) == (1, 3)
    assert d["false_known_by_kind"] == {
        "unlearnt": 1, "duplicate": 1, "neighbour": 1, "background": 1
    }  # fmt: skip
    back = EvaluationResult.from_dict(json.loads(json.dumps(d)))
    assert back.scenes[0].false_known_detail == s.false_known_detail
    assert (
        "| … on an unlearnt object / elsewhere (duplicate, neighbour, background) | 1 / 3 (1, "
        "1, 1) |" in format_table(back)
    )


def test_the_learnt_part_is_chosen_by_list_or_by_seeded_fraction() -> None:
    labels = [f"o{i:02d}" for i in range(12)]
    half = choose_learnt(labels, fraction=0.5, seed=4)
    other = choose_learnt(labels, fraction=0.5, seed=4, other=True)
    assert len(half) == len(other) == 6 and sorted(half + other) == labels
    assert half == choose_learnt(labels, fraction=0.5, seed=4)  # the seed decides
    assert {choose_learnt(labels, fraction=0.5, seed=k) for k in range(5)} != {half}
    assert len(choose_learnt(labels, fraction=0.01)) == 1  # never nothing ...
    assert len(choose_learnt(labels, fraction=0.99)) == 11  # ... and never everything
    assert choose_learnt(labels, learn=["o03", "o01"]) == ("o01", "o03")
    with pytest.raises(InputError, match="no object cup"):
        choose_learnt(labels, learn=["cup"])
    with pytest.raises(InputError, match="between 0 and 1"):
        LearnSplit(fraction=1.0)
    with pytest.raises(InputError, match="not both"):
        LearnSplit(learn=("o01",), fraction=0.5)
    assert not LearnSplit().active and LearnSplit().labels(["b", "a"]) == ("a", "b")


def test_evaluate_learning_part_of_the_objects(card_dataset: Path, tmp_path: Path) -> None:
    """Learning astronaut and chelsea only: coffee (and scene_001's ghost) become distractors,
    so by hand 4 of 4 learnt objects to find, 4 ordered pairs of them, none false."""
    result = evaluate(card_dataset, workers=1, learn=LearnSplit(learn=("astronaut", "chelsea")))
    assert (result.objects_found, result.objects_total) == (4, 4)
    assert (result.pairs_described, result.pairs_total) == (4, 4)
    assert result.false_known == 0
    assert all(s.labels == ("astronaut", "chelsea") for s in result.scenes)
    d = result.to_dict()
    assert (d["learnt"], d["unlearnt"]) == (["astronaut", "chelsea"], ["coffee"])
    assert d["split"] == {"learn": ["astronaut", "chelsea"], "fraction": None, "seed": 0,
                          "other": False}  # fmt: skip
    assert EvaluationResult.from_dict(d).to_dict()["learnt"] == ["astronaut", "chelsea"]
    assert "Learnt: astronaut, chelsea; not learnt (distractors): coffee." in format_table(result)
    with pytest.raises(InputError, match="drop --db"):
        evaluate(card_dataset, db=tmp_path / "x.db", learn=LearnSplit(fraction=0.5))


def test_the_cli_learns_the_other_part(
    card_dataset: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from scenespeak.cli import main

    args = ["evaluate", str(card_dataset), "--json", "--workers", "1", "-q"]
    assert main([*args, "--learn", "coffee", "--other-part"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert (d["learnt"], d["unlearnt"]) == (["astronaut", "chelsea"], ["coffee"])
    assert d["objects_total"] == 4 and d["false_known"] == 0
    assert main([*args, "--learn", "mug"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no object mug" in err[0]


# --- a tiny generated set ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    scenes = pytest.importorskip("scenespeak.tools.scenes")
    root = tmp_path_factory.mktemp("gen") / "gen"
    scenes.generate_dataset(root, 2, seed=3, pitched=False, progress=None)
    return root


def test_a_tiny_generated_set_learning_half_of_its_objects(generated: Path) -> None:
    from scenespeak.pipeline import dataset_labels

    result = evaluate(generated, workers=1, learn=LearnSplit(fraction=0.5, seed=2))
    d = result.to_dict()
    labels = dataset_labels(generated)
    assert sorted(d["learnt"] + d["unlearnt"]) == labels
    assert len(d["learnt"]) == round(len(labels) / 2)
    truth = [load_scene_truth(generated / f"scene_{i:03d}") for i in range(2)]
    learnt = [o for t in truth for o in t.objects if o.label in d["learnt"] and not o.distractor]
    assert result.objects_total == len(learnt)
    for s in result.scenes:
        assert set(s.labels) <= set(d["learnt"])
        assert len(s.false_known_detail) == s.false_known
        assert all(k in FALSE_KNOWN_KINDS for _n, k, _o in s.false_known_detail)
    assert d["false_known_unlearnt"] + d["false_known_elsewhere"] == d["false_known"]


def test_a_tiny_generated_set(generated: Path) -> None:
    root = generated
    result = evaluate(root, workers=1)
    truth = [load_scene_truth(root / f"scene_{i:03d}") for i in range(2)]
    # the metrics agree with the truth files, counted here by hand
    assert result.n_scenes == 2
    assert result.objects_total == sum(len(t.objects) for t in truth)
    assert result.pairs_total == sum(len(t.objects) * (len(t.objects) - 1) for t in truth)
    for s in result.scenes:
        assert s.usable == (s.n_found == s.n_objects and s.pairs_described == s.pairs_total)
        assert s.clear_total + s.ambiguous_total <= s.pairs_described
        assert len(s.centroid_errors) == s.n_found
    assert result.objects_found >= 1
