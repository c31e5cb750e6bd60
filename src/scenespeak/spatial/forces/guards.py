"""Guards of the public force functions against values a caller passes by mistake (issue 12).

Complex, text or ``None`` input, a non-finite or negative ``mask_tolerance``, exponents whose
``d**-r`` cannot be represented, coordinates far from unit size (computed at unit size and
scaled back, ``F_r`` being scale-covariant), and results that are not finite, all zero or
negative beyond rounding are refused with :class:`~scenespeak.errors.InputError`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError

FloatArray = NDArray[np.float64]


def check_directions(directions: object) -> int:
    """A positive number of directions, at most ``max_directions``."""
    from scenespeak import limits

    if isinstance(directions, bool) or not isinstance(directions, int | np.integer):
        raise InputError("directions", f"must be a positive integer, got {directions!r}")
    if directions < 1:
        raise InputError("directions", f"must be a positive integer, got {directions}")
    if directions > limits.current().max_directions:
        raise InputError(
            "directions", limits.exceeded("max_directions", f"{directions} directions", 0)
        )
    return int(directions)


def check_r(r: object) -> float:
    """A real exponent with ``|r| <= 20``."""
    if type(r) is float and -_MAX_R <= r <= _MAX_R:  # the common case, first (NaN fails it)
        return r
    if isinstance(r, bool) or not isinstance(r, int | float | np.integer | np.floating):
        raise InputError("r", f"must be a real number, got {r!r}")
    value = float(r)
    if not math.isfinite(value):
        raise InputError("r", f"must be a finite real number, got {value}")
    if abs(value) > _MAX_R:
        raise InputError(
            "r",
            f"|r| = {abs(value):g} > {_MAX_R:g}: d**-r under/overflows float64 for any real "
            "scene (the paper uses r = 0 and r = 2)",
        )
    return value


def check_tolerance(value: object) -> float | None:
    """``mask_tolerance``: None, or a finite number of pixels in [0, 1e6]."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise InputError("mask_tolerance", f"must be a number of pixels, got {value!r}")
    tol = float(value)
    if not math.isfinite(tol) or tol < 0 or tol > 1e6:
        raise InputError(
            "mask_tolerance", f"must be a finite number of pixels in [0, 1e6], got {tol}"
        )
    return tol


def as_vertices(obj: ArrayLike, name: str) -> NDArray[np.generic]:
    """The raw array of a polygon or mask, refusing what is not real numbers (or bool)."""
    from scenespeak import limits

    try:
        arr = np.asarray(obj)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"cannot be read as vertices or a mask ({exc})") from None
    if obj is None or np.iscomplexobj(arr):
        what = "None" if obj is None else "complex numbers"
        raise InputError(name, f"cannot be read as real (N, 2) vertices or a mask: got {what}")
    if arr.dtype.kind not in "biuf":
        raise InputError(
            name, f"cannot be read as real (N, 2) vertices or a boolean mask: dtype {arr.dtype}"
        )
    if arr.dtype != np.bool_ and arr.ndim == 2 and len(arr) > limits.current().max_vertices:
        raise InputError(name, limits.exceeded("max_vertices", f"{len(arr)} vertices", 0))
    return arr


_MAX_R = 20.0
_SCALE_RANGE = (1e-6, 1e6)


def normalise_pair(
    a: NDArray[np.generic], b: NDArray[np.generic]
) -> tuple[NDArray[np.generic], NDArray[np.generic], float]:
    """Polygons far from unit size, moved and scaled to it; ``k`` is the scale factor.

    ``F_r`` is scale-covariant: scaling both objects by ``k`` multiplies it by ``k**(3 - r)``
    (Matsakis & Wendling 1999), so very small or very large coordinates (1e-160, 1e150) are
    computed at unit size and scaled back. Inputs of ordinary size are left exactly as given.
    """
    if (
        a.dtype == np.bool_
        or a.ndim != 2
        or b.ndim != 2
        or a.shape[-1:] != (2,)
        or b.shape[-1:] != (2,)
    ):
        return a, b, 1.0
    both = np.concatenate([np.asarray(a, np.float64), np.asarray(b, np.float64)])
    if not np.isfinite(both).all() or len(both) == 0:
        return a, b, 1.0
    with np.errstate(over="ignore", invalid="ignore"):
        lo = both.min(axis=0)
        k = float((both.max(axis=0) - lo).max())
        far = float(np.abs(both).max())
    if math.isfinite(k) and k > 0 and _SCALE_RANGE[0] <= k <= _SCALE_RANGE[1] and far <= 1e12:
        return a, b, 1.0
    if not math.isfinite(k) or k <= 0:
        return a, b, 1.0
    return (np.asarray(a, np.float64) - lo) / k, (np.asarray(b, np.float64) - lo) / k, k


def rescaled(h: FloatArray, k: float, exponents: Sequence[float]) -> FloatArray:
    """Histograms of the normalised pair brought back to the caller's scale, checked."""
    out = np.array(h, dtype=np.float64, copy=True)
    rows = out.reshape(len(exponents), -1)
    for i, r in enumerate(exponents):
        if k != 1.0:
            log_factor = (3.0 - r) * math.log10(k)
            if abs(log_factor) > 300:
                raise InputError(
                    "argument/referent",
                    f"objects of size {k:.3g} give F_r = {k:.3g}**{3 - r:g} times the unit-size "
                    "values, which float64 cannot hold: express the coordinates in other units",
                )
            rows[i] *= 10.0**log_factor
    return checked_histogram(out)


def checked_histogram(h: FloatArray) -> FloatArray:
    """Refuse a histogram that is not finite or all zero; clear rounding-level negatives."""
    if not np.isfinite(h).all():
        raise InputError(
            "argument/referent", "the histogram overflowed (non-finite values): rescale the input"
        )
    rows = h.reshape(-1, h.shape[-1])
    for row in rows:
        top = float(row.max(initial=0.0))
        if not top > 0 or top < 1e-300:
            raise InputError(
                "argument/referent",
                "the histogram is zero in every direction (the objects are too far apart for "
                "their size, or too small, for float64): nothing can be said about them",
            )
        neg = row < 0
        if neg.any():
            if float(-row[neg].min()) > 1e-6 * top:
                raise InputError(
                    "argument/referent",
                    "the histogram has negative forces (a near-degenerate polygon, e.g. a "
                    "sliver): simplify or thicken it",
                )
            row[neg] = 0.0
    return h
