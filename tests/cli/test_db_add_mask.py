"""`scenespeak db add` without `--mask` learns the object on its plain background, as
`scenespeak evaluate` does (issue 10: "the object in its training views when no mask is
given"): the view's outline is the object's, not the whole photo; a close-up with no background
to find keeps the whole photo."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from scenespeak.cli import main
from scenespeak.perception.recognition import ObjectDatabase


def _photo(path: Path, *, plain: bool) -> Path:
    rng = np.random.default_rng(3)
    texture = cv2.GaussianBlur(rng.integers(0, 255, (240, 320, 3)).astype(np.uint8), (0, 0), 1.5)
    img = np.full((240, 320, 3), 170, np.uint8) if plain else texture.copy()
    if plain:
        img[60:180, 100:220] = texture[60:180, 100:220]  # the object, on a grey table
    cv2.imwrite(str(path), img)
    return path


def test_db_add_without_a_mask_learns_the_object_not_the_photo(tmp_path: Path) -> None:
    db = tmp_path / "objects.db"
    on_table = _photo(tmp_path / "tin.png", plain=True)
    close_up = _photo(tmp_path / "poster.png", plain=False)
    for label, path in (("tin", on_table), ("poster", close_up)):
        assert main(["db", "add", "--db", str(db), "--label", label, str(path)]) == 0
    with ObjectDatabase.open(db, readonly=True) as database:
        (tin,) = database.views("tin")
        (poster,) = database.views("poster")
    assert tin.has_mask
    lo, hi = tin.outline.min(axis=0), tin.outline.max(axis=0)
    assert np.all(lo >= [90, 50]) and np.all(hi <= [230, 190]), (lo, hi)  # the object's box
    assert not poster.has_mask  # nothing plain round it: the whole photo stays the view
