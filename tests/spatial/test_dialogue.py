"""Questions and answers (issue 13) on generated scenes with known truth.

The scenes are the generator's layouts (``tools.scenes.sample_layout``) described by the
spatial half from their true footprints (``tools.dialogue_eval.layout_scene``): every
answer is checked against the generator's ground truth, not against the rule base's output.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import pytest

from scenespeak.errors import InputError
from scenespeak.spatial.dialogue import (
    Answer,
    ask,
    load_scene,
    parse,
    scene_from_dict,
    summarize,
    viewer_entries,
)
from scenespeak.spatial.dialogue.grammar import normalise
from scenespeak.spatial.dialogue.resolve import resolve
from scenespeak.spatial.dialogue.scene import DialogueScene, hull_gap
from scenespeak.spatial.dialogue.uncertainty import (
    angle_sigma_deg,
    depth_error,
    relation_confidence,
    uncertain,
)
from scenespeak.spatial.dialogue.views import choose_referent
from scenespeak.spatial.dialogue.words import describe_object, is_clutter
from scenespeak.tools.dialogue_eval import (
    LayoutScene,
    layout_scene,
    said_direction,
    viewer_consistent,
    where_consistent,
)

SEEDS = range(8)
PHRASE = {"left": "to the left of", "right": "to the right of", "front": "in front of",
          "behind": "behind"}  # fmt: skip
OPPOSITE = {"left": "right", "right": "left", "front": "behind", "behind": "front"}


@pytest.fixture(scope="module")
def layouts() -> list[tuple[LayoutScene, DialogueScene]]:
    out = []
    for seed in SEEDS:
        ls = layout_scene(seed)
        out.append((ls, scene_from_dict(ls.description)))
    return out


def _truth(ls: LayoutScene) -> dict[tuple[str, str], dict[str, Any]]:
    return {(r["argument"], r["referent"]): r for r in ls.truth["relations"]}


def _box(label: str, x: float, y: float, s: float = 0.1, **extra: Any) -> dict[str, Any]:
    hull = [[x - s / 2, y - s / 2], [x + s / 2, y - s / 2], [x + s / 2, y + s / 2],
            [x - s / 2, y + s / 2]]  # fmt: skip
    return {"label": label, "hull": hull, "centroid": [x, 0.2, y], "points": 100,
            "height_range": [-0.25, -0.25 + s], **extra}  # fmt: skip


def _scene(*objects: dict[str, Any]) -> DialogueScene:
    """A described scene of boxes, relations from the library's rule base."""
    import numpy as np

    from scenespeak.spatial.language import relate_objects

    names = [o.get("name", o["label"]) for o in objects]
    found = relate_objects([np.array(o["hull"]) for o in objects], names=names)
    rels = [r.to_dict() for r, _ in found]
    return scene_from_dict({"objects": list(objects), "relations": rels})


# --------------------------------------------------------------------------------------------
# the grammar


