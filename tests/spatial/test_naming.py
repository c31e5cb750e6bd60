"""Instance names: several objects of one label told apart as a person would."""

from __future__ import annotations

import numpy as np
import pytest

from scenespeak.contract import SpatialObject
from scenespeak.spatial.naming import instance_names, name_instances

SQ = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]])


def obj(label: str, x: float, y: float, frame: str = "horizontal", name: str | None = None):
    return SpatialObject(name or label, label, SQ + np.array([x, y]), frame=frame)  # type: ignore[arg-type]


def test_unique_labels_keep_their_names() -> None:
    assert instance_names([obj("mug", 0, 1), obj("can", 1, 1)]) == ["mug", "can"]


def test_two_side_by_side_are_left_and_right() -> None:
    assert instance_names([obj("mug", 0.4, 1), obj("mug", -0.4, 1.1)]) == ["right mug", "left mug"]


def test_one_behind_the_other_is_front_and_back() -> None:
    assert instance_names([obj("mug", 0.0, 2), obj("mug", 0.05, 1)]) == ["back mug", "front mug"]


def test_image_plane_uses_top_and_bottom() -> None:
    names = instance_names([obj("mug", 0, 300, "image"), obj("mug", 10, 100, "image")])
    assert names == ["top mug", "bottom mug"]


def test_three_in_a_row() -> None:
    names = instance_names([obj("mug", 0, 1), obj("mug", -0.5, 1), obj("mug", 0.5, 1.05)])
    assert names == ["middle mug", "left mug", "right mug"]


def test_not_in_a_row_named_by_their_neighbours() -> None:
    # three mugs in an L: no axis orders them cleanly; each has a different nearest object
    mugs = [obj("mug", 0, 1), obj("mug", 0.5, 1), obj("mug", 0.5, 1.5)]
    others = [obj("can", -0.3, 1), obj("hat", 0.9, 0.9), obj("box", 0.5, 2.0)]
    names = instance_names(mugs + others)
    assert names[:3] == ["mug near the can", "mug near the hat", "mug near the box"]
    assert names[3:] == ["can", "hat", "box"]


def test_ordinal_fallback_is_distinct() -> None:
    mugs = [obj("mug", x, 1 + 0.3 * (k % 2)) for k, x in enumerate([0.0, 0.2, 0.4, 0.6])]
    names = instance_names(mugs)
    assert names == [
        "first mug from the left",
        "second mug from the left",
        "third mug from the left",
        "fourth mug from the left",
    ]


def test_already_distinct_names_are_kept() -> None:
    objs = [
        obj("unknown", 0, 1, name="unknown object 1"),
        obj("unknown", 1, 1, name="unknown object 2"),
    ]
    assert instance_names(objs) == ["unknown object 1", "unknown object 2"]


@pytest.mark.parametrize("n", [2, 3, 5, 9, 12])
def test_always_distinct(n: int) -> None:
    rng = np.random.default_rng(n)
    objs = [obj("mug", *rng.uniform(-1, 1, 2)) for _ in range(n)] + [obj("mug", 0, 0)]
    names = instance_names(objs)
    assert len(set(names)) == len(names)


def test_name_instances_keeps_labels() -> None:
    out = name_instances([obj("mug", 0, 1), obj("mug", 1, 1)])
    assert [(o.name, o.label) for o in out] == [("left mug", "mug"), ("right mug", "mug")]
