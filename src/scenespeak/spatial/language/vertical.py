"""The vertical plane: "on top of", "above", "below", "under" from the points' heights."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError
from scenespeak.spatial.language.thresholds import DEFAULT_THRESHOLDS, Thresholds

__all__ = ["vertical_relation"]


def _heights(h: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(h, dtype=np.float64).ravel()
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"must be a 1-D array of heights in metres ({exc})") from None
    if a.size == 0:
        raise InputError(name, "is empty; give the heights of the object's points along up")
    if not np.all(np.isfinite(a)):
        raise InputError(name, "has non-finite heights (NaN or inf)")
    return a


def vertical_relation(
    a_heights: ArrayLike,
    b_heights: ArrayLike,
    *,
    horizontal_overlap: float,
    thresholds: Thresholds | None = None,
) -> str | None:
    """The vertical relation of A to B: "on top of", "above", "under", "below" or None.

    The rule: each object's vertical extent is the 5th–95th percentile of its points' heights
    along up (robust to a stray keypoint). With ``gap = bottom(A) − top(B)`` and the contact
    tolerance ``tol = max(contact_tolerance, contact_fraction · thinner object's extent)``:

    - no vertical relation when the footprints overlap by less than ``vertical_overlap`` of
      the smaller one (side by side: the horizontal words say it);
    - A "on top of" B when ``|gap| <= tol`` and A's median height is above B's; "above" when
      ``gap > tol``;
    - symmetrically "under" (B on top of A) and "below";
    - None when the extents overlap by more than ``tol`` (e.g. the mug inside a can).

    Parameters
    ----------
    a_heights, b_heights : array_like
        Heights (metres, larger = higher) of the objects' points along up.
    horizontal_overlap : float
        area(A ∩ B) / min(area(A), area(B)) of the footprints on the horizontal plane.
    thresholds : Thresholds, optional

    Examples
    --------
    >>> mug = np.linspace(0.12, 0.22, 20)           # a mug standing on a 12 cm can
    >>> can = np.linspace(0.0, 0.12, 30)
    >>> vertical_relation(mug, can, horizontal_overlap=1.0)
    'on top of'
    >>> vertical_relation(can, mug, horizontal_overlap=1.0)
    'under'
    >>> vertical_relation(mug + 0.3, can, horizontal_overlap=1.0)
    'above'
    >>> vertical_relation(mug, can, horizontal_overlap=0.0) is None
    True
    """
    t = thresholds or DEFAULT_THRESHOLDS
    a = _heights(a_heights, "a_heights")
    b = _heights(b_heights, "b_heights")
    if not math.isfinite(horizontal_overlap) or horizontal_overlap < 0:
        raise InputError("horizontal_overlap", f"must be a fraction >= 0, got {horizontal_overlap}")
    if horizontal_overlap < t.vertical_overlap:
        return None
    return _vertical_rule(_extent(a), _extent(b), t)


def _extent(h: NDArray[np.float64]) -> tuple[float, float, float]:
    """An object's vertical extent for :func:`vertical_relation`: the 5th and 95th percentiles
    and the median of its points' heights."""
    lo, hi = np.percentile(h, [5.0, 95.0])
    return float(lo), float(hi), float(np.median(h))


def _vertical_rule(
    a: tuple[float, float, float], b: tuple[float, float, float], t: Thresholds
) -> str | None:
    """The rule of :func:`vertical_relation` on two :func:`_extent` (footprints overlapping)."""
    a_lo, a_hi, a_mid = a
    b_lo, b_hi, b_mid = b
    tol = max(t.contact_tolerance, t.contact_fraction * min(a_hi - a_lo, b_hi - b_lo))
    gap_ab = a_lo - b_hi
    gap_ba = b_lo - a_hi
    if a_mid > b_mid and gap_ab >= -tol:
        return "on top of" if gap_ab <= tol else "above"
    if b_mid > a_mid and gap_ba >= -tol:
        return "under" if gap_ba <= tol else "below"
    return None