@pytest.mark.parametrize(
    ("question", "form", "relation", "phrases"),
    [
        ("Where is the mug?", "where", None, ("the mug",)),
        ("where's the can", "where", None, ("the can",)),
        ("Could you please tell me where the mug is?", "where", None, ("the mug",)),
        ("Hey robot, where are the mugs?", "where", None, ("the mugs",)),
        ("Is the mug to the left of the can?", "yes-no", "left", ("the mug", "the can")),
        ("is the mug left of can", "yes-no", "left", ("the mug", "can")),
        ("Is the left mug behind the can?", "yes-no", "behind", ("the left mug", "the can")),
        ("is a mug in front of the can?", "yes-no", "front", ("a mug", "the can")),
        ("is the mug on top of the can", "yes-no", "on top of", ("the mug", "the can")),
        ("Is the mug on the can?", "yes-no", "on top of", ("the mug", "the can")),
        ("is the box on the left of the can", "yes-no", "left", ("the box", "the can")),
        ("Is the mug near the can?", "yes-no", "near", ("the mug", "the can")),
        ("is the mug next to the can", "yes-no", "next to", ("the mug", "the can")),
        ("Is the mug far from the can?", "yes-no", "far from", ("the mug", "the can")),
        ("tell me if the mug is under the box", "yes-no", "below", ("the mug", "the box")),
        ("Can you tell me whether the mugs are behind me?", "yes-no", "behind",
         ("the mugs", "me")),
        ("What is to the left of the can?", "what", "left", ("the can",)),
        ("which objects are behind the box", "what", "behind", ("the box",)),
        ("Is there anything near the can?", "what", "near", ("the can",)),
        ("what is on my left?", "what", "left", ("me",)),
        ("Which object is closest to me?", "superlative", None, ("me",)),
        ("what is the nearest object", "superlative", None, ("me",)),
        ("which object is farthest from the can?", "superlative", None, ("the can",)),
        ("What is the leftmost object?", "superlative", None, ("me",)),
        ("what do you see?", "see", None, ()),
        ("Please, what can you see?", "see", None, ()),
        ("how many objects do you see", "count", None, ()),
        ("How far is the mug from the can?", "distance", None, ("the mug", "the can")),
        ("how far away is the box", "distance", None, ("the box",)),
        ("Is the mug between the can and the box?", "between", None,
         ("the mug", "the can", "the box")),
        ("what is between the can and the box?", "what-between", None,
         ("the can", "the box")),
        ("tell me about the unknown object 2", "about", None, ("the unknown object 2",)),
        ("sing me a song", "unparsed", None, ()),
        ("", "unparsed", None, ()),
    ],
)  # fmt: skip
def test_every_question_form_parses(
    question: str, form: str, relation: str | None, phrases: tuple[str, ...]
) -> None:
    q = parse(question)
    assert q.form == form, normalise(question)
    if relation is not None:
        assert q.relation == relation
    if phrases:
        assert q.phrases == phrases


def test_superlative_words() -> None:
    assert parse("which object is closest to me?").superlative == "closest"
    assert parse("what is the nearest object").superlative == "closest"
    assert parse("which one is furthest from the can").superlative == "farthest"
    assert parse("what is the rightmost object").superlative == "rightmost"
    assert parse("which object is on the far left").superlative == "leftmost"


# --------------------------------------------------------------------------------------------
# names


def test_names_labels_plurals_and_articles() -> None:
    scene = _scene(
        _box("mug", -0.3, 1.0, name="left mug"),
        _box("mug", 0.3, 1.0, name="right mug"),
        _box("can", 0.0, 1.0),
    )
    assert resolve("the left mug", scene).one.name == "left mug"
    assert resolve("The Right Mug", scene).one.name == "right mug"
    assert resolve("the mug on the left", scene).one.name == "left mug"
    assert resolve("a can", scene).one.name == "can"
    assert resolve("cans", scene).one.name == "can"
    assert resolve("the mug", scene).status == "ambiguous"
    assert {o.name for o in resolve("the mugs", scene).objects} == {"left mug", "right mug"}
    assert resolve("me", scene).status == "me" and resolve("the camera", scene).status == "me"
    a = ask("where is the mug?", scene)
    assert a.kind == "unknown" and a.answer.startswith("Which mug do you mean?")
    assert set(a.objects) == {"left mug", "right mug"}
    a = ask("where are the mugs?", scene)
    assert a.kind == "where" and "left mug" in a.answer and "right mug" in a.answer
    a = ask("is the left mug to the left of the can?", scene)
    assert a.kind == "yes-no" and a.answer == "Yes." and a.objects == ("left mug", "can")


