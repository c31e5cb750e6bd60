"""The frozen mask set of issue 16 (tools/mask_set.py): pinned, disjoint, subset-stable."""

from __future__ import annotations

import numpy as np

from scenespeak.tools.mask_set import (
    KINDS,
    TUNING_SEED,
    VALIDATION_SEED,
    digest,
    mask_pairs,
)

#: sha256 of the 64² and 128² pairs of each seed: the set the rule was chosen on and the one
#: it is reported on must not drift (docs/forces.md quotes the whole-set digests).
PINNED = {
    TUNING_SEED: "fc9181c9ad05f733b897f1f1386a999b5d99e60c8b2ebfcd025ca39a181fef78",
    VALIDATION_SEED: "2e236a5bb5a73456cf15223cf0ae085a591b78196e281f127c251fec9a7275da",
}


def test_the_set_is_frozen_and_subsets_hold_the_same_pairs() -> None:
    for seed, expected in PINNED.items():
        small = mask_pairs(seed, sizes=(64, 128))
        assert digest(small) == expected
        assert digest(mask_pairs(seed, sizes=(128,))) == digest(small[len(KINDS) * 3 :])


def test_pairs_are_disjoint_and_keep_their_polygons() -> None:
    from scipy import ndimage

    pairs = mask_pairs(TUNING_SEED, sizes=(64, 128))
    assert [p.kind for p in pairs[:12]] == [k for k in KINDS for _ in range(3)]
    for p in pairs:
        # not even 8-neighbours: F2 is defined for every pair
        assert not (ndimage.binary_dilation(p.a, np.ones((3, 3), bool)) & p.b).any()
        assert p.gap >= 1.5
        assert (p.polygon_a is None) == (p.kind == "field")
    tuning = {digest([p]) for p in pairs}
    validation = {digest([p]) for p in mask_pairs(VALIDATION_SEED, sizes=(64, 128))}
    assert not tuning & validation
