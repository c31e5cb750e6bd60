"""The Histogram of Forces (Matsakis & Wendling 1999), exact for polygons, fast for masks.

For two plane objects A (the *argument*) and B (the *referent*) and a direction θ, the force
histogram ``F_r^{AB}(θ)`` sums, over every line of direction θ, the elementary forces
``d**-r`` between the points of A and the points of B that lie behind them in direction θ. It
is large when A lies in direction θ from B. ``r = 0`` (constant forces, "F0") depends on shape
and size only; ``r = 2`` (gravitational forces, "F2") weighs near parts more.

Method (see ``docs/forces.md``)
-------------------------------
Each object is turned into a set of oriented boundary edges (interior on the left). On one line
the four-term formula of forces.md pairs every endpoint of an A-section with every endpoint of a
B-section, so ``F(θ)`` is a signed sum over (edge of A, edge of B) of ``∫ Φ(s_A(v) - s_B(v)) dv``
over the range of lines both edges cross. Both ``s_A`` and ``s_B`` are linear in ``v``, so each
integral is closed-form (an antiderivative ``Ψ`` of ``Φ``). Only edge pairs whose line ranges
overlap contribute; they are found for a block of directions at once from one sort of the
vertices per direction and cumulative counts, so the cost is close to O((n + m) · directions)
for convex objects. No line is ever sampled: the result is exact up to rounding. With an even
number of directions only half are swept; the pairs give ``F(θ + π)`` too.

Masks are traced into polygons (marching squares at level 0.5, holes included, simplified by
Douglas-Peucker to 0.25 px) and computed exactly in the same way.

Direction convention: ``h[k]`` is the value at angle ``2*pi*k/directions``; angle 0 is +x and
``pi/2`` is +y. For masks, +x is increasing column and +y is *decreasing* row (image "up").

Layout
------
``regions`` (validation, :func:`prepare`), ``masks`` + ``_trace`` (tracing: marching squares),
``contact`` (overlap, via :mod:`scenespeak.geometry.polygons`), ``reference`` (the NumPy sweep:
the specification), ``_sweep`` + ``_table`` + ``kernel`` (the compiled sweep, Numba; the
reference without it or for small work, see ``_jit``), ``_shapes`` (compiled helpers of
``prepare``), ``api``.

Examples
--------
>>> import numpy as np
>>> from scenespeak.spatial.forces import force_histogram
>>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
>>> h = force_histogram(square + [3.0, 0.0], square, r=0.0, directions=4)
>>> h.round(6).tolist()   # A is to the right of B: everything at angle 0
[1.0, 0.0, 0.0, 0.0]
"""

from scenespeak.spatial.forces.api import (
    PairForces,
    _check_defined,
    _check_directions,
    _check_r,
    _f0_and_f2,
    _many_f0_and_f2,
    _pair,
    f0_f2_pairs,
    force_histogram,
    force_histograms,
    hybrid_histogram,
    intersection_area,
    polygon_area,
    polygons_intersect,
)
from scenespeak.spatial.forces.contact import _boxes_apart, _contact
from scenespeak.spatial.forces.kernel import KernelSpec, compiled, sweep_pairs
from scenespeak.spatial.forces.masks import _mask_region
from scenespeak.spatial.forces.reference import (
    _edge_pair_histograms,
    _Kernel,
    _many_f0_f2,
    _pairs,
)
from scenespeak.spatial.forces.regions import Region, _polygon_region, _Region, _region, prepare

__all__ = [
    "KernelSpec",
    "PairForces",
    "Region",
    "compiled",
    "f0_f2_pairs",
    "force_histogram",
    "force_histograms",
    "hybrid_histogram",
    "intersection_area",
    "polygon_area",
    "polygons_intersect",
    "prepare",
    "sweep_pairs",
]

# The private names above are re-exported for the tests and benchmarks that pin the reference.
_PRIVATE = (
    _Kernel,
    _Region,
    _boxes_apart,
    _check_defined,
    _check_directions,
    _check_r,
    _contact,
    _edge_pair_histograms,
    _f0_and_f2,
    _many_f0_and_f2,
    _many_f0_f2,
    _mask_region,
    _pair,
    _pairs,
    _polygon_region,
    _region,
)
