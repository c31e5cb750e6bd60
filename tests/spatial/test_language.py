"""Spatial language: layouts through ``scenespeak.relate``, rules on synthetic histograms,
grammar, the vertical plane, viewer-centric relations and the scene summary."""

from __future__ import annotations

import itertools
import json
import re

import numpy as np
import pytest

import scenespeak
from scenespeak.errors import InputError
from scenespeak.spatial import language
from scenespeak.spatial.degrees import direction_degree, four_degrees
from scenespeak.spatial.language import (
    DIRECTIONS,
    Relation,
    Thresholds,
    describe_relation,
    describe_viewer_relation,
    layout_table,
    relate,
    rules,
    summarize_scene,
    vertical_relation,
    words,
)
from scenespeak.spatial.layouts import (
    FIG8,
    FIG9,
    FIG10,
    FIG11,
    FIG11_HEIGHTS,
    LAYOUTS,
    disc,
    polar,
    rect,
)

N = 180


def spike(deg: float, n: int = N) -> np.ndarray:
    h = np.zeros(n)
    h[round(deg / (360 / n)) % n] = 1.0
    return h


def say(scene: dict[str, np.ndarray], a: str, b: str, **kw: object) -> Relation:
    return scenespeak.relate(scene[a], scene[b], argument=a, referent=b, **kw)


# -- The seed paper's seven sentences, word for word ----------------------------------------
SEED = [
    (FIG8, "hat", "mug", "The hat is mostly to the left of the mug but somewhat behind."),
    (FIG8, "mug", "can", "The mug is mostly to the right of the can but somewhat to the front."),
    (FIG8, "can", "hat", "The can is front-left of the hat."),
    (
        FIG9,
        "hat",
        "can",
        "The hat is to the left of the can but extends to the rear relative to the can.",
    ),
    (FIG10, "mug", "can", "The mug is to the left of the can."),
    (FIG11, "hat", "mug", "The hat is mostly in front of the mug but somewhat to the right."),
    (FIG11, "mug", "can", "The mug is surrounded by the can."),
]


@pytest.mark.parametrize(("scene", "a", "b", "sentence"), SEED, ids=[s[3][:40] for s in SEED])
def test_seed_sentences(scene: dict, a: str, b: str, sentence: str) -> None:
    assert say(scene, a, b).sentence == sentence


def test_seed_other_sentences_of_the_same_figures() -> None:
    # The figures' remaining sentences that our pattern table words the same way.
    assert say(FIG10, "hat", "mug").sentence == (
        "The hat is mostly to the right of the mug but somewhat to the front."
    )
    assert say(FIG10, "can", "hat").sentence == (
        "The can is mostly to the right of the hat but somewhat behind."
    )
    assert say(FIG11, "can", "hat").sentence == (
        "The can is mostly behind the hat but somewhat to the left."
    )


def test_seed_scenes_match_their_captions() -> None:
    # Fig. 8: the hat is between the can and the mug (left to right) and the farthest back.
    cx = {k: v.mean(axis=0) for k, v in FIG8.items()}
    assert cx["can"][0] < cx["hat"][0] < cx["mug"][0]
    assert cx["hat"][1] > max(cx["can"][1], cx["mug"][1])
    # Fig. 11: the mug's footprint lies inside the can's.
    assert say(FIG11, "mug", "can").overlap == pytest.approx(1.0)


def test_fig11_with_heights_says_on_top_of() -> None:
    rel = say(FIG11, "mug", "can", a_heights=FIG11_HEIGHTS["mug"], b_heights=FIG11_HEIGHTS["can"])
    assert rel.sentence == "The mug is on top of the can."
    assert rel.vertical == "on top of"
    assert rel.primary == "surrounded"  # the horizontal rule set's answer is kept
    assert rel.horizontal_sentence == "The mug is surrounded by the can."
    back = say(FIG11, "can", "mug", a_heights=FIG11_HEIGHTS["can"], b_heights=FIG11_HEIGHTS["mug"])
    assert back.sentence == "The can is under the mug."
    # The hat stands on the table beside them: no vertical relation, horizontal words stay.
    hat = say(FIG11, "hat", "mug", a_heights=FIG11_HEIGHTS["hat"], b_heights=FIG11_HEIGHTS["mug"])
    assert hat.vertical is None
    assert hat.sentence == "The hat is mostly in front of the mug but somewhat to the right."


