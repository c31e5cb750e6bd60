"""One entry point for the force sweep: the compiled kernel, or the NumPy reference.

:func:`sweep_pairs` takes prepared regions, the pairs to compute and the kernels, and returns
every pair's histograms. With Numba installed (the ``fast`` extra) it runs the compiled loops of
:mod:`~scenespeak.spatial.forces._sweep` (all pairs of a scene in one call, one direction at a
time, each region projected once per direction); without it, or with ``SCENESPEAK_NO_NUMBA=1``,
the NumPy reference of :mod:`~scenespeak.spatial.forces.reference`. Both give the same
histograms to rounding (``tests/spatial/test_forces_kernel.py`` pins 1e-9 relative to each
histogram's largest bin).

Why Numba and not a C/C++ or Rust extension: the package is pure Python and installs from a
source checkout with ``pip install`` anywhere; an extension would need a compiler on the user's
machine or a wheel per platform and Python version built and published by CI. Numba ships
wheels for every platform NumPy does, compiles for the CPU it runs on (AVX-512 here), and its
on-disk cache makes the compile a one-time cost (see ``docs/forces.md`` for the measured
cold/warm start-up). Its absence costs speed, never correctness.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scenespeak.spatial.forces import _jit
from scenespeak.spatial.forces.regions import Region

FloatArray = NDArray[np.float64]

__all__ = ["KernelSpec", "compiled", "direction_table", "kernel_code", "sweep_pairs"]


@dataclass(frozen=True)
class KernelSpec:
    """An elementary force: ``d**-r`` (``hybrid`` False) or ``1 / max(d, Y0)**2`` (True).

    The hybrid kernel's ``Y0`` is given per pair to :func:`sweep_pairs`.
    """

    r: float
    hybrid: bool = False

    @property
    def code(self) -> int:
        """The kernel's code for the compiled sweep (:func:`kernel_code`)."""
        return kernel_code(self.r, self.hybrid)


def kernel_code(r: float, hybrid: bool = False) -> int:
    """The compiled sweep's code of a kernel: 0 for ``r = 0``, 1 for ``r = 2``, 2 for the hybrid
    F02, 3 for any other ``r`` (``_sweep``'s module docstring).

    Examples
    --------
    >>> kernel_code(0.0), kernel_code(2.0), kernel_code(2.0, hybrid=True), kernel_code(1.5)
    (0, 1, 2, 3)
    """
    if hybrid:
        return 2
    if r == 0.0:
        return 0
    if r == 2.0:
        return 1
    return 3


def compiled() -> bool:
    """Whether the compiled kernel can be used (Numba installed and not disabled).

    It is used for a sweep once the process's work pays for loading it
    (:mod:`~scenespeak.spatial.forces._jit`; ``SCENESPEAK_NUMBA=always`` from the first).

    Examples
    --------
    >>> isinstance(compiled(), bool)
    True
    """
    return _jit.available()


@functools.lru_cache(maxsize=64)
def direction_table(directions: int) -> FloatArray:
    """``(directions, 2)`` read-only array of ``(cos θ, sin θ)``, ``θ = 2π d / directions``.

    The values the compiled sweep computes for each direction (the same expression, the same
    C library's ``cos`` and ``sin``), made once per number of directions and shared: a small
    call of the convex chain walk otherwise spends a tenth of its time on them.

    Examples
    --------
    >>> t = direction_table(4)
    >>> t.shape, t.flags.writeable
    ((4, 2), False)
    >>> [round(float(x), 12) for x in t[1]]
    [0.0, 1.0]
    """
    rows = [(2.0 * math.pi * d / directions) for d in range(directions)]
    table = np.array([(math.cos(t), math.sin(t)) for t in rows], dtype=np.float64)
    table = table.reshape(directions, 2)
    table.flags.writeable = False
    return table


def _reference(
    regions: Sequence[Region],
    pairs: Sequence[tuple[int, int]],
    kernels: Sequence[KernelSpec],
    y0: Sequence[float],
    directions: int,
) -> FloatArray:
    from scenespeak.spatial.forces.reference import _edge_pair_histograms, _Kernel

    out = np.empty((len(pairs), len(kernels), directions))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for p, (i, j) in enumerate(pairs):
            ks = [_Kernel(k.r, y0[p] if k.hybrid else 0.0) for k in kernels]
            out[p] = _edge_pair_histograms(regions[i], regions[j], ks, directions)
    return out


def _packed(
    regions: Sequence[Region],
) -> tuple[FloatArray, NDArray[np.int64], NDArray[np.int64], FloatArray, NDArray[np.bool_]]:
    """The regions' vertices end to end, each relative to its first vertex, and which regions
    are convex."""
    sizes = np.array([len(r.start) for r in regions], dtype=np.int64)
    region_start = np.zeros(len(regions) + 1, dtype=np.int64)
    np.cumsum(sizes, out=region_start[1:])
    origin = np.array([r.start[0] for r in regions], dtype=np.float64).reshape(-1, 2)
    pts = np.concatenate([r.start for r in regions]) - np.repeat(origin, sizes, axis=0)
    nxt = np.concatenate([r.nxt + region_start[g] for g, r in enumerate(regions)])
    convex = np.array([r.convex for r in regions], dtype=np.bool_)
    return pts, nxt.astype(np.int64), region_start, origin, convex


def sweep_pairs(
    regions: Sequence[Region],
    pairs: Sequence[tuple[int, int]],
    kernels: Sequence[KernelSpec],
    directions: int,
    y0: Sequence[float] | None = None,
) -> FloatArray:
    """Force histograms of ``pairs`` of ``regions``, shape ``(len(pairs), len(kernels), D)``.

    Parameters
    ----------
    regions : sequence of Region
        Prepared objects (:func:`~scenespeak.spatial.forces.prepare`).
    pairs : sequence of (int, int)
        ``(argument, referent)`` indices into ``regions``.
    kernels : sequence of KernelSpec
    directions : int
        Histogram bins; ``h[..., k]`` is the value at angle ``2*pi*k/directions``.
    y0 : sequence of float, optional
        Each pair's ``Y0`` for hybrid kernels.

    Returns
    -------
    numpy.ndarray
        Not checked for finiteness (``F_r`` of touching objects may be infinite for r >= 2).
    """
    y0_arr = np.zeros(len(pairs)) if y0 is None else np.asarray(y0, dtype=np.float64)
    if not pairs:
        return np.zeros((0, len(kernels), directions))
    sizes = [len(r.start) for r in regions]
    work = directions * sum(sizes[i] + sizes[j] for i, j in pairs)
    if not _jit.wanted(len(pairs), work):
        return _reference(regions, pairs, kernels, list(y0_arr), directions)
    from scenespeak.spatial.forces._sweep import sweep

    index = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    codes = np.array([k.code for k in kernels], dtype=np.int64)
    rs = np.array([k.r for k in kernels], dtype=np.float64)
    out: FloatArray = sweep(
        _packed(regions),
        np.ascontiguousarray(index[:, 0]),
        np.ascontiguousarray(index[:, 1]),
        y0_arr,
        (codes, rs),
        int(directions),
    )
    return out
