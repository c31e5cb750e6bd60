"""The stereo stage's options: sparse matching, dense SGBM, and the one call on a pair.

Each function of the stage takes its options object (``options=``) and still accepts the old
single keywords, which replace the object's fields (``match_stereo(fl, fr, rect, ratio=0.7)``
is ``match_stereo(fl, fr, rect, options=MatchOptions(ratio=0.7))``); an unknown keyword is
refused naming the fields. The defaults are those of a plain call on a pair; the pipeline's
stereo stage sets its own (:class:`scenespeak.perception.stage_options.StereoOptions`: the
cropped dense map with :data:`~scenespeak.perception.stage_options.DENSE_MARGIN` = 16 px).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal, TypeVar

from scenespeak.overrides import replace_fields

__all__ = ["PLAIN_DENSE_MARGIN", "DenseOptions", "MatchOptions", "PointsOptions"]

#: ``dense_margin`` of a plain :func:`~scenespeak.perception.stereo.stereo_points` call with
#: ``dense_crop=True``. It is not the pipeline's 16 px (``stage_options.DENSE_MARGIN``) on
#: purpose: plain calls with ``dense_crop=True`` and no margin exist (``bench_stereo.py``, whose
#: figures ``docs/calibration.md`` publishes, and ``tests/perception/test_stereo.py``), so a
#: change would change their maps and matches. Every pipeline caller sets its margin.
PLAIN_DENSE_MARGIN = 5

_O = TypeVar("_O", "MatchOptions", "DenseOptions", "PointsOptions")


def _with_overrides(cls: type[_O], options: _O | None, overrides: Mapping[str, object]) -> _O:
    """``options`` (or the defaults) with single fields replaced (unknown names refused)."""
    return replace_fields(
        options if options is not None else cls(),
        overrides,
        lambda bad, names: TypeError(
            f"unknown {cls.__name__} keywords {bad}; the fields are {names}"
        ),
    )


@dataclass(frozen=True)
class MatchOptions:
    """Knobs of :func:`~scenespeak.perception.stereo.match_stereo`.

    Attributes
    ----------
    ratio : float
        0.6 — Lowe's ratio test: best distance < ``ratio`` × second best (the seed paper's
        value). Keypoints at the same place as the best (OpenCV's duplicates with another
        orientation) are not taken as the second best.
    band_px : float
        1.5 — epipolar band: largest row difference in rectified pixels.
    min_disparity, max_disparity : float, float or None
        0.0, None — accepted range of the depth-giving disparity ``x_l − x_r + doffs``
        (> min, <= max; None: no upper bound).
    mutual : bool
        True — cross check: the right keypoint's best left keypoint must be the same one.
    search : {"auto", "global", "band"}
        ``"global"``: the paper's test, best and second best over all right keypoints, then the
        band. ``"band"``: best and second best inside the band. ``"auto"``: band when a dense
        map is given (the dense check removes what the weaker test lets through), else global.
    band_ratio : float
        0.8 — the ratio used by the band search (its second best is nearer than a global one,
        so the same value would be stricter).
    dense_tol_px : float
        0.75 — with a dense map: the dense disparity at the left keypoint must agree within
        this many pixels.
    edge_px, edge_window : float, int
        1.0, 5 — with a dense map: it may vary by at most ``edge_px`` in the ``edge_window`` ×
        ``edge_window`` pixels around the keypoint (no depth edge, no hole).

    Examples
    --------
    >>> MatchOptions.with_overrides(None, {"ratio": 0.7}).ratio
    0.7
    """

    ratio: float = 0.6
    band_px: float = 1.5
    min_disparity: float = 0.0
    max_disparity: float | None = None
    mutual: bool = True
    search: Literal["auto", "global", "band"] = "auto"
    band_ratio: float = 0.8
    dense_tol_px: float = 0.75
    edge_px: float = 1.0
    edge_window: int = 5

    @classmethod
    def with_overrides(
        cls, options: MatchOptions | None, overrides: Mapping[str, object]
    ) -> MatchOptions:
        """``options`` (or the defaults) with single fields replaced (unknown names refused)."""
        return _with_overrides(cls, options, overrides)


@dataclass(frozen=True)
class DenseOptions:
    """Knobs of :func:`~scenespeak.perception.stereo.dense_disparity` (OpenCV StereoSGBM).

    Attributes
    ----------
    min_disparity, num_disparities : int or None
        None — search range; by default derived from the keypoint disparities (the range of
        the values shared by at least 3 of them within 2 px, ± 8 px, at most half the image
        width) or, without them, from 0.3 m to infinity.
    block_size : int
        3 — SGBM block size (odd).
    uniqueness : int
        10 — SGBM's uniquenessRatio (percent margin of the best cost over the second best).
    pad : int or None
        None — with a region: pixels of context computed around it (and then dropped), so that
        SGBM's path costs have settled at the region's border (None: ``block_size // 2 + 2``).

    Examples
    --------
    >>> DenseOptions.with_overrides(None, {"pad": 16}).pad
    16
    """

    min_disparity: int | None = None
    num_disparities: int | None = None
    block_size: int = 3
    uniqueness: int = 10
    pad: int | None = None

    @classmethod
    def with_overrides(
        cls, options: DenseOptions | None, overrides: Mapping[str, object]
    ) -> DenseOptions:
        """``options`` (or the defaults) with single fields replaced (unknown names refused)."""
        return _with_overrides(cls, options, overrides)


@dataclass(frozen=True)
class PointsOptions:
    """Knobs of :func:`~scenespeak.perception.stereo.stereo_points` (a plain call on a pair).

    Attributes
    ----------
    ratio, band_px, band_ratio : float
        0.6, 1.5, 0.8 — see :class:`MatchOptions`.
    verify : bool
        True — use the dense check (more and more accurate matches; also gives ``dense`` for
        ``region_points``). Without it, the paper's matching with a cross check.
    min_points : int
        0 — raise :class:`~scenespeak.errors.ImageError` when fewer points are found (0: return
        an empty result instead; a textureless pair gives no points).
    dense_crop : bool
        False — compute the dense map (``verify``) only over the bounding box of the keypoints
        it has to check (plus ``dense_roi``) instead of the whole image: the same checks for a
        fraction of the cost when the scene does not fill the image (about 2.5× faster on the
        rendered table scenes); elsewhere the map is NaN. The pipeline sets True.
    dense_roi : (x0, y0, x1, y1) or None
        None — with ``dense_crop``, a region of the INPUT left image (pixels) the dense map must
        also cover, e.g. the recognised objects' outlines (of this pair).
    dense_margin : int
        :data:`PLAIN_DENSE_MARGIN` (5) — with ``dense_crop``, pixels added around the
        keypoints' bounding box (and the region); the pipeline sets 16.
    left_name, right_name : str
        "left image", "right image" — names (file names) used in error messages.

    Examples
    --------
    >>> PointsOptions.with_overrides(None, {"dense_crop": True}).dense_margin
    5
    """

    ratio: float = 0.6
    band_px: float = 1.5
    band_ratio: float = 0.8
    verify: bool = True
    min_points: int = 0
    dense_crop: bool = False
    dense_roi: tuple[float, float, float, float] | None = None
    dense_margin: int = PLAIN_DENSE_MARGIN
    left_name: str = "left image"
    right_name: str = "right image"

    @classmethod
    def with_overrides(
        cls, options: PointsOptions | None, overrides: Mapping[str, object]
    ) -> PointsOptions:
        """``options`` (or the defaults) with single fields replaced (unknown names refused)."""
        return _with_overrides(cls, options, overrides)