def test_honest_answers_for_unseen_objects_and_nonsense() -> None:
    scene = _scene(_box("mug", -0.3, 1.0), _box("can", 0.0, 1.0))
    for q, expected in [
        ("where is the cup?", "I don't see a cup."),
        ("Is the apple left of the mug?", "I don't see an apple."),
        ("is the mug left of the cup", "I don't see a cup."),
        ("where are the forks?", "I don't see any forks."),
    ]:
        a = ask(q, scene)
        assert (a.answer, a.kind, a.degree) == (expected, "unknown", None), q
    a = ask("what's the meaning of life, the universe and everything?", scene)
    assert a.kind == "unknown" and a.answer.startswith("Sorry, I did not understand")
    a = ask("is the mug left of the mug?", scene)
    assert a.kind == "unknown"


def test_answer_json_is_the_interface() -> None:
    scene = _scene(_box("mug", -0.3, 1.0), _box("can", 0.0, 1.0))
    d = ask("Is the mug to the left of the can?", scene).to_dict()
    assert list(d)[:5] == ["question", "answer", "kind", "degree", "objects"]
    assert d["question"] == "Is the mug to the left of the can?"
    assert d["kind"] in ("where", "yes-no", "which", "unknown")
    assert 0.0 <= d["degree"] <= 1.0 and d["objects"] == ["mug", "can"]
    assert 0.0 <= d["confidence"] <= 1.0
    json.dumps(d)
    assert ask("where is the cup", scene).to_dict()["degree"] is None


# --------------------------------------------------------------------------------------------
# answers against the generator's truth


def test_yes_no_on_clear_pairs_is_right(layouts: list[tuple[LayoutScene, DialogueScene]]) -> None:
    checked = 0
    for ls, scene in layouts:
        for (a, b), t in _truth(ls).items():
            if t["ambiguous"]:
                continue
            for asked in PHRASE:
                ans = ask(f"Is the {a} {PHRASE[asked]} the {b}?", scene)
                assert ans.kind == "yes-no" and ans.objects == (a, b)
                rel = scene.relation(a, b)
                assert rel is not None and ans.degree == pytest.approx(rel.degree(asked))
                if asked == t["primary"]:
                    assert re.match(r"(Yes|Mostly|Probably)", ans.answer), (a, b, ans.answer)
                elif asked == OPPOSITE[t["primary"]]:
                    assert ans.answer.startswith("No"), (a, b, asked, ans.answer)
                    assert PHRASE[rel.primary] in ans.answer or "-" in ans.answer
                else:
                    assert not ans.answer.startswith("Yes")
                checked += 1
    assert checked >= 100


def test_graded_wording_follows_the_degree() -> None:
    # straight left; left and a good deal behind; behind with a little left; right.
    scene = _scene(
        _box("can", 0.0, 1.0),
        _box("hat", -0.5, 1.0),
        _box("mug", -0.4, 1.35),
        _box("box", -0.12, 1.6),
        _box("tin", 0.5, 1.0),
    )
    assert ask("is the hat to the left of the can?", scene).answer == "Yes."
    mug = ask("is the mug to the left of the can?", scene)
    assert 0.3 < mug.degree < 0.8 and mug.answer.startswith("Mostly")
    box = ask("is the box to the left of the can?", scene)
    assert 0.05 < box.degree < 0.8 and box.answer.startswith(("Partly", "No")), box
    tin = ask("is the tin to the left of the can?", scene)
    assert tin.degree == pytest.approx(0.0, abs=0.05)
    assert tin.answer == "No, it is to the right of the can."


def test_where_names_a_referent_and_a_true_direction(
    layouts: list[tuple[LayoutScene, DialogueScene]],
) -> None:
    for ls, scene in layouts:
        truth = _truth(ls)
        for o in ls.truth["objects"]:
            a = ask(f"Where is the {o['label']}?", scene)
            assert a.kind == "where" and a.objects[0] == o["label"]
            assert a.answer.count(". ") <= 2  # one or two sentences
            if len(a.objects) > 1:
                ref = a.objects[1]
                t = truth[o["label"], ref]
                said = said_direction(a.answer)
                assert where_consistent(said, t["angle_deg"], o["on"] == ref), (a.answer, t)
                assert a.distance_m == pytest.approx(
                    hull_gap(scene.object(o["label"]).hull, scene.object(ref).hull)
                )
            else:
                assert "me" in a.answer


