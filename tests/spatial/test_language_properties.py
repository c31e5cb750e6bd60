"""Property tests of the spatial-language rules (hypothesis, derandomised in conftest)."""

from __future__ import annotations

import itertools
import math
from dataclasses import astuple

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st

from scenespeak.spatial.degrees import DIRECTIONS, four_degrees
from scenespeak.spatial.language import Relation, Thresholds, describe_relation, relate

OPPOSITE = {"left": "right", "right": "left", "front": "behind", "behind": "front"}
MIRROR = {"left": "right", "right": "left", "front": "front", "behind": "behind"}
ROTATE = {"right": "behind", "behind": "left", "left": "front", "front": "right"}  # +90°


def ellipse(cx: float, cy: float, a: float, b: float, rot: float, n: int) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    x, y = a * np.cos(t), b * np.sin(t)
    c, s = math.cos(rot), math.sin(rot)
    return np.column_stack([cx + c * x - s * y, cy + s * x + c * y])


@st.composite
def shapes(draw: st.DrawFn) -> tuple[float, float, float, int]:
    a = draw(st.floats(0.02, 0.25))
    b = draw(st.floats(0.02, 0.25))
    rot = draw(st.floats(0.0, math.pi))
    n = draw(st.integers(5, 14))
    return a, b, rot, n


