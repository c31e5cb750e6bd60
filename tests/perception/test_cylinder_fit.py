"""Which training views of a cylinder are raised (recognition/cylinder_views.py): fast, on
drawn silhouettes.

An automatic mask often leaves part of a plain top face out (the generator's soup and cup on
the cylinder stress set: 2 of 5 views each had a flat, ragged top edge and were not raised,
session 10). The bottom rim and the width still say "cylinder"; the top rim's elevation is the
object's other views'.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scenespeak.perception.recognition.cylinder_views import cylinder_of, elevated_views


def _silhouette(top_cut: int | None = None) -> NDArray[np.bool_]:
    """A cylinder 81 px wide seen from above: top rim bulge 6 px, bottom 12 px; with
    ``top_cut``, every row above it left out (a flat top edge)."""
    m = np.zeros((200, 200), bool)
    u = np.arange(60, 141)
    cos = np.sqrt(1 - ((u - 100) / 40.5) ** 2)
    for x, k in zip(u, cos, strict=True):
        m[int(np.rint(50 - 6 * k)) : int(np.rint(150 + 12 * k)) + 1, x] = True
    if top_cut is not None:
        m[:top_cut] = False
    return m


def test_views_with_the_top_face_left_out_are_raised_too() -> None:
    masks = [_silhouette(), _silhouette(), _silhouette(), _silhouette(56), _silhouette(58)]
    assert [cylinder_of(m) is not None for m in masks] == [True, True, True, False, False]
    images = [np.full((200, 200), 120, np.uint8) for _ in masks]
    raised = elevated_views(images, masks)
    assert sorted({i for i, _, _, _ in raised}) == [0, 1, 2, 3, 4]


def test_a_box_is_still_no_cylinder() -> None:
    box = np.zeros((200, 200), bool)
    box[50:150, 60:141] = True
    images = [np.full((200, 200), 120, np.uint8)] * 5
    assert elevated_views(images, [box] * 5) == []
    assert elevated_views(images, [_silhouette(), _silhouette(), box, box, box]) == []