def test_where_prefers_a_near_clear_salient_referent() -> None:
    # The mug is just left of the can; the box far away is also exactly right of the mug.
    scene = _scene(
        _box("mug", -0.2, 1.0, 0.08), _box("can", 0.0, 1.0, 0.08), _box("box", 1.2, 1.0, 0.3)
    )
    a = ask("where is the mug?", scene)
    assert a.objects == ("mug", "can") and "to the left of the can" in a.answer
    assert "next to the can" in a.answer or "near the can" in a.answer
    # Alone, the object is placed in the camera's frame.
    alone = _scene(_box("mug", -0.4, 1.0))
    a = ask("where is the mug?", alone)
    assert a.objects == ("mug",) and "in front of me" in a.answer and "to the left" in a.answer


def test_what_is_left_of_lists_only_true_objects(
    layouts: list[tuple[LayoutScene, DialogueScene]],
) -> None:
    for ls, scene in layouts:
        truth = _truth(ls)
        for ref in scene.names:
            for d in PHRASE:
                a = ask(f"what is {PHRASE[d]} the {ref}?", scene)
                assert a.kind == "which"
                if a.answer.startswith("Nothing"):
                    assert a.objects == (ref,)
                    continue
                for name in a.objects:
                    t = truth[name, ref]
                    assert where_consistent(d, t["angle_deg"], False), (name, d, ref, t)


def test_superlatives_against_truth(layouts: list[tuple[LayoutScene, DialogueScene]]) -> None:
    for ls, scene in layouts:
        objs = ls.truth["objects"]
        near = min(objs, key=lambda o: math.dist(o["centroid"], (0, 0, 0)))
        a = ask("Which object is closest to me?", scene)
        assert a.kind == "which" and a.objects == (near["label"],)
        far = max(objs, key=lambda o: math.dist(o["centroid"], (0, 0, 0)))
        assert ask("what is the farthest object?", scene).objects == (far["label"],)
        left = min(objs, key=lambda o: math.atan2(o["centroid"][0], o["centroid"][2]))
        assert ask("what is the leftmost object?", scene).objects == (left["label"],)
        right = max(objs, key=lambda o: math.atan2(o["centroid"][0], o["centroid"][2]))
        assert ask("which object is on the far right?", scene).objects == (right["label"],)


def test_what_do_you_see_and_how_many(layouts: list[tuple[LayoutScene, DialogueScene]]) -> None:
    for ls, scene in layouts:
        labels = {o["label"] for o in ls.truth["objects"]}
        a = ask("What do you see?", scene)
        assert a.kind == "which" and set(a.objects) == labels
        assert all(f"the {lab}" in a.answer for lab in labels)
        assert ask("how many objects do you see?", scene).answer == f"I see {len(labels)} objects."


def test_distance_words_and_metres() -> None:
    scene = _scene(_box("mug", -0.15, 1.0), _box("can", 0.0, 1.0), _box("box", 1.5, 1.0))
    a = ask("how far is the mug from the can?", scene)
    assert a.kind == "where" and a.distance_m == pytest.approx(0.05)
    assert a.answer == "The mug is 5 cm from the can (next to it)."
    near = ask("is the mug next to the can?", scene)
    assert near.degree == 1.0 and near.answer.startswith("Yes")
    far = ask("is the mug far from the box?", scene)
    assert far.degree == 1.0 and far.distance_m == pytest.approx(1.55)
    assert ask("is the mug near the box?", scene).answer.startswith("No")
    assert ask("what is next to the can?", scene).objects == ("mug",)
    a = ask("how far away is the box?", scene)
    assert a.distance_m == pytest.approx(math.dist((1.5, 0.2, 1.0), (0, 0, 0)))