@st.composite
def layouts(draw: st.DrawFn, overlap: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Two convex polygons: B near (0, 1) m, A at a random bearing and distance."""
    sa, sb = draw(shapes()), draw(shapes())
    ra, rb = max(sa[:2]), max(sb[:2])
    bearing = draw(st.floats(0.0, 2.0 * math.pi))
    gap = draw(st.floats(-0.8, 0.0)) * min(ra, rb) if overlap else draw(st.floats(0.01, 1.0))
    d = ra + rb + gap
    a = ellipse(d * math.cos(bearing), 1.0 + d * math.sin(bearing), *sa)
    b = ellipse(0.0, 1.0, *sb)
    return a, b


def far_from_thresholds(rel: Relation, eps: float = 1e-6) -> bool:
    """True unless a degree sits on a threshold (where rounding may tip either way)."""
    t = Thresholds()
    cuts = [
        t.directly,
        t.plain,
        t.mostly,
        t.compound_min,
        t.secondary_min,
        t.somewhat,
        t.fits,
        t.fits_partly,
    ]
    a = sorted(rel.degrees.values())
    gaps = [abs(x - c) for x in a for c in cuts]
    diffs = [abs(abs(x - y) - t.compound_gap) for x in a for y in a] + [
        abs(x - y) for x, y in itertools.pairwise(a) if y > 0.05
    ]
    share = abs(rel.extends_share - t.extends_share) if rel.extends_share else 1.0
    dev = abs(abs(math.degrees(rel.deviation)) - t.extends_deviation_deg)
    return min(gaps + diffs + [share, dev, abs(rel.deviation)]) > eps


def words(rel: Relation, table: dict[str, str]) -> tuple[object, ...]:
    def m(x: str | None) -> str | None:
        return table.get(x, x) if x is not None else None

    pair = {m(rel.primary), m(rel.secondary)} if rel.kind == "compound" else None
    if pair is not None:
        return (rel.kind, frozenset(pair), rel.hedge, rel.secondary_hedge)
    return (rel.kind, m(rel.primary), m(rel.secondary), rel.hedge, rel.secondary_hedge)


def plain(rel: Relation) -> tuple[object, ...]:
    if rel.kind == "compound":
        return (rel.kind, frozenset((rel.primary, rel.secondary)), rel.hedge, None)
    return (rel.kind, rel.primary, rel.secondary, rel.hedge, rel.secondary_hedge)


@given(layouts())
def test_mirroring_swaps_left_and_right(lay: tuple[np.ndarray, np.ndarray]) -> None:
    a, b = lay
    rel = relate(a, b, argument="hat", referent="mug")
    assume(far_from_thresholds(rel))
    flip = np.array([-1.0, 1.0])
    mir = relate(a * flip, b * flip, argument="hat", referent="mug")
    assert plain(mir) == words(rel, MIRROR)
    swapped = {MIRROR[d]: v for d, v in rel.degrees.items()}
    assert all(abs(mir.degrees[d] - swapped[d]) < 1e-6 for d in DIRECTIONS)
    if rel.kind == "direction" and rel.primary in ("left", "right"):
        other = "right" if rel.primary == "left" else "left"
        assert rel.sentence.replace(f"the {rel.primary}", f"the {other}") == mir.sentence


@given(layouts())
def test_swapping_argument_and_referent_gives_the_opposite(
    lay: tuple[np.ndarray, np.ndarray],
) -> None:
    a, b = lay
    rel = relate(a, b, argument="hat", referent="mug")
    assume(far_from_thresholds(rel))
    back = relate(b, a, argument="mug", referent="hat")
    assert back.primary == OPPOSITE[rel.primary]
    assert plain(back) == words(rel, OPPOSITE)


@given(layouts(overlap=True))
def test_swapping_overlapping_objects(lay: tuple[np.ndarray, np.ndarray]) -> None:
    a, b = lay
    rel = relate(a, b)
    assume(far_from_thresholds(rel))
    back = relate(b, a)
    if rel.primary == "surrounded":
        assert back.primary == "surrounded"
        converse = {"surrounded": "surrounds", "partly surrounded": "partly surrounds"}
        converse |= {v: k for k, v in converse.items()}
        # Equal areas make "surrounded by" both ways; otherwise exactly one encloses.
        assert back.kind in (rel.kind, converse[rel.kind])
    else:
        assert back.primary == OPPOSITE[rel.primary]


@given(layouts(), st.integers(1, 3))
def test_rotating_a_clear_layout_moves_the_primary_by_one_step(
    lay: tuple[np.ndarray, np.ndarray], quarter_turns: int
) -> None:
    a, b = lay
    rel = relate(a, b)
    assume(rel.kind == "direction" and rel.degrees[rel.primary] >= 0.6)
    assume(far_from_thresholds(rel))
    rot = np.array([[0.0, -1.0], [1.0, 0.0]])  # +90°
    ra, rb = a.copy(), b.copy()
    expected = rel.primary
    for _ in range(quarter_turns):
        ra, rb = ra @ rot.T, rb @ rot.T
        expected = ROTATE[expected]
    turned = relate(ra, rb)
    assert turned.primary == expected
    table = dict(ROTATE)
    for _ in range(quarter_turns - 1):
        table = {k: ROTATE[v] for k, v in table.items()}
    assert plain(turned) == words(rel, table)


@given(layouts(), st.floats(0.2, 5.0), st.floats(-3.0, 3.0), st.floats(-3.0, 3.0))
def test_scaling_and_translation_change_nothing(
    lay: tuple[np.ndarray, np.ndarray], k: float, dx: float, dy: float
) -> None:
    a, b = lay
    rel = relate(a, b)
    assume(far_from_thresholds(rel))
    moved = relate(a * k + [dx, dy], b * k + [dx, dy])
    assert plain(moved) == plain(rel)
    assert moved.sentence == rel.sentence


@given(
    st.sampled_from([72, 180, 360]),
    st.integers(0, 3),
    st.floats(0.0, 90.0),
    st.sampled_from([1, -1]),
)
def test_single_spike_degree(n: int, k: int, delta: float, sign: int) -> None:
    step = 360.0 / n
    offset = round(delta / step)  # a spike sits on a bin
    h = np.zeros(n)
    h[(k * n // 4 + sign * offset) % n] = 2.5
    d = four_degrees(h)[DIRECTIONS[k]]
    assert abs(d.degree - (1.0 - offset * step / 90.0)) <= 0.02


@given(
    st.lists(st.floats(0.0, 10.0), min_size=180, max_size=180),
    st.lists(st.floats(0.0, 10.0), min_size=180, max_size=180),
)
def test_any_histograms_give_a_valid_relation(f0: list[float], f2: list[float]) -> None:
    # (all zero is refused: nothing is ever described from no force; tests/fuzz checks it)
    assume(max(f0) > 1e-290 and max(f2) > 1e-290)
    rel = describe_relation(np.array(f0), np.array(f2), argument="hat", referent="can")
    assert rel.primary in (*DIRECTIONS, "surrounded")
    assert rel.secondary in (*DIRECTIONS, None)
    assert 0.0 <= rel.confidence <= 1.0
    assert all(0.0 <= v <= 1.0 for v in rel.degrees.values())
    assert rel.sentence.startswith("The hat ") and rel.sentence.endswith(".")
    assert "  " not in rel.sentence
    if rel.secondary is not None:
        assert rel.hedge != "directly"  # never "directly ... but slightly"
    assert astuple(rel)  # frozen dataclass round-trips
