"""Views of a cylinder from higher up, synthesised at ``db add`` (recognition/cylinder_views.py).

On by default since session 10 (``add_object(..., raise_cylinders=False)`` turns them off),
measured on the cylinder stress set of docs/evaluation.md ("Session 10"). The training views
are rendered by the generator (its can, mug and book, five yaws, with masks).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scenespeak.perception.features import detect, load_image
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.recognition.cylinder_views import cylinder_of, elevated_views

pytestmark = pytest.mark.slow  # renders ten training views (~5 s idle)

YAWS = (0.0, 72.0, 144.0, -144.0, -72.0)


def _views(tmp_path: Path, label: str) -> tuple[list[Path], list[np.ndarray]]:
    scenes = pytest.importorskip("scenespeak.tools.scenes")
    from scenespeak.tools.scene_model import CATALOGUE

    obj = {o.label: o for o in CATALOGUE}[label]
    paths = scenes.render_training_views(obj, tmp_path / label, yaws=YAWS, masks=True)
    masks = [load_image(p.with_name(p.stem + "_mask.png"), gray=True) > 0 for p in paths]
    return paths, masks


def test_a_cylinder_is_seen_from_higher_up_and_a_box_is_not(tmp_path: Path) -> None:
    cans, can_masks = _views(tmp_path, "can")
    books, book_masks = _views(tmp_path, "book")
    cyls = [cylinder_of(m) for m in can_masks]
    assert all(c is not None for c in cyls)
    widths = [c.r for c in cyls if c is not None]
    assert max(widths) / min(widths) < 1.05  # the same silhouette from every side
    grays = [load_image(p, gray=True) for p in cans]
    raised = elevated_views(grays, can_masks)
    assert sorted({d for _, d, _, _ in raised}) == [18.0, 32.0] and len(raised) == 10
    # seen from higher up, the rims bulge more and the body is shorter
    i, _d, _view, mask = min(raised, key=lambda r: r[1])  # 18 degrees higher
    before, after = cyls[i], cylinder_of(mask)
    assert before is not None and after is not None
    assert after.sin_bottom > before.sin_bottom + 0.2
    assert after.bottom - after.top < before.bottom - before.top
    # a box's faces have straight bottom edges, and its width changes with the side it shows
    assert elevated_views([load_image(p, gray=True) for p in books], book_masks) == []
    with ObjectDatabase.create(tmp_path / "objects.db") as db:
        plain = db.add_object("can", cans, masks=can_masks, raise_cylinders=False)
        more = db.add_object("can 2", cans, masks=can_masks)
        book = db.add_object("book", books, masks=book_masks)
    assert (plain.views, more.views, book.views) == (5, 15, 5)


def _seen_from_above(tmp_path: Path, label: str, elevation: float) -> np.ndarray:
    """The generator's ``label`` 0.6 m away, seen from ``elevation`` degrees above (a rig
    0.3-0.45 m above the support sees near objects so), at a yaw between the training views."""
    scenes = pytest.importorskip("scenespeak.tools.scenes")
    from scenespeak.tools.scene_model import CATALOGUE, Placement, Rig

    obj = {o.label: o for o in CATALOGUE}[label]
    d = 0.6
    rig = Rig(elevation, obj.size[2] / 2 + d * np.tan(np.radians(elevation)), 0.0, 60.0, (640, 480))
    placed = Placement(obj, (0.0, d, 0.0), 36.0)
    ((img, _seg),) = scenes.render([placed.mesh()], [rig.camera()], scenes.SUPERSAMPLE)
    return np.asarray(img)


def test_a_mug_seen_from_above_is_found_by_default(tmp_path: Path) -> None:
    # Issue 10: squat cylinders seen from 25-45 degrees above matched views from 17 degrees
    # too little. The mug 40 degrees below the camera: the learnt views alone give no
    # detection (11 ratio-test matches, session 10), the views from higher up one (29). The
    # synthesised views' descriptors are told apart in the ratio test (label._test) and vote
    # for the learnt view they come from (loading.synthetic_of).
    mugs, mug_masks = _views(tmp_path, "mug")
    books, book_masks = _views(tmp_path, "book")
    query = detect(_seen_from_above(tmp_path, "mug", 40.0))
    with ObjectDatabase.create(tmp_path / "objects.db") as db:
        db.add_object("book", books, masks=book_masks)
        db.add_object("mug", mugs, masks=mug_masks, raise_cylinders=False)
        plain = db.label(query)
        db.add_object("mug", mugs, masks=mug_masks, replace=True)
        found = db.label(query)
    assert [d.label for d in found.detections] == ["mug"]
    assert int((found.matched >= 0).sum()) > 1.5 * int((plain.matched >= 0).sum())