def test_between() -> None:
    scene = _scene(_box("mug", 0.0, 1.0), _box("can", -0.5, 1.0), _box("box", 0.5, 1.0),
                   _box("tin", 0.0, 1.6))  # fmt: skip
    a = ask("is the mug between the can and the box?", scene)
    assert a.kind == "yes-no" and a.degree == pytest.approx(1.0) and a.answer.startswith("Yes")
    b = ask("is the tin between the can and the box?", scene)
    assert b.degree < 0.3 and b.answer.startswith("No")
    c = ask("what is between the can and the box?", scene)
    assert c.kind == "which" and c.objects == ("mug",)


def test_on_top_of_from_a_stacked_layout() -> None:
    for seed in range(20):
        ls = layout_scene(seed, stacked=True)
        top = [o for o in ls.truth["objects"] if o["on"]]
        if top:
            break
    else:  # pragma: no cover
        pytest.skip("no stacked layout in 20 seeds")
    scene = scene_from_dict(ls.description)
    a, b = top[0]["label"], top[0]["on"]
    yes = ask(f"is the {a} on top of the {b}?", scene)
    assert (yes.answer, yes.degree) == ("Yes.", 1.0)
    assert ask(f"is the {b} on top of the {a}?", scene).answer.startswith("No")
    assert ask(f"is the {b} under the {a}?", scene).answer == "Yes."
    where = ask(f"where is the {a}?", scene)
    assert where.objects == (a, b) and f"on top of the {b}" in where.answer
    assert a in ask(f"what is on the {b}?", scene).objects


def test_summary_has_at_most_n_plus_one_sentences_and_every_object(
    layouts: list[tuple[LayoutScene, DialogueScene]],
) -> None:
    for ls, scene in layouts:
        text = summarize(scene)
        sentences = re.split(r"(?<=[.!?])\s+", text)
        assert len(sentences) <= len(scene.objects) + 1
        assert all(f"the {o['label']}" in text for o in ls.truth["objects"])


def test_viewer_is_consistent_with_the_camera_position(
    layouts: list[tuple[LayoutScene, DialogueScene]],
) -> None:
    for ls, scene in layouts:
        entries = {e["object"]: e for e in viewer_entries(scene)}
        for o in ls.truth["objects"]:
            e = entries[o["label"]]
            assert viewer_consistent(e, o["centroid"][0], o["centroid"][2]), e
            assert e["distance_m"] == pytest.approx(math.dist(o["centroid"], (0, 0, 0)), abs=1e-3)
            assert "me" in e["sentence"]


def test_yes_no_about_me() -> None:
    scene = _scene(_box("mug", -0.5, 1.0), _box("can", 0.5, 1.0))
    a = ask("is the mug to the left of me?", scene)
    assert a.kind == "yes-no" and a.degree > 0.5 and "to the left" in a.answer
    b = ask("is the can to the left of you?", scene)
    assert b.degree == 0.0 and b.answer.startswith("No")
    assert ask("what is on my left?", scene).objects == ("mug",)
    assert ask("what is on your right?", scene).objects == ("can",)


# --------------------------------------------------------------------------------------------
# unknown objects, clutter, uncertainty


def test_unknown_objects_are_described_and_clutter_kept_out() -> None:
    scene = _scene(
        _box("mug", 0.0, 1.0),
        _box("unknown object 1", -0.3, 1.0, 0.06, color=[200, 30, 30]),
        # a flat, wide cluster far behind: a patch of floor, not a thing
        _box("unknown object 2", 0.4, 2.5, 0.8, height_range=[-0.25, -0.245]),
    )
    red, floor = scene.objects[1], scene.objects[2]
    assert describe_object(red) == "small red object" and not is_clutter(red)
    assert is_clutter(floor)
    see = ask("what do you see?", scene)
    assert see.objects == ("unknown object 1", "mug")
    assert "small red object" in see.answer and "unknown object" not in see.answer
    assert "unknown object 2" not in summarize(scene)
    a = ask("where is the small red object?", scene)
    assert a.objects == ("unknown object 1", "mug")
    assert a.answer.startswith("The small red object is ") and "left of the mug" in a.answer
    about = ask("tell me about unknown object 1", scene)
    assert about.answer.startswith("It is a small red object I cannot name")
    assert ask("where is the mug?", scene).objects[1:] != ("unknown object 2",)