# -- One layout per pattern -------------------------------------------------------------------
BOX = disc(0.0, 1.0, 0.05)


def cup_at(deg: float, r: float = 0.3) -> np.ndarray:
    return disc(*polar(r, deg), 0.05)


@pytest.mark.parametrize(
    ("deg", "word"),
    [(0, "to the right of"), (90, "behind"), (180, "to the left of"), (270, "in front of")],
)
def test_each_direction(deg: float, word: str) -> None:
    rel = relate(cup_at(deg), BOX, argument="cup", referent="box")
    assert rel.sentence == f"The cup is directly {word} the box."
    assert rel.primary == DIRECTIONS[deg // 90]
    assert rel.secondary is None


@pytest.mark.parametrize(
    ("deg", "sentence"),
    [
        (177, "The cup is directly to the left of the box."),
        (168, "The cup is to the left of the box."),
        (165, "The cup is to the left of the box but slightly behind."),
        (158, "The cup is mostly to the left of the box but slightly behind."),
        (147, "The cup is mostly to the left of the box but somewhat behind."),
        (200, "The cup is mostly to the left of the box but slightly to the front."),
        (215, "The cup is mostly to the left of the box but somewhat to the front."),
        (225, "The cup is front-left of the box."),
        (135, "The cup is rear-left of the box."),
        (45, "The cup is rear-right of the box."),
        (310, "The cup is front-right of the box."),
        (123, "The cup is mostly behind the box but somewhat to the left."),
    ],
)
def test_hedge_bands_on_layouts(deg: float, sentence: str) -> None:
    assert relate(cup_at(deg), BOX, argument="cup", referent="box").sentence == sentence


def test_layout_directly() -> None:
    rel = relate(rect(-0.4, 0.95, -0.2, 1.05), BOX, argument="book", referent="box")
    assert rel.hedge == "directly"
    assert rel.degrees["left"] >= Thresholds().directly


def test_layout_loosely() -> None:
    bracket = next(lay for lay in LAYOUTS if lay.name == "loosely")
    rel = relate(bracket.a, bracket.b, argument="bracket", referent="box")
    assert rel.sentence == "The bracket is loosely to the left of the box."
    assert rel.degrees["left"] < Thresholds().mostly
    assert rel.overlap == 0.0  # disjoint: never "surrounded", however wide the histogram


def test_layout_extends() -> None:
    rel = relate(rect(-0.3, 0.95, -0.15, 1.5), BOX, argument="bar", referent="box")
    assert rel.sentence == (
        "The bar is mostly to the left of the box but extends to the rear relative to the box."
    )
    assert rel.secondary_hedge == "extends"
    assert abs(np.degrees(rel.deviation)) < Thresholds().extends_deviation_deg
    assert rel.extends_share >= Thresholds().extends_share
    # The same bar centred on the box's depth spreads both ways: no extension.
    sym = relate(rect(-0.3, 0.7, -0.15, 1.3), BOX, argument="bar", referent="box")
    assert sym.secondary_hedge != "extends"
    assert sym.primary == "left"


def test_layout_surrounded() -> None:
    tray = disc(0.0, 1.0, 0.15, 48)
    rel = relate(disc(0.02, 1.0, 0.04), tray, argument="coin", referent="tray")
    assert rel.sentence == "The coin is surrounded by the tray."
    assert rel.primary == "surrounded" and rel.kind == "surrounded"
    assert rel.coverage >= Thresholds().surround_full
    assert rel.hybrid  # F2 is undefined for intersecting objects: F02 was used
    conv = relate(tray, disc(0.02, 1.0, 0.04), argument="tray", referent="coin")
    assert conv.sentence == "The tray surrounds the coin."
    assert conv.primary == "surrounded" and conv.kind == "surrounds"


def test_layout_partly_surrounded() -> None:
    tray = disc(0.0, 1.0, 0.15, 48)
    rel = relate(disc(-0.12, 1.0, 0.05, 32), tray, argument="coin", referent="tray")
    assert rel.sentence == "The coin is partly surrounded by the tray."
    assert rel.kind == "partly surrounded"
    assert max(rel.degrees.values()) >= Thresholds().fits  # a direction half fits...
    assert max(rel.degrees.values()) < Thresholds().fits_partly  # ...but not well enough
    assert 0.0 < rel.overlap < 1.0


def test_layout_overlap_but_direction() -> None:
    # Half out of the tray: the direction fits well enough to win over "partly surrounded".
    tray = disc(0.0, 1.0, 0.15, 48)
    rel = relate(disc(-0.15, 1.0, 0.05, 32), tray, argument="coin", referent="tray")
    assert rel.overlap > 0.0
    assert rel.sentence == "The coin is mostly to the left of the tray."


def test_touching_objects_use_the_hybrid_histogram() -> None:
    rel = relate(rect(0, 0, 1, 1), rect(1, 0, 2, 1), argument="book", referent="box")
    assert rel.hybrid and rel.overlap == 0.0
    assert rel.sentence == "The book is directly to the left of the box."


def test_overlap_areas() -> None:
    from scenespeak.geometry.polygons import intersection_area

    sq = rect(0, 0, 2, 2)
    assert intersection_area(rect(1, 1, 3, 3), sq) == pytest.approx(1.0)
    # Non-convex on both sides: the grid estimate (U-shape and an L-shape).
    u = np.array([[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]], float)
    ell = np.array([[0.5, 0.5], [2.5, 0.5], [2.5, 0.8], [0.8, 0.8], [0.8, 2.5], [0.5, 2.5]])
    exact = 0.3 * (2.5 - 0.5) + 0.3 * (2.5 - 0.8)  # the L lies wholly in the U's base and wall
    assert intersection_area(ell, u) == pytest.approx(exact, rel=0.02)
    assert intersection_area(ell + np.array([1.0, 0.0]), u) < 0.9 * exact


def test_layout_table_sentences() -> None:
    table = layout_table()
    for *_, sentence in SEED:
        assert sentence in table
    assert "The lamp is above the box." in table
    assert table.count("```text") == len(LAYOUTS)


# -- The degree of truth on synthetic histograms ----------------------------------------------
def test_uniform_histogram_scores_zero() -> None:
    for d in four_degrees(np.ones(N)).values():
        assert d.degree == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("delta", [0, 2, 10, 20, 30, 44, 46, 60, 80, 88, 90])
def test_spike_degree_is_linear_in_the_offset(delta: int) -> None:
    for k, name in enumerate(DIRECTIONS):
        for sign in (1, -1):
            h = spike(90 * k + sign * delta)
            deg = four_degrees(h)[name]
            assert deg.degree == pytest.approx(1 - delta / 90, abs=0.02)
            assert np.degrees(deg.deviation) == pytest.approx(sign * delta if delta < 90 else 0)


def test_opposite_and_perpendicular_spikes() -> None:
    d = four_degrees(spike(180))
    assert d["right"].degree == 0.0
    assert d["behind"].degree == pytest.approx(0.0) and d["front"].degree == pytest.approx(0.0)
    assert d["left"].degree == 1.0


def test_contrary_forces_cancel_the_nearest_favourable_ones() -> None:
    # 1 unit at 0°, 1 unit at 120° (30° past the pivot at 90°): the moment 1·30° cancels
    # the favourable force at 0° in part (it sits 90° from the pivot): 1/3 of it is gone.
    h = spike(0) + spike(120)
    d = direction_degree(h, 0)
    assert d.effective == pytest.approx(2 / 3)
    assert d.contrary == pytest.approx(1 + 1 / 3)
    assert d.degree == pytest.approx((2 / 3) / 2)


def test_mixture_of_two_spikes_leans_to_the_heavier() -> None:
    h = 2 * spike(180) + spike(130)  # mostly left, some behind-left
    rel = describe_relation(h, h)
    assert rel.primary == "left"
    assert rel.secondary == "behind"
    assert rel.deviation < 0  # clockwise from left is behind


def test_hedge_bands_on_spikes() -> None:
    t = Thresholds()
    # a(P) = 1 − δ/90: "directly" within 6.3°, none to 18°, "mostly" to 40.5°.
    cases = {0: "directly", 6: "directly", 8: None, 16: None, 20: "mostly", 36: "mostly"}
    for delta, hedge in cases.items():
        rel = describe_relation(spike(180 - delta), spike(180 - delta))
        assert rel.hedge == hedge, delta
    # a(S) = δ/90: no secondary below secondary_min (13.5°).
    assert describe_relation(spike(168), spike(168)).secondary is None
    assert describe_relation(spike(164), spike(164)).secondary == "behind"
    assert t.secondary_min == 0.15


def test_secondary_bands_on_spikes() -> None:
    # "somewhat" from a(S) >= 0.30 (a lean of 27°), "slightly" below.
    assert describe_relation(spike(154), spike(154)).secondary_hedge == "slightly"
    assert describe_relation(spike(152), spike(152)).secondary_hedge == "somewhat"


def test_compound_band_on_spikes() -> None:
    # Compound within ±6.75° of the diagonal: |a(P) − a(S)| < 0.15.
    for deg in (220, 224, 226, 230):
        assert describe_relation(spike(deg), spike(deg)).kind == "compound", deg
    for deg in (216, 234):
        assert describe_relation(spike(deg), spike(deg)).kind == "direction", deg


def test_extends_rule_on_synthetic() -> None:
    # F2: a narrow peak at 180°; F0: the same peak plus 30 % of its mass around 100°.
    f2 = spike(178) + spike(182)
    f0 = f2 + 0.3 * (spike(98) + spike(102)) / 0.6 * 0.6
    rel = describe_relation(f0, f2, argument="hat", referent="can")
    assert rel.secondary_hedge == "extends"
    assert rel.sentence.endswith("but extends to the rear relative to the can.")
    # Symmetric spread (front and behind alike) is not an extension.
    sym = f2 + 0.3 * (spike(100) + spike(260))
    assert describe_relation(sym, f2).secondary_hedge != "extends"


def test_coverage_on_synthetic() -> None:
    t = Thresholds()
    half = np.where(np.arange(N) < N // 2, 1.0, 0.0)
    assert rules._coverage(half, t) == pytest.approx(0.5 + 10 / 180, abs=0.02)
    # Isolated empty bins (hull noise) are smoothed away: coverage stays complete.
    holes = np.ones(N)
    holes[::15] = 0.0
    assert rules._coverage(holes, t) == 1.0
    # Tails below 10 % of the maximum do not count.
    tail = np.full(N, 0.05)
    tail[:90] = 1.0
    assert rules._coverage(tail, t) < 0.6


def test_surround_rule_on_synthetic() -> None:
    flat = np.ones(N)
    assert describe_relation(flat, flat).kind == "surrounded"
    # Overlap 0 (disjoint objects) rules out "surrounded".
    assert describe_relation(flat, flat, overlap=0.0).kind == "direction"
    # A flat histogram with a bump: a direction that fits wins.
    bump = flat + 400 * spike(0)
    assert describe_relation(bump, bump).primary == "right"
    # The larger object surrounds the smaller one.
    rel = describe_relation(
        flat, flat, argument="tray", referent="coin", overlap=0.1, referent_overlap=1.0
    )
    assert rel.sentence == "The tray surrounds the coin."


def test_facts_object_and_keywords_agree() -> None:
    flat = np.ones(N)
    facts = language.RelationFacts(overlap=0.1, referent_overlap=1.0, vertical="on top of")
    by_object = describe_relation(flat, flat, "tray", "coin", facts=facts)
    by_keywords = describe_relation(
        flat, flat, "tray", "coin", overlap=0.1, referent_overlap=1.0, vertical="on top of"
    )
    assert by_object == by_keywords
    assert by_object.vertical == "on top of" and by_object.overlap == 0.1
    with pytest.raises(InputError, match="not both"):
        describe_relation(flat, flat, facts=facts, overlap=0.0)
    with pytest.raises(TypeError, match="unexpected keyword argument 'overlapp'"):
        describe_relation(flat, flat, overlapp=0.0)  # type: ignore[call-arg]


# -- Grammar ----------------------------------------------------------------------------------
def test_every_combination_is_grammatical() -> None:
    seen = set()
    hedges = ["directly", None, "mostly", "loosely"]
    for frame in ("object", "viewer"):
        for p, hedge in itertools.product(DIRECTIONS, hedges):
            ccw, cw = rules._neighbours(p)
            options = [(None, None)] + [
                (s, sh) for s in (ccw, cw) for sh in ("somewhat", "slightly", "extends")
            ]
            for s, sh in options:
                d = words._Decision("direction", p, s, hedge, sh, 1.0, 0.0, 0.0, 0.0)
                seen.add(words._render(d, "hat", "can", frame))
        for fb, lr in itertools.product(("front", "behind"), ("left", "right")):
            d = words._Decision("compound", fb, lr, None, None, 1.0, 0.0, 0.0, 0.0)
            seen.add(words._render(d, "hat", "can", frame))
        for kind in ("surrounded", "partly surrounded", "surrounds", "partly surrounds"):
            d = words._Decision(kind, "surrounded", None, None, None, 1.0, 0.0, 0.0, 0.0)
            seen.add(words._render(d, "hat", "can", frame))
        for v in language.VERTICAL_WORDS:
            d = words._Decision("direction", "left", None, None, None, 1.0, 0.0, 0.0, 0.0)
            seen.add(words._render(d, "hat", "can", frame, v))
    assert len(seen) > 150
    for s in seen:
        assert re.fullmatch(r"The hat [a-z][a-zI ,\-]*[a-z]\.", s), s
        assert "  " not in s and " ," not in s, s
        for bad in (
            "to the behind",
            "to the in front",
            "the front of",
            "to behind",
            "in behind",
            "to the rear of",
            "None",
        ):
            assert bad not in s, s
    assert "The hat is mostly to the left of the can but somewhat behind." in seen
    assert "The hat is in front of me, slightly to the left." in seen
    assert "The hat is on top of the can." in seen


def test_to_dict_is_json_ready() -> None:
    rel = say(FIG8, "hat", "mug")
    d = rel.to_dict()
    text = json.dumps(d)
    back = json.loads(text)
    assert back["primary"] == "left" and back["secondary"] == "behind"
    assert back["sentence"] == rel.sentence
    assert back["deviation_deg"] == pytest.approx(np.degrees(rel.deviation))
    assert set(back["degrees"]) == set(DIRECTIONS)
    assert back["vertical"] is None


def test_labels_come_from_the_caller() -> None:
    rel = relate(cup_at(180), BOX, argument="red cup", referent="blue box")
    assert rel.sentence == "The red cup is directly to the left of the blue box."


# -- The vertical plane -----------------------------------------------------------------------
def test_vertical_rule() -> None:
    t = Thresholds()
    can = np.linspace(0.0, 0.12, 30)
    mug = np.linspace(0.12, 0.22, 20)
    assert vertical_relation(mug, can, horizontal_overlap=1.0) == "on top of"
    assert vertical_relation(can, mug, horizontal_overlap=1.0) == "under"
    # Within the contact tolerance either way: still contact.
    assert vertical_relation(mug + 0.025, can, horizontal_overlap=1.0) == "on top of"
    assert vertical_relation(mug - 0.025, can, horizontal_overlap=1.0) == "on top of"
    # Beyond it: "above" / "below".
    assert vertical_relation(mug + 0.08, can, horizontal_overlap=1.0) == "above"
    assert vertical_relation(can, mug + 0.08, horizontal_overlap=1.0) == "below"
    # The tolerance grows with the thinner object's extent (25 %): 1 m tall objects, 10 cm gap.
    tall = np.linspace(0.0, 1.0, 50)
    assert vertical_relation(tall + 1.1, tall, horizontal_overlap=1.0) == "on top of"
    assert vertical_relation(tall + 1.3, tall, horizontal_overlap=1.0) == "above"
    # Overlapping height ranges (a mug inside a bin): no vertical relation.
    assert vertical_relation(mug - 0.1, can, horizontal_overlap=1.0) is None
    # A stray low keypoint does not matter (5th percentile).
    noisy = np.concatenate([mug, [0.0]])
    assert vertical_relation(noisy, can, horizontal_overlap=1.0) == "on top of"
    assert t.contact_tolerance == 0.05 and t.contact_fraction == 0.25


def test_vertical_needs_overlap() -> None:
    can = np.linspace(0.0, 0.12, 30)
    mug = np.linspace(0.12, 0.22, 20)
    assert vertical_relation(mug, can, horizontal_overlap=0.09) is None
    assert vertical_relation(mug, can, horizontal_overlap=0.11) == "on top of"
    # Through relate: side by side on a shelf at different heights stays horizontal.
    rel = relate(cup_at(180), BOX, argument="cup", referent="box", a_heights=mug, b_heights=can)
    assert rel.vertical is None
    assert rel.sentence == "The cup is directly to the left of the box."


def test_vertical_takes_precedence_over_a_direction_too() -> None:
    # A book lying on a box but sticking out to the left.
    box = rect(-0.1, 0.9, 0.1, 1.1)
    book = rect(-0.2, 0.95, 0.0, 1.05)
    rel = relate(
        book,
        box,
        argument="book",
        referent="box",
        a_heights=np.linspace(0.2, 0.23, 5),
        b_heights=np.linspace(0.0, 0.2, 9),
    )
    assert rel.sentence == "The book is on top of the box."
    assert rel.primary in (*DIRECTIONS, "surrounded")


def test_vertical_errors() -> None:
    with pytest.raises(InputError, match="a_heights"):
        vertical_relation([], [0.0], horizontal_overlap=1.0)
    with pytest.raises(InputError, match="b_heights"):
        vertical_relation([0.0], [np.nan], horizontal_overlap=1.0)
    with pytest.raises(InputError, match="horizontal_overlap"):
        vertical_relation([0.0], [1.0], horizontal_overlap=-1.0)
    with pytest.raises(InputError, match="both"):
        relate(cup_at(0), BOX, a_heights=[0.0, 1.0])


# -- Viewer-centric -----------------------------------------------------------------------------
def test_viewer_relation() -> None:
    mug = disc(-0.35, 1.1, 0.05)
    rel = describe_viewer_relation(mug, "mug")
    assert rel.sentence == "The mug is in front of me, slightly to the left."
    assert rel.referent == "me" and rel.frame == "viewer"
    assert rel.primary == "front" and rel.secondary == "left"
    ahead = describe_viewer_relation(disc(0.0, 1.0, 0.05), "mug")
    assert ahead.sentence == "The mug is directly in front of me."
    right = describe_viewer_relation(disc(0.8, 0.0, 0.05), "can")
    assert right.sentence == "The can is directly to my right."
    diag = describe_viewer_relation(disc(-0.7, 0.7, 0.05), "hat")
    assert diag.sentence == "The hat is in front of me and to the left."


def test_viewer_relation_is_mirrored_in_depth_only() -> None:
    # The same object relative to a box at the camera: "behind" the box is "in front of me".
    mug = disc(-0.35, 1.1, 0.05)
    as_object = relate(mug, rect(-0.05, -0.05, 0.05, 0.05), argument="mug", referent="box")
    as_viewer = describe_viewer_relation(mug, "mug")
    assert as_object.primary == "behind" and as_viewer.primary == "front"
    assert as_object.secondary == as_viewer.secondary == "left"


def test_viewer_errors() -> None:
    with pytest.raises(InputError, match="viewer_size"):
        describe_viewer_relation(disc(0, 1, 0.1), "mug", viewer_size=0.0)


# -- Scene summary ----------------------------------------------------------------------------
def all_relations(scene: dict, heights: dict | None = None) -> list[Relation]:
    out = []
    for a, b in itertools.permutations(scene, 2):
        kw = {}
        if heights:
            kw = {"a_heights": heights[a], "b_heights": heights[b]}
        out.append(say(scene, a, b, **kw))
    return out


def test_summary_of_fig8() -> None:
    rels = all_relations(FIG8)
    text = summarize_scene(rels)
    assert text.startswith("From left to right: the can, the hat and the mug.")
    sentences = re.findall(r"[^.]+\.", text)
    assert len(sentences) <= 1 + 3 < len(rels)
    assert "The can is front-left of the hat." in text


def test_summary_of_fig11_prefers_the_vertical_relation() -> None:
    text = summarize_scene(all_relations(FIG11, FIG11_HEIGHTS))
    assert "The mug is on top of the can." in text
    assert "The can is under the mug." not in text  # a pair is said only once


def test_summary_uses_centroids_for_nearest_neighbours() -> None:
    sq = rect(0, 0, 0.1, 0.1)
    scene = {"a": sq, "b": sq + np.array([0.2, 0.0]), "c": sq + np.array([2.0, 0.0])}
    cents = {k: v.mean(axis=0) for k, v in scene.items()}
    text = summarize_scene(all_relations(scene), centroids=cents)
    assert "The c is directly to the right of the b." in text
    assert "of the a." not in text.split(". ")[-1]


def test_summary_of_nothing() -> None:
    assert summarize_scene([]) == ""


# -- Errors -------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("f0", "f2", "match"),
    [
        (np.ones(10), np.ones(10), "multiple of 4"),
        (np.ones((4, 45)), np.ones(180), "1-D"),
        (np.ones(180), np.ones(176), "bins"),
        (-np.ones(180), np.ones(180), "negative"),
        (np.ones(180), np.full(180, np.inf), "hybrid F02"),
    ],
)
def test_describe_relation_errors(f0: np.ndarray, f2: np.ndarray, match: str) -> None:
    with pytest.raises(InputError, match=match):
        describe_relation(f0, f2)


def test_relate_errors() -> None:
    with pytest.raises(InputError, match="argument polygon"):
        relate(np.zeros((2, 2)), BOX)
    with pytest.raises(InputError, match="zero area"):
        relate(np.array([[0, 0], [1, 1], [2, 2]]), BOX)
    with pytest.raises(InputError, match="directions"):
        relate(cup_at(0), BOX, directions=90)
    with pytest.raises(InputError, match="argument"):
        relate(cup_at(0), BOX, argument="")
    with pytest.raises(InputError, match="vertical"):
        describe_relation(np.ones(180), np.ones(180), vertical="beside")


def test_docs_table_is_current() -> None:
    from pathlib import Path

    doc = Path(__file__).resolve().parents[2] / "docs" / "language.md"
    text = doc.read_text(encoding="utf-8")
    # Regenerate with: python -m scenespeak.spatial.language --update-doc docs/language.md
    assert language.update_doc_table(text) == text


def test_cli_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert language.main(["--table"]) == 0
    out = capsys.readouterr().out
    assert "The can is front-left of the hat." in out


# -- One histogram computation shared by relate and the pipeline -----------------------------
@pytest.mark.parametrize(
    "a, b",
    [
        (cup_at(150), BOX),  # disjoint: F0 and F2 from one sweep
        (rect(0, 0, 1, 1), rect(1, 0, 2, 1)),  # touching: hybrid F02
        (disc(0.02, 1.0, 0.04), disc(0.0, 1.0, 0.15, 48)),  # inside: surrounded
    ],
)
def test_pair_histograms_are_what_relate_decides_from(a: np.ndarray, b: np.ndarray) -> None:
    pair = language.pair_histograms(a, b)
    assert pair.f0.shape == pair.f2.shape == (N,)
    rel = relate(a, b, argument="cup", referent="box")
    assert rel.hybrid == pair.hybrid
    same = language.relation_of_pair(pair, argument="cup", referent="box")
    assert same.to_dict() == rel.to_dict()
    back = relate(b, a, argument="box", referent="cup")
    assert np.allclose(pair.reversed().f0, language.pair_histograms(b, a).f0, atol=1e-9)
    # both ways at once: the reverse is bit for bit the reversed pair described on its own
    ab, ba = language.relations_of_pair(pair, argument="cup", referent="box")
    assert ab.to_dict() == rel.to_dict()
    alone = language.relation_of_pair(pair.reversed(), argument="box", referent="cup")
    assert ba.to_dict() == alone.to_dict()
    assert (ba.primary, ba.secondary, ba.kind) == (back.primary, back.secondary, back.kind)


def test_relations_of_pair_with_heights_gives_both_vertical_words() -> None:
    mug = np.linspace(0.12, 0.22, 20)
    can = np.linspace(0.0, 0.12, 30)
    pair = language.pair_histograms(cup_at(180, r=0.01), BOX)
    ab, ba = language.relations_of_pair(
        pair, argument="mug", referent="can", a_heights=mug, b_heights=can
    )
    assert (ab.vertical, ba.vertical) == ("on top of", "under")
    assert ab.sentence == "The mug is on top of the can."
    with pytest.raises(InputError):
        language.relations_of_pair(pair, a_heights=mug)
    with pytest.raises(InputError):
        language.pair_histograms(BOX, BOX, directions=90)
