"""Is this calibration, and this scene, plausible? Refusals with the reason and the fix.

A calibration can be valid (finite, a rotation, a non-zero baseline) and still wrong in the ways
people actually get wrong:

* **millimetres** — OpenCV's stereo_calib sample and most chessboard tutorials measure the
  board in millimetres, so ``T = [-193, 0, 0]`` means 19.3 cm; read as metres every depth is
  1000× too far. A baseline over :attr:`~scenespeak.limits.Limits.max_baseline_m` is refused
  with "looks like millimetres: pass --units mm" (:func:`with_units` converts);
* **left and right swapped** — ``T[0] > 0`` says the right camera is to the left of the left
  one (:func:`check_rig`); swapped images show as most matches having a negative disparity
  (:func:`check_pair_order`);
* **a scene that cannot be** — a median depth of hundreds of metres or a median disparity under
  a pixel (:func:`check_depths`), what a wrong unit or a swapped pair gives on a table scene.

Each check raises :class:`~scenespeak.errors.CalibrationError` naming the calibration file; the
bounds are in :mod:`scenespeak.limits` and can be raised there (``--limit``).

>>> from dataclasses import dataclass, replace
>>> from scenespeak.perception.calibration import rig_from_short
>>> rig = replace(rig_from_short(0.12, 60.0, (640, 480), source="calib.json"), T=[-120.0, 0, 0])
>>> check_rig(rig)  # a file's T = [-120, 0, 0]
... # doctest: +ELLIPSIS
Traceback (most recent call last):
...
scenespeak.errors.CalibrationError: calib.json: ... looks like millimetres: pass --units mm ...
>>> round(with_units(rig, "mm").baseline, 3)
0.12
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak import limits as _limits
from scenespeak.errors import CalibrationError, ImageError, InputError
from scenespeak.perception.calibration import Rectification, StereoRig, rectify

if TYPE_CHECKING:  # features imports OpenCV; the checks of a rig alone do not need it
    from scenespeak.perception.features import Features

__all__ = [
    "CHECK_FEATURES",
    "UNITS",
    "check_depths",
    "check_pair_order",
    "check_rig",
    "pitch_up",
    "swapped",
    "with_units",
]

Units = Literal["m", "cm", "mm"]
#: Length units a calibration's translations may be written in, and their size in metres.
UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: :func:`check_pair_order` matches the strongest this many SIFT features of each image.
CHECK_FEATURES = 1500


def with_units(rig: StereoRig, units: str) -> StereoRig:
    """The rig with ``T`` converted from ``units`` to metres (``"m"``: unchanged).

    Raises
    ------
    InputError
        An unknown unit (``--units`` names m, cm or mm).
    """
    key = units.strip().lower() if isinstance(units, str) else units
    if key not in UNITS:
        raise InputError("--units", f"unknown unit {units!r}; use one of m, cm, mm")
    if key == "m":
        return rig
    return replace(rig, T=np.asarray(rig.T) * UNITS[key])


def swapped(rig: StereoRig) -> StereoRig:
    """The rig with its cameras exchanged (the right camera becomes the left one).

    For a calibration whose "left" camera is physically on the right (``T[0] > 0``, e.g. a
    stereo_calib run with the image names swapped): ``K``, ``dist`` exchanged,
    ``R' = Rᵀ``, ``T' = −Rᵀ T``; give the images in the other order too (the CLI's ``--swap``
    does both). ``up`` is turned into the new left camera's frame.

    >>> from scenespeak.perception.calibration import rig_from_short
    >>> (swapped(rig_from_short(0.12, 60.0, (640, 480))).T + 0.0).tolist()  # + 0.0: no -0.0
    [0.12, 0.0, 0.0]
    """
    R = np.asarray(rig.R)
    T = np.asarray(rig.T)
    return replace(
        rig,
        K_left=rig.K_right,
        K_right=rig.K_left,
        dist_left=rig.dist_right,
        dist_right=rig.dist_left,
        R=R.T,
        T=-R.T @ T,
        up=R @ np.asarray(rig.up),
    )


def pitch_up(pitch_deg: float) -> NDArray[np.float64]:
    """World up in the left camera's frame for a rig pitched ``pitch_deg`` down (0 = level).

    The camera's Y axis points down and Z forward; pitched down by ``a``, the world's up is
    ``(0, -cos a, -sin a)`` (the scene generator's convention, ``tools/scenes.py``).

    >>> pitch_up(0.0).tolist()
    [0.0, -1.0, -0.0]
    """
    try:
        a = float(pitch_deg)
    except (TypeError, ValueError):
        raise InputError("--pitch", f"must be a number of degrees, got {pitch_deg!r}") from None
    if not math.isfinite(a) or not -90.0 < a < 90.0:
        raise InputError("--pitch", f"must be between -90 and 90 degrees (down), got {a}")
    r = math.radians(a)
    return np.array([0.0, -math.cos(r), -math.sin(r)])


def check_rig(rig: StereoRig) -> StereoRig:
    """Refuse a rig whose baseline or camera order cannot be right; return it otherwise.

    Raises
    ------
    CalibrationError
        A baseline over ``max_baseline_m`` (named as millimetres or centimetres when it looks
        like them) or under ``min_baseline_m``; a right camera to the left of the left one.
    """
    lim = _limits.current()
    b = rig.baseline
    src = rig.source
    if b > lim.max_baseline_m:
        unit = "millimetres: pass --units mm" if b >= 20 else "centimetres: pass --units cm"
        raise CalibrationError(
            src,
            f"the baseline is {b:g} (in the file's units); read as metres that is a {b:g} m "
            f"rig, which looks like {unit} (or write T / baseline in metres); "
            "--limit max_baseline_m=N allows larger rigs",
        )
    if b < lim.min_baseline_m:
        raise CalibrationError(
            src,
            f"the baseline is {b:g} m, under {lim.min_baseline_m:g} m: T must be in metres "
            "(--units mm / cm convert); --limit min_baseline_m=N allows smaller rigs",
        )
    w = rig.image_size[0]
    for name, k in (("K_left", rig.K_left), ("K_right", rig.K_right)):
        fx = float(k[0, 0])
        if not 0.05 * w <= fx <= 100.0 * w:
            hfov = 2 * math.degrees(math.atan(w / (2 * fx)))
            raise CalibrationError(
                src,
                f"{name}: a focal length of {fx:.4g} px for images {w} px wide means a "
                f"{hfov:.3g} degree field of view, which no stereo camera has: check fx "
                "(pixels) and the image size",
            )
    t = np.asarray(rig.T)
    if t[0] > 0 and abs(t[0]) >= 0.5 * b:
        raise CalibrationError(
            src,
            f"T[0] = {t[0]:g} > 0 says the right camera is to the LEFT of the left camera: the "
            "cameras look swapped (images named the wrong way round when calibrating?); pass "
            "--swap to exchange both the images and the calibration's cameras",
        )
    return rig


@dataclass(frozen=True)
class _PairMatches:
    """Mutual ratio-test SIFT matches of a pair, before any stereo constraint."""

    keypoints: tuple[int, int]
    left_xy: NDArray[np.float64]  # raw pixel positions of the matches
    right_xy: NDArray[np.float64]
    left_rect: NDArray[np.float64]  # the same, rectified
    right_rect: NDArray[np.float64]


def _strongest(features: Features, n: int) -> Features:
    """The features whose response is at least the ``n``-th largest (ties kept, as OpenCV's
    ``nfeatures`` keeps them), in their order."""
    if len(features) <= n:
        return features
    cut = np.partition(features.response, len(features) - n)[len(features) - n]
    return features.subset(np.flatnonzero(features.response >= cut))


#: Left descriptors per block of :func:`_ratio_matches`' distance matrix (bounds memory).
_RATIO_BLOCK = 256


def _ratio_matches(
    left: NDArray[np.uint8], right: NDArray[np.uint8], ratio: float
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(left, right) indices of the best right descriptor of each left one whose distance is
    under ``ratio`` times the second best's: the pairs, in left order, of OpenCV's
    ``BFMatcher(NORM_L2).knnMatch(left, right, k=2)`` with ``m[0].distance < ratio *
    m[1].distance``, bit for bit, at about a quarter of its CPU (issue 16).

    Exact because SIFT descriptors are whole numbers in 0..255: every product, partial sum
    and squared distance of ``|l|² + |r|² - 2 l·r`` is a whole number of magnitude below
    2**24, which float32 holds exactly in any summation order (BLAS's blocking and fused
    multiply-adds included), so the squared distances are OpenCV's sums of squared
    differences exactly, and their float32 square roots (correctly rounded) are its
    distances. A tie for the best fails the test either way (``d1 < ratio * d1`` is false),
    so which of two equally near descriptors is "best" never matters.

    >>> d = np.array([[0, 0], [10, 0], [0, 9], [40, 40]], np.uint8)
    >>> [x.tolist() for x in _ratio_matches(d[:1], d, 0.7)]  # itself (0) vs 9: kept
    [[0], [0]]
    >>> [x.tolist() for x in _ratio_matches(d[:1], d[1:], 0.7)]  # 9 vs 10: ambiguous
    [[], []]
    """
    dl = np.asarray(left, np.uint8)
    dr = np.asarray(right, np.uint8)
    nl, nr = len(dl), len(dr)
    if nl == 0 or nr < 2:  # OpenCV gives no second neighbour: no match passes
        z = np.zeros(0, np.intp)
        return z, z.copy()
    norm_l = np.einsum("ij,ij->i", dl, dl, dtype=np.int32).astype(np.float32)
    norm_r = np.einsum("ij,ij->i", dr, dr, dtype=np.int32).astype(np.float32)
    ql = dl.astype(np.float32)
    rt = np.ascontiguousarray(dr.T, dtype=np.float32)
    best = np.empty(nl, np.intp)
    d1 = np.empty(nl, np.float32)
    d2 = np.empty(nl, np.float32)
    for s in range(0, nl, _RATIO_BLOCK):
        sq = ql[s : s + _RATIO_BLOCK] @ rt
        sq *= -2.0
        sq += norm_l[s : s + _RATIO_BLOCK, None]
        sq += norm_r[None, :]
        rows = np.arange(len(sq))
        b = sq.argmin(axis=1)
        best[s : s + len(sq)] = b
        d1[s : s + len(sq)] = sq[rows, b]
        sq[rows, b] = np.inf
        d2[s : s + len(sq)] = sq.min(axis=1)
    ok = np.sqrt(d1).astype(np.float64) < ratio * np.sqrt(d2).astype(np.float64)
    return np.flatnonzero(ok), best[ok]


def _sift_matches(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    rect: Rectification,
    features: tuple[Features, Features] | None = None,
) -> _PairMatches:
    """Ratio-test SIFT matches anywhere in the other image (raw and rectified positions).

    The :data:`CHECK_FEATURES` strongest features of each image: detected here, or taken
    from ``features``.
    """
    from scenespeak.perception.features import detect, to_gray

    if features is None:
        fl = detect(to_gray(left), max_features=CHECK_FEATURES)
        fr = detect(to_gray(right), max_features=CHECK_FEATURES)
    else:
        fl, fr = (_strongest(f, CHECK_FEATURES) for f in features)
    none = np.zeros((0, 2))
    if len(fl) < 8 or len(fr) < 8:
        return _PairMatches((len(fl), len(fr)), none, none, none, none)
    li, ri = _ratio_matches(fl.descriptors, fr.descriptors, 0.7)
    if not len(li):
        return _PairMatches((len(fl), len(fr)), none, none, none, none)
    lxy, rxy = np.asarray(fl.xy[li], np.float64), np.asarray(fr.xy[ri], np.float64)
    with np.errstate(all="ignore"):  # a wild calibration may send points anywhere
        lr = rect.rectify_points(lxy, "left")
        rr = rect.rectify_points(rxy, "right")
    return _PairMatches((len(fl), len(fr)), lxy, rxy, lr, rr)


def _median(values: ArrayLike) -> float:
    """``np.median`` of a non-empty array, the same float (NaN if any value is NaN), without
    ``np.median``'s first call importing ``numpy.ma`` (about 12 ms of a command's start-up,
    issue 16): the middle value, or the two middle ones' sum halved, as ``np.mean`` takes it.

    >>> _median([3.0, 1.0, 2.0]), _median([4.0, 1.0, 2.0, 3.0])
    (2.0, 2.5)
    """
    a = np.asarray(values, dtype=np.float64).ravel()
    n = len(a)
    if np.isnan(a).any():
        return math.nan
    part = np.partition(a, [(n - 1) // 2, n // 2])
    lo, hi = part[(n - 1) // 2], part[n // 2]
    return float(lo) if n % 2 else float((lo + hi) / 2.0)


def _check_same_scene(m: _PairMatches, names: tuple[str, str], source: str) -> None:
    """Refuse two images that are not a stereo pair, or a calibration that does not fit them.

    * both images textured (>= 100 keypoints) but under 8 features match anywhere in the other
      image: not two views of one scene (a wrong file, noise);
    * the matches' raw disparity is zero: both files are the same view (left given twice);
    * many matches, but under 20 % of them within 4 px of the same rectified row: the
      calibration (R, distortion, K) does not fit these images.
    """
    n = len(m.left_xy)
    both = f"{names[0]}, {names[1]}"
    if min(m.keypoints) >= 100 and n < 8:
        raise ImageError(
            both,
            f"the two images do not show the same scene: only {n} of {m.keypoints[0]} and "
            f"{m.keypoints[1]} SIFT features match anywhere in the other image; give the left "
            "and right images of one stereo pair",
        )
    if n < 20:
        return
    shift = np.abs(m.left_xy - m.right_xy).max(axis=1)
    if _median(shift) < 0.5:
        raise ImageError(
            both,
            f"{names[1]} shows the same view as {names[0]} ({n} matches, median shift "
            f"{_median(shift):.2g} px): give the other camera's image as RIGHT",
        )
    dy = np.abs(m.left_rect[:, 1] - m.right_rect[:, 1])
    on_row = float(np.mean(np.isfinite(dy) & (dy <= 4.0)))
    if on_row < 0.2:
        raise CalibrationError(
            source,
            f"{n} SIFT features match between the images, but only {on_row:.0%} of them lie on "
            "the same rectified row: the calibration does not fit these images (check R, the "
            "distortion, K and the image size)",
        )


def check_pair_order(
    left: NDArray[np.generic],
    right: NDArray[np.generic],
    rig: StereoRig,
    *,
    names: tuple[str, str] = ("LEFT", "RIGHT"),
    rect: Rectification | None = None,
    min_matches: int = 20,
    features: tuple[Features, Features] | None = None,
) -> float:
    """Refuse a pair that is not one (see below) or whose matches mostly have negative
    disparity (images swapped).

    Matches are taken without the usual positive-disparity filter (which would hide the
    problem: a swapped pair keeps only its few wrong matches and reports them far away), and
    first without the epipolar band, which tells apart an image that is not the other half of
    the pair (no feature matches anywhere; or the same view twice) from a calibration that does
    not fit the images (features match, but not along rectified rows).

    The check looks at the :data:`CHECK_FEATURES` strongest SIFT features of each image. With
    ``features`` (the images' features, already detected, e.g. by the stereo stage) it takes
    the strongest of those instead of running SIFT twice more: ``scenespeak points`` does, and
    saves about half of its time (issue 16). The matches are OpenCV's brute-force 2-nearest
    ratio-test pairs, computed in NumPy bit for bit (:func:`_ratio_matches`, issue 16
    session 8: 18 -> 5 ms CPU for 1,300 features a side).

    Returns
    -------
    float
        The fraction of matches with a negative depth-giving disparity ``x_l − x_r + doffs``.

    Raises
    ------
    ImageError
        Two textured images with (almost) no feature in common, or the same view twice (the
        message names both images).
    CalibrationError
        More than half of at least ``min_matches`` matches are negative; or the images match
        but not along the calibration's rectified rows.
    """
    size = (rig.image_size[1], rig.image_size[0])
    if np.shape(left)[:2] != size or np.shape(right)[:2] != size:
        return 0.0  # the stereo stage names the image whose size does not fit the calibration
    r = rect if rect is not None else rectify(rig)
    matches = _sift_matches(left, right, r, features)
    _check_same_scene(matches, names, rig.source)
    lxy, rxy = matches.left_rect, matches.right_rect
    band = np.abs(lxy[:, 1] - rxy[:, 1]) <= 1.5
    lxy, rxy = lxy[band], rxy[band]
    if len(lxy) < min_matches:
        return 0.0
    disparity = lxy[:, 0] - rxy[:, 0] + r.doffs
    negative = float(np.mean(disparity < 0))
    if negative > 0.5:
        raise CalibrationError(
            rig.source,
            f"{negative:.0%} of {len(lxy)} stereo matches have a negative disparity: {names[0]} "
            f"and {names[1]} look swapped; give the left camera's image first",
        )
    return negative


def check_depths(
    depths: ArrayLike,
    disparities: ArrayLike,
    source: str,
    *,
    min_points: int = 10,
) -> None:
    """Refuse a scene whose median depth or disparity is implausible for this rig.

    Parameters
    ----------
    depths : array
        Depths (Z in the left camera frame, metres) of the triangulated points.
    disparities : array
        Their depth-giving disparities in pixels.
    source : str
        The calibration file (what is most likely wrong).

    Raises
    ------
    CalibrationError
        Median depth over ``max_scene_depth_m`` or median disparity under
        ``min_median_disparity_px`` (with at least ``min_points`` points).
    """
    z = np.asarray(depths, dtype=np.float64).ravel()
    d = np.asarray(disparities, dtype=np.float64).ravel()
    z = z[np.isfinite(z)]
    d = d[np.isfinite(d)]
    if len(z) < min_points:
        return
    lim = _limits.current()
    mz = _median(z)
    md = _median(d) if len(d) else math.inf
    if mz > lim.max_scene_depth_m or md < lim.min_median_disparity_px:
        raise CalibrationError(
            source,
            f"the scene's median depth is {mz:.4g} m (median disparity {md:.3g} px over "
            f"{len(z)} points), which is not plausible: check that T is in metres (--units mm "
            "for millimetres) and that LEFT and RIGHT are in order; "
            "--limit max_scene_depth_m=N / min_median_disparity_px=N accept such scenes",
        )