def test_depth_error_and_probably() -> None:
    assert depth_error(2.0, focal_px=500.0, baseline_m=0.1, sigma_px=1.0) == pytest.approx(0.08)
    # Two small objects 5 m away, mostly behind one another but with a large sideways part:
    # the depth error could turn "behind" into "to the left".
    far = _scene(_box("mug", -0.25, 5.5, 0.05), _box("can", 0.0, 5.0, 0.05))
    rel = far.relation("mug", "can")
    assert rel is not None and rel.primary == "behind"
    assert angle_sigma_deg(far.object("mug"), far.object("can"), far) > 5.0
    assert uncertain(rel, far)
    a = ask("is the mug behind the can?", far)
    assert a.answer.startswith("Probably")
    # "where" then falls back to the camera's frame (or says "probably").
    where = ask("where is the mug?", far).answer
    assert "probably" in where or "in front of me" in where
    # The same layout at 1 m is sure.
    near = _scene(_box("mug", -0.25, 1.5, 0.05), _box("can", 0.0, 1.0, 0.05))
    rel_near = near.relation("mug", "can")
    assert rel_near is not None and not uncertain(rel_near, near)
    assert relation_confidence(rel_near, near) >= relation_confidence(rel, far)


def test_referent_choice_scores_clarity() -> None:
    scene = _scene(_box("mug", 0.0, 1.0), _box("can", 0.15, 1.15), _box("box", 0.0, 1.5))
    chosen = choose_referent(scene.object("mug"), scene)
    assert chosen is not None and chosen[0].name == "box"  # clear "in front of", not diagonal


# --------------------------------------------------------------------------------------------
# the saved scene


def test_load_scene_and_its_errors(tmp_path: Path) -> None:
    ls = layout_scene(1)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(ls.description))
    a = ask("where is the card?", load_scene(path))
    b = ask("where is the card?", ls.description)
    assert a == b and isinstance(a, Answer)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(InputError, match="cannot be read as JSON"):
        load_scene(bad)
    with pytest.raises(InputError, match="no such file"):
        load_scene(tmp_path / "missing.json")
    with pytest.raises(InputError, match='no "objects" list'):
        scene_from_dict({"relations": []})
    with pytest.raises(InputError, match="hull"):
        scene_from_dict({"objects": [{"label": "mug", "hull": [[0, 0]]}]})
    with pytest.raises(InputError, match="not in 'objects'"):
        scene_from_dict(
            {"objects": [], "relations": [{"argument": "a", "referent": "b", "primary": "left"}]}
        )


def test_names_from_the_naming_module_resolve() -> None:
    import numpy as np

    from scenespeak.contract import SpatialObject
    from scenespeak.spatial.naming import instance_names

    boxes = [_box("mug", 0.0, 1.0), _box("mug", 0.0, 1.6), _box("can", 0.6, 1.0)]
    names = instance_names(
        [SpatialObject(b["label"], b["label"], np.array(b["hull"])) for b in boxes]
    )
    scene = _scene(*[{**b, "name": n} for b, n in zip(boxes, names, strict=True)])
    for name in names:
        a = ask(f"where is the {name}?", scene)
        assert a.kind == "where" and a.objects[0] == name, (name, a)
    front, back = names[0], names[1]
    a = ask(f"is the {back} behind the {front}?", scene)
    assert a.answer == "Yes." and a.objects == (back, front)
    assert ask("where is the mug?", scene).answer.startswith("Which mug do you mean?")
