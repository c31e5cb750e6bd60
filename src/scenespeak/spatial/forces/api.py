"""The public functions: one pair (polygons or masks), several exponents, the hybrid F02,
and all pairs of a scene in one call.

Every function validates its input, checks that the histogram is defined for the exponent
(``F_r`` diverges for overlapping objects when ``r >= 1`` and touching ones when ``r >= 2``),
and runs the sweep of :mod:`~scenespeak.spatial.forces.kernel` (compiled when Numba is there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypeGuard

import numpy as np
from numpy.typing import ArrayLike, NDArray

from scenespeak.errors import InputError
from scenespeak.spatial.forces import _jit, guards
from scenespeak.spatial.forces.contact import _contact
from scenespeak.spatial.forces.kernel import KernelSpec, direction_table, kernel_code, sweep_pairs
from scenespeak.spatial.forces.regions import DEFAULT_MASK_TOLERANCE as _MASK_TOLERANCE
from scenespeak.spatial.forces.regions import Region, _region

FloatArray = NDArray[np.float64]


def _check_directions(directions: int) -> int:
    return guards.check_directions(directions)


_F0 = KernelSpec(0.0)
_F2 = KernelSpec(2.0)
_F02 = KernelSpec(2.0, hybrid=True)


def _sweep_one(
    a: Region, b: Region, kernels: list[KernelSpec], directions: int, y0: float = 0.0
) -> FloatArray:
    """``(len(kernels), directions)`` histograms of one pair."""
    return sweep_pairs([a, b], [(0, 1)], kernels, directions, [y0])[0]


def _pair(
    argument: ArrayLike, referent: ArrayLike, mask_tolerance: float | None
) -> tuple[Region, Region]:
    a_arr = guards.as_vertices(argument, "argument")
    b_arr = guards.as_vertices(referent, "referent")
    mask_tolerance = guards.check_tolerance(mask_tolerance)
    a_mask, b_mask = a_arr.dtype == np.bool_, b_arr.dtype == np.bool_
    if a_mask != b_mask:
        raise InputError(
            "argument/referent",
            "one object is a boolean mask and the other a polygon: give two polygons or two "
            "masks of the same shape",
        )
    if a_mask and a_arr.shape != b_arr.shape:
        raise InputError(
            "argument/referent",
            f"masks have different shapes {a_arr.shape} and {b_arr.shape}: both must come "
            "from the same image",
        )
    return (
        _region(a_arr, "argument", mask_tolerance),
        _region(b_arr, "referent", mask_tolerance),
    )


def force_histogram(
    argument: ArrayLike,
    referent: ArrayLike,
    r: float = 2.0,
    directions: int = 180,
    *,
    mask_tolerance: float | None = _MASK_TOLERANCE,
) -> FloatArray:
    """Histogram of forces ``F_r`` of ``argument`` (A) with respect to ``referent`` (B).

    Parameters
    ----------
    argument, referent : array_like
        Either two ``(N, 2)`` vertex arrays of simple polygons (convex or not, either
        orientation, no self-intersection), or two 2-D boolean masks of equal shape.
    r : float, default 2.0
        Exponent of the elementary force ``d**-r``: 0 for constant forces, 2 for gravitational
        forces; any real value where the histogram is defined (``r < 1`` always; ``r < 2`` if
        the objects do not overlap; any ``r`` if they do not touch).
    directions : int, default 180
        Number of directions; ``h[k]`` is the value at angle ``2*pi*k/directions``.
    mask_tolerance : float or None, default None
        For masks: the traced outline is simplified to within this many pixels (0 keeps every
        marching-squares vertex); ``None`` chooses it per ring by the measured rule of
        :func:`scenespeak.spatial.forces.masks.outline_tolerance` (``docs/forces.md``).

    Returns
    -------
    numpy.ndarray
        Float array of length ``directions``: how much the argument lies in each direction from
        the referent. Not normalised.

    Raises
    ------
    scenespeak.errors.InputError
        Degenerate input (see ``docs/forces.md``), or ``r`` where the histogram is undefined
        (overlapping objects for ``r >= 1``, touching objects for ``r >= 2``); use
        :func:`hybrid_histogram` for those.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[2.0, 0.0], [3.0, 0.0], [3.0, 1.0], [2.0, 1.0]])
    >>> b = a - [2.0, 0.0]
    >>> h = force_histogram(a, b, r=2.0, directions=8)
    >>> int(np.argmax(h))   # A is to the right of B
    0
    """
    return force_histograms(argument, referent, (r,), directions, mask_tolerance=mask_tolerance)[0]


def _check_r(r: object) -> float:
    return guards.check_r(r)


def _check_defined(a: Region, b: Region, r: float) -> None:
    """Raise if ``F_r`` diverges for these objects (overlap for r >= 1, contact for r >= 2)."""
    if r < 1:
        return
    inter, touch = _contact(a, b)
    if inter > 0:
        raise InputError(
            "argument/referent",
            f"the objects overlap (area of A∩B = {inter:.6g}), so F_r diverges for "
            f"r = {r:g} >= 1; use r < 1 (e.g. F0) or hybrid_histogram() for F02",
        )
    if r >= 2 and touch:
        raise InputError(
            "argument/referent",
            f"the objects touch, so F_r diverges for r = {r:g} >= 2; use r < 2 or "
            "hybrid_histogram() for F02",
        )


def _direct(
    argument: ArrayLike,
    referent: ArrayLike,
    exponents: list[float],
    directions: int,
    mask_tolerance: float | None,
) -> FloatArray | None:
    """:func:`force_histograms` of two float64 polygons in one compiled call
    (:mod:`~scenespeak.spatial.forces._direct`), or None when the general path must run: other
    input, the NumPy reference (``_jit``), or anything to report or handle."""
    from scenespeak import limits

    most = limits.current().max_vertices
    if not (_float_polygon(argument, most) and _float_polygon(referent, most)):
        return None
    if mask_tolerance is not None and not _plain_tolerance(mask_tolerance):
        return None
    if not _jit.wanted(1, directions * (len(argument) + len(referent))):
        return None
    from scenespeak.spatial.forces._direct import pair_histograms

    codes = np.array([kernel_code(x) for x in exponents], dtype=np.int64)
    rs = np.array(exponents, dtype=np.float64)
    status, out = pair_histograms(
        np.ascontiguousarray(argument),
        np.ascontiguousarray(referent),
        (codes, rs),
        direction_table(directions),
    )
    return out if status == 0 else None


def _float_polygon(obj: object, most: int) -> TypeGuard[FloatArray]:
    """An ``(N, 2)`` float64 array of at most ``most`` vertices (what the direct path takes)."""
    return (
        isinstance(obj, np.ndarray)
        and obj.dtype == np.float64
        and obj.ndim == 2
        and obj.shape[1] == 2
        and len(obj) <= most
    )


def _plain_tolerance(value: object) -> bool:
    """Whether ``guards.check_tolerance`` accepts ``value`` (it is not used for polygons)."""
    try:
        guards.check_tolerance(value)
    except InputError:
        return False
    return True


def force_histograms(
    argument: ArrayLike,
    referent: ArrayLike,
    r: Sequence[float] = (0.0, 2.0),
    directions: int = 180,
    *,
    mask_tolerance: float | None = _MASK_TOLERANCE,
) -> FloatArray:
    """Several force histograms of one pair at once (the geometry is shared).

    Same as stacking :func:`force_histogram` for each exponent in ``r``, but faster: the
    objects are validated, traced and swept once.

    Parameters
    ----------
    argument, referent : array_like
        As for :func:`force_histogram`.
    r : sequence of float, default (0.0, 2.0)
        The exponents; every one must be defined for this pair.
    directions : int, default 180
        Number of directions; ``h[i, k]`` is the value for ``r[i]`` at ``2*pi*k/directions``.
    mask_tolerance : float or None, default None
        As for :func:`force_histogram`.

    Returns
    -------
    numpy.ndarray
        Array of shape ``(len(r), directions)``.

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> f0, f2 = force_histograms(sq + [0.0, 3.0], sq, directions=4)
    >>> int(np.argmax(f0)), int(np.argmax(f2))   # A is above B: angle pi/2
    (1, 1)
    """
    directions = _check_directions(directions)
    items = r if isinstance(r, tuple | list) else np.atleast_1d(np.asarray(r, dtype=object))
    exponents = [_check_r(x) for x in items]
    if not exponents:
        raise InputError("r", "give at least one exponent")
    direct = _direct(argument, referent, exponents, directions, mask_tolerance)
    if direct is not None:
        return direct
    a_arr, b_arr, k = guards.normalise_pair(
        guards.as_vertices(argument, "argument"), guards.as_vertices(referent, "referent")
    )
    a, b = _pair(a_arr, b_arr, mask_tolerance)
    _check_defined(a, b, max(exponents))
    with np.errstate(all="ignore"):
        h = _sweep_one(a, b, [KernelSpec(x) for x in exponents], directions)
    return guards.rescaled(h, k, exponents)


def hybrid_histogram(
    argument: ArrayLike,
    referent: ArrayLike,
    p0: float = 0.01,
    p1: float = 3.0,
    directions: int = 180,
    *,
    mask_tolerance: float | None = _MASK_TOLERANCE,
) -> FloatArray:
    """Hybrid histogram F02: gravitational forces, constant below a distance ``Y0``.

    The elementary force is ``1 / max(d, Y0)**2`` with ``Y0 = max(p0 * D_min, p1 * D_AB)``,
    where ``D_X = 2 * sqrt(area(X) / pi)``, ``D_min`` is that of the smaller object and
    ``D_AB`` that of ``A ∩ B``. Defined for touching and intersecting objects; equal to
    ``force_histogram(..., r=2)`` for objects farther apart than ``Y0``.

    Parameters
    ----------
    argument, referent : array_like
        As for :func:`force_histogram`.
    p0, p1 : float
        Positive factors of ``Y0`` (Matsakis' defaults 0.01 and 3).
    directions : int, default 180
        Number of directions; ``h[k]`` is the value at angle ``2*pi*k/directions``.
    mask_tolerance : float or None, default None
        As for :func:`force_histogram`.

    Returns
    -------
    numpy.ndarray
        Float array of length ``directions``.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    >>> b = a + [1.0, 0.0]   # overlaps A: F2 is undefined, F02 is not
    >>> h = hybrid_histogram(a, b, directions=4)
    >>> bool(h[2] > h[0])    # A sticks out to the left of B
    True
    """
    directions = _check_directions(directions)
    for label, value in (("p0", p0), ("p1", p1)):
        if (
            isinstance(value, bool)
            or not (isinstance(value, int | float | np.number) and math.isfinite(value))
            or value < 0
            or value > 1e3
        ):
            raise InputError(label, f"must be a finite number in [0, 1000], got {value!r}")
    a_arr, b_arr, k = guards.normalise_pair(
        guards.as_vertices(argument, "argument"), guards.as_vertices(referent, "referent")
    )
    a, b = _pair(a_arr, b_arr, mask_tolerance)
    inter, _ = _contact(a, b)
    d_min = 2.0 * math.sqrt(min(a.area, b.area) / math.pi)
    d_int = 2.0 * math.sqrt(inter / math.pi)
    y0 = max(float(p0) * d_min, float(p1) * d_int)
    if y0 <= 0:
        raise InputError("p0/p1", "Y0 = max(p0*D_min, p1*D_AB) is 0: give p0 > 0")
    with np.errstate(all="ignore"):
        h = _sweep_one(a, b, [KernelSpec(2.0, hybrid=True)], directions, y0)
    return guards.rescaled(h, k, [2.0])[0]


def _f0_and_f2(
    a: Region,
    b: Region,
    directions: int,
    *,
    try_f2: bool = True,
    contact: tuple[float, bool] | None = None,
) -> tuple[FloatArray, FloatArray, bool]:
    """F0 and F2 of two prepared regions, or F0 and the hybrid F02 where F2 is undefined.

    For regions made once per object (``_polygon_region``) and used in many pairs: the same
    values as ``force_histograms(A, B, (0, 2))`` when that succeeds and gives a finite F2
    (and ``try_f2``), else ``force_histogram(A, B, r=0)`` and ``hybrid_histogram(A, B)``, but
    with one ``_contact`` and one sweep for both kernels (the kernels share the edge pairs and
    are summed separately, so each result is the one of its own sweep, bit for bit).

    ``contact`` is ``_contact(a, b)`` when already known.

    Returns
    -------
    f0, f2, hybrid
        ``f2`` is F02 when ``hybrid``.
    """
    inter, touch = _contact(a, b) if contact is None else contact
    if try_f2 and not inter > 0 and not touch:  # what _check_defined(a, b, 2.0) lets through
        try:
            f0, f2 = _sweep_one(a, b, [_F0, _F2], directions)
            if np.all(np.isfinite(f2)):
                return f0, f2, False
        except (ValueError, ArithmeticError):
            pass
    d_min = 2.0 * math.sqrt(min(a.area, b.area) / math.pi)
    d_int = 2.0 * math.sqrt(inter / math.pi)
    y0 = max(0.01 * d_min, 3.0 * d_int)  # hybrid_histogram's defaults p0 = 0.01, p1 = 3
    if y0 <= 0:
        raise InputError("p0/p1", "Y0 = max(p0*D_min, p1*D_AB) is 0: give p0 > 0")
    f0, f02 = _sweep_one(a, b, [_F0, _F02], directions, y0)
    return f0, f02, True


@dataclass(frozen=True)
class PairForces:
    """F0 and F2 of many pairs (F02 where F2 is undefined), from :func:`f0_f2_pairs`.

    Attributes
    ----------
    f0, f2 : ndarray, shape (P, directions)
        Constant and gravitational forces of each pair; ``f2[p]`` is the hybrid F02 (Matsakis'
        defaults ``p0 = 0.01``, ``p1 = 3``) where ``hybrid[p]``. Each row is contiguous; the
        two may be views of one ``(P, 2, directions)`` array (then not C-contiguous as a whole).
    hybrid : ndarray of bool, shape (P,)
    """

    f0: FloatArray
    f2: FloatArray
    hybrid: NDArray[np.bool_]


def _boxes(regions: Sequence[Region]) -> FloatArray:
    """``(G, 4)`` bounding boxes ``[xmin, ymin, xmax, ymax]`` of the regions' vertices."""
    return np.array([[*r.start.min(axis=0), *r.start.max(axis=0)] for r in regions]).reshape(-1, 4)


def _apart(boxes: FloatArray, ia: NDArray[np.intp], ib: NDArray[np.intp]) -> NDArray[np.bool_]:
    """:func:`_boxes_apart` of many pairs at once (the same operations on the same floats)."""
    lo_a, hi_a = boxes[ia, :2], boxes[ia, 2:]
    lo_b, hi_b = boxes[ib, :2], boxes[ib, 2:]
    scale = (np.maximum(hi_a, hi_b) - np.minimum(lo_a, lo_b)).max(axis=1, initial=0.0)
    tol = (1e-10 * scale)[:, None]
    return ((lo_a > hi_b + tol) | (lo_b > hi_a + tol)).any(axis=1)


def _y0(a: Region, b: Region, inter: float) -> float:
    """``Y0 = max(p0 * D_min, p1 * D_AB)`` with Matsakis' defaults p0 = 0.01, p1 = 3."""
    d_min = 2.0 * math.sqrt(min(a.area, b.area) / math.pi)
    d_int = 2.0 * math.sqrt(inter / math.pi)
    y0 = max(0.01 * d_min, 3.0 * d_int)
    if y0 <= 0:
        raise InputError("p0/p1", "Y0 = max(p0*D_min, p1*D_AB) is 0: give p0 > 0")
    return y0


def f0_f2_pairs(
    regions: Sequence[Region],
    pairs: Sequence[tuple[int, int]] | NDArray[np.intp] | None = None,
    directions: int = 180,
    *,
    try_f2: Sequence[bool] | NDArray[np.bool_] | None = None,
) -> PairForces:
    """F0 and F2 (or F02) of many pairs of prepared objects, in one sweep.

    The same values as :func:`force_histograms` ``(A, B, (0, 2))`` for each pair where that is
    defined and finite, else :func:`force_histogram` ``(A, B, r=0)`` and
    :func:`hybrid_histogram` ``(A, B)``: the objects are validated once (:func:`prepare`),
    pairs whose bounding boxes are apart skip the contact test, and every pair is swept in one
    call of the kernel, which skips, direction by direction, the pairs that no line meets.
    Memory is linear in the number of pairs.

    Parameters
    ----------
    regions : sequence of Region
        From :func:`prepare`.
    pairs : sequence of (int, int) or (P, 2) int array, optional
        ``(argument, referent)`` indices; default every unordered pair ``i < j`` (the
        histograms of ``(j, i)`` are those of ``(i, j)`` turned by half a turn).
    directions : int, default 180
    try_f2 : sequence or array of bool, optional
        Per pair, whether to try F2 at all (False: F02 directly, e.g. for footprints already
        known to overlap).

    Returns
    -------
    PairForces

    Examples
    --------
    >>> import numpy as np
    >>> from scenespeak.spatial.forces import prepare
    >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> objs = [prepare(sq + [3.0 * k, 0.0], f"box {k}") for k in range(3)]
    >>> got = f0_f2_pairs(objs, directions=8)
    >>> got.f0.shape, got.hybrid.tolist()
    ((3, 8), [False, False, False])
    >>> int(np.argmax(got.f2[0]))   # box 0 is left of box 1: angle pi
    4
    """
    directions = _check_directions(directions)
    g = len(regions)
    if pairs is None:
        pairs = [(i, j) for i in range(g) for j in range(i + 1, g)]
    index = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
    n = len(index)
    if n and (index.min() < 0 or index.max() >= g):
        raise InputError("pairs", f"indices must lie in 0..{g - 1} (one per prepared region)")
    tries = np.ones(n, bool) if try_f2 is None else np.asarray(try_f2, dtype=bool)
    if tries.shape != (n,):
        raise InputError("try_f2", f"give one flag per pair: {tries.size} for {n} pairs")
    apart = _apart(_boxes(regions), index[:, 0], index[:, 1])
    inter = np.zeros(n)
    touch = np.zeros(n, bool)
    for k in np.flatnonzero(~apart):
        inter[k], touch[k] = _contact(regions[index[k, 0]], regions[index[k, 1]])
    f0 = np.empty((n, directions))
    f2 = np.empty((n, directions))
    hybrid = np.ones(n, bool)
    tried = np.flatnonzero(tries & ~(inter > 0) & ~touch)
    if tried.size:
        with np.errstate(all="ignore"):
            swept = sweep_pairs(regions, index[tried].tolist(), [_F0, _F2], directions)
        finite = np.isfinite(swept[:, 1]).all(axis=1)
        if tried.size == n and bool(finite.all()):
            # Every pair apart with a finite F2 (the usual scene): F0 and F2 are the sweep's
            # own rows (views, not copied twice through a mask).
            return PairForces(f0=swept[:, 0], f2=swept[:, 1], hybrid=np.zeros(n, bool))
        ok = tried[finite]
        f0[ok], f2[ok] = swept[finite, 0], swept[finite, 1]
        hybrid[ok] = False
    rest = np.flatnonzero(hybrid)
    if rest.size:
        y0 = [_y0(regions[index[k, 0]], regions[index[k, 1]], inter[k]) for k in rest]
        with np.errstate(all="ignore"):
            swept = sweep_pairs(regions, index[rest].tolist(), [_F0, _F02], directions, y0)
        f0[rest], f2[rest] = swept[:, 0], swept[:, 1]
    return PairForces(f0=f0, f2=f2, hybrid=hybrid)


def _many_f0_and_f2(
    items: Sequence[tuple[Region, Region, bool]], directions: int
) -> list[tuple[FloatArray, FloatArray, bool]]:
    """:func:`_f0_and_f2` of several pairs ``(a, b, try_f2)`` (older form of
    :func:`f0_f2_pairs`, kept for callers that have the pairs as region objects)."""
    regions: list[Region] = []
    where: dict[int, int] = {}
    for a, b, _ in items:
        for r in (a, b):
            if id(r) not in where:
                where[id(r)] = len(regions)
                regions.append(r)
    got = f0_f2_pairs(
        regions,
        [(where[id(a)], where[id(b)]) for a, b, _ in items],
        directions,
        try_f2=[t for _, _, t in items],
    )
    return [(got.f0[k], got.f2[k], bool(got.hybrid[k])) for k in range(len(items))]


def polygon_area(polygon: ArrayLike) -> float:
    """Area of a simple polygon (``(N, 2)`` vertices, either orientation) or of a mask outline.

    Examples
    --------
    >>> polygon_area([[0, 0], [2, 0], [2, 1], [0, 1]])
    2.0
    """
    return _region(np.asarray(polygon), "polygon", _MASK_TOLERANCE).area


def intersection_area(a: ArrayLike, b: ArrayLike) -> float:
    """Area of ``A ∩ B`` for two simple polygons (convex or not), exact up to rounding.

    Computed with Green's theorem: the boundary of ``A ∩ B`` is the part of A's boundary
    inside B plus the part of B's boundary inside A (edges split at every crossing; shared
    boundary pieces counted once when both interiors lie on the same side).

    Examples
    --------
    >>> sq = [[0, 0], [2, 0], [2, 2], [0, 2]]
    >>> intersection_area(sq, [[1, 1], [3, 1], [3, 3], [1, 3]])
    1.0
    """
    ra, rb = _pair(a, b, _MASK_TOLERANCE)
    return _contact(ra, rb)[0]


def polygons_intersect(a: ArrayLike, b: ArrayLike) -> bool:
    """Whether the interiors of two simple polygons overlap (touching does not count).

    Examples
    --------
    >>> sq = [[0, 0], [1, 0], [1, 1], [0, 1]]
    >>> polygons_intersect(sq, [[1, 0], [2, 0], [2, 1], [1, 1]])
    False
    """
    return intersection_area(a, b) > 0.0
