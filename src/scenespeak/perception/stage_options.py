"""The stereo stage's options as the pipeline runs it (the one owner of their defaults).

:func:`scenespeak.perception.stereo.stereo_points` keeps its own defaults for a plain call on a
pair (:class:`scenespeak.perception.stereo.PointsOptions`: ``dense_crop=False``, the dense map
over the whole image, so ``dense_margin`` is not used; with ``dense_crop=True`` and no margin,
:data:`~scenespeak.perception.stereo.PLAIN_DENSE_MARGIN` = 5 px, kept because plain callers of
that form exist and their maps would change); every caller that runs the *pipeline's* stereo
stage (``describe``, ``points``, the tracker's keyframes) takes :class:`StereoOptions` from
here, so the cropped map and its margin have one default, :data:`DENSE_MARGIN`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypedDict

__all__ = ["DENSE_MARGIN", "StereoOptions"]

#: Pixels around the stereo matches' bounding box that the cropped dense map also covers. A
#: recognised outline reaches beyond the matches' box only by a few textureless pixels, where
#: SGBM finds little anyway; 16 px is the margin the pipeline's figures were measured with
#: (``docs/calibration.md``, "the matches' bounding box plus 16 px").
DENSE_MARGIN = 16


class StereoKeywords(TypedDict):
    """The keywords :meth:`StereoOptions.keywords` hands to ``stereo_points``."""

    ratio: float
    dense_crop: bool
    dense_margin: int


@dataclass(frozen=True)
class StereoOptions:
    """Knobs of the pipeline's stereo stage (``stereo.stereo_points``).

    Attributes
    ----------
    ratio : float
        0.6 — Lowe's ratio for left/right matching (the seed paper's value).
    dense_crop : bool
        True — compute the dense map only over the bounding box of the stereo matches it
        verifies, plus ``dense_margin`` pixels, not the whole image (about 2.5× faster on the
        rendered table scenes; the map does not wait for the labels, so it is computed while
        the objects are recognised).
    dense_margin : int
        :data:`DENSE_MARGIN` — pixels around the matches' box for ``dense_crop``.
    check_order : bool
        False — first refuse a pair that is swapped, unrelated or not fitted by the calibration
        (:func:`scenespeak.perception.plausibility.check_pair_order`) on the stage's own SIFT
        features, so that the check costs no SIFT of its own (``scenespeak describe`` sets it).
        Not one of :meth:`keywords`: the check runs before ``stereo_points``.

    Examples
    --------
    >>> StereoOptions().keywords()
    {'ratio': 0.6, 'dense_crop': True, 'dense_margin': 16}
    """

    ratio: float = 0.6
    dense_crop: bool = True
    dense_margin: int = DENSE_MARGIN
    check_order: bool = False

    def keywords(self) -> StereoKeywords:
        """The keywords of ``stereo_points`` these options set."""
        return {
            "ratio": self.ratio,
            "dense_crop": self.dense_crop,
            "dense_margin": self.dense_margin,
        }
