"""Benchmark of the Histogram of Forces engine (``scenespeak.spatial.forces``).

Prints median wall-clock times (one process, one thread) of F0 + F2:

* two convex 30-vertex polygons at 180 directions (issue 16's target: <= 0.1 ms),
* two non-convex (star-shaped) 200-vertex polygons at 180 directions (target: <= 2 ms),
* two 512 x 512 boolean masks (target: <= 4 ms),
* how the time scales with the vertex count and with the number of directions,
* the 10 pairs of a 5-object scene (convex hulls of 8-22 vertices, as the pipeline makes):
  one ``force_histograms`` call per pair against one sweep for all pairs
  (``forces.prepare`` + ``forces.f0_f2_pairs``, what ``language.relate_objects`` uses).

"F0+F2" is timed two ways: two calls of ``force_histogram`` (r=0, then r=2), and one call of
``force_histograms`` (both exponents sharing the validation and the sweep). Each timing is
whole public calls on the raw arrays or masks: validation, preparation (tracing, the
simplicity check), the contact test, the sweep and the check of the result are all inside;
nothing is prepared outside the timed region.

The machine may be shared: medians over many repeats are printed together with the load
average, and should be read with it.

Side by side with Matsakis & Wendling's raster algorithm in C (``--mw PATH`` or the environment
variable ``SCENESPEAK_MW_HOF``): a binary that takes ``A.pgm B.pgm directions repeats`` and prints
``median_ms best_ms argmax_f0 argmax_f2 [median_cpu_ms]`` for F0 then F2 of the two masks. It is
not part of the repository (``docs/forces.md`` says where the authors' code is and how to build
the driver, outside the repository); without it that table is skipped. Polygons are given to it
rasterised into a square image (the size in the table), the way a segmentation would.

Run::

    python benchmarks/bench_forces.py            # full run (a few minutes)
    python benchmarks/bench_forces.py --quick    # fewer repeats
    python benchmarks/bench_forces.py --mw /tmp/mw/hof_raster
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from skimage.draw import polygon as raster_polygon

from scenespeak.spatial.forces import (
    compiled,
    force_histogram,
    force_histograms,
    hybrid_histogram,
)

Array = NDArray[np.float64]


def convex(n: int, centre: tuple[float, float], radius: float, phase: float = 0.0) -> Array:
    """A convex polygon with ``n`` vertices on an ellipse."""
    a = phase + 2 * np.pi * np.arange(n) / n
    return np.column_stack([centre[0] + radius * np.cos(a), centre[1] + 0.7 * radius * np.sin(a)])


def star(n: int, centre: tuple[float, float], radius: float, seed: int) -> Array:
    """A non-convex star-shaped polygon: sorted random angles, random radii."""
    rng = np.random.default_rng(seed)
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = rng.uniform(0.5 * radius, radius, n)
    return np.column_stack([centre[0] + rad * np.cos(ang), centre[1] + rad * np.sin(ang)])


#: The clock of every timing: wall clock by default; ``--clock cpu`` uses the process's CPU
#: time (one thread throughout), which on a crowded machine is closer to an idle core's time.
CLOCK: list[Callable[[], float]] = [time.perf_counter]


def timings_ms(fn: Callable[[], object], repeat: int) -> list[float]:
    fn()  # warm-up (imports, caches)
    clock = CLOCK[0]
    times = []
    for _ in range(repeat):
        t0 = clock()
        fn()
        times.append(1e3 * (clock() - t0))
    return times


def median_ms(fn: Callable[[], object], repeat: int) -> float:
    return statistics.median(timings_ms(fn, repeat))


def median_best(fn: Callable[[], object], repeat: int) -> str:
    """``"median (best)"`` in ms: the best run shows the cost on an idle core."""
    times = timings_ms(fn, repeat)
    return f"{statistics.median(times):.3f} ({min(times):.3f})"


def f0_f2_calls(a: object, b: object, directions: int = 180) -> Callable[[], object]:
    return lambda: (
        force_histogram(a, b, r=0.0, directions=directions),
        force_histogram(a, b, r=2.0, directions=directions),
    )


def f0_f2_shared(a: object, b: object, directions: int = 180) -> Callable[[], object]:
    return lambda: force_histograms(a, b, r=(0.0, 2.0), directions=directions)


def masks() -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Two 512 x 512 masks: a rasterised 60-vertex star and a disc-like blob."""
    shape = (512, 512)
    a = np.zeros(shape, bool)
    b = np.zeros(shape, bool)
    pa = star(60, (150.0, -200.0), 110.0, seed=1)
    rr, cc = raster_polygon(-pa[:, 1], pa[:, 0], shape)
    a[rr, cc] = True
    pb = convex(90, (370.0, -330.0), 100.0)
    rr, cc = raster_polygon(-pb[:, 1], pb[:, 0], shape)
    b[rr, cc] = True
    return a, b


def polygon_vertices(mask: NDArray[np.bool_], tolerance: float | None) -> int:
    """Number of outline vertices a mask is traced into (private helper, for the table)."""
    from scenespeak.spatial.forces import prepare

    return len(prepare(mask, "mask", mask_tolerance=tolerance).start)


def scene_hulls() -> list[Array]:
    """Five convex hulls of 8-22 vertices, 5-25 cm across, 0.2-1 m apart (like the bench
    scene's objects on the ground plane)."""
    rng = np.random.default_rng(4)
    out = []
    for k, n in enumerate((17, 13, 8, 22, 20)):
        centre = (0.35 * k - 0.7 + rng.uniform(-0.05, 0.05), 1.0 + rng.uniform(-0.3, 0.3))
        out.append(convex(n, centre, rng.uniform(0.05, 0.12), rng.uniform(0, 1)))
    return out


def scene_pairs(directions: int = 180) -> tuple[Callable[[], object], Callable[[], object]]:
    """(per pair, all pairs at once) F0+F2 of every unordered pair of :func:`scene_hulls`."""
    from scenespeak.spatial.forces import f0_f2_pairs, prepare

    hulls = scene_hulls()
    index = [(i, j) for i in range(len(hulls)) for j in range(i + 1, len(hulls))]

    def per_pair() -> object:
        return [force_histograms(hulls[i], hulls[j], directions=directions) for i, j in index]

    def all_pairs() -> object:
        regions = [prepare(h, "hull") for h in hulls]
        return f0_f2_pairs(regions, index, directions)

    return per_pair, all_pairs


def rasterise(polys: list[Array], size: int) -> list[NDArray[np.bool_]]:
    """The polygons as boolean masks of a ``size`` x ``size`` image (the scene fills 90 %)."""
    pts = np.concatenate(polys)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    scale = 0.9 * size / float((hi - lo).max())
    out = []
    for p in polys:
        q = (p - lo) * scale + 0.05 * size
        mask = np.zeros((size, size), bool)
        rr, cc = raster_polygon(size - 1 - q[:, 1], q[:, 0], mask.shape)
        mask[rr, cc] = True
        out.append(mask)
    return out


def _write_pgm(path: Path, mask: NDArray[np.bool_]) -> None:
    h, w = mask.shape
    # Three header lines: MW's readPGM reads "P5", then "width height", then the maximum.
    path.write_bytes(f"P5\n{w} {h}\n255\n".encode() + (mask.astype(np.uint8) * 255).tobytes())


def mw_ms(binary: str, a: NDArray[np.bool_], b: NDArray[np.bool_], repeat: int) -> float:
    """Median ms of the MW binary's F0 + F2 (its own timer: no process start-up counted).

    The binary's fifth output field, if it prints one, is its median CPU time: used with
    ``--clock cpu`` so that both sides are timed on the same clock.
    """
    with tempfile.TemporaryDirectory() as tmp:
        pa, pb = Path(tmp) / "a.pgm", Path(tmp) / "b.pgm"
        _write_pgm(pa, a)
        _write_pgm(pb, b)
        out = subprocess.run(
            [binary, str(pa), str(pb), "180", str(repeat)],
            capture_output=True,
            text=True,
            check=True,
            timeout=3600,
        )
    fields = out.stdout.split()
    if CLOCK[0] is time.process_time and len(fields) >= 5:
        return float(fields[4])
    return float(fields[0])


def mw_table(binary: str, rep: int) -> None:
    """Every case of this benchmark against the MW raster code, side by side in one run."""
    print(
        f"\nAgainst Matsakis & Wendling's raster algorithm in C ({binary}), F0+F2, 180 "
        "directions, median ms of each (ours: force_histograms on the polygons or masks):\n"
    )
    print("| case | image | MW C (raster) | ours | ours faster by |")
    print("| --- | ---: | ---: | ---: | ---: |")
    cases: list[tuple[str, list[Array]]] = [
        ("convex 30 + 30", [convex(30, (0.0, 0.0), 1.0), convex(30, (3.0, 1.0), 1.2, 0.1)]),
        ("star 200 + 200", [star(200, (0.0, 0.0), 1.0, 2), star(200, (2.6, 0.8), 1.2, 3)]),
    ]
    for n in (8, 16, 60, 120, 250, 500):
        cases.append((f"convex {n} + {n}", [convex(n, (0, 0), 1.0), convex(n, (3, 1), 1.2, 0.1)]))
        cases.append((f"star {n} + {n}", [star(n, (0, 0), 1.0, 2), star(n, (2.6, 0.8), 1.2, 3)]))
    for name, polys in cases:
        for size in (256, 512):
            ma, mb = rasterise(polys, size)
            t_mw = mw_ms(binary, ma, mb, max(3, rep // 4))
            t_poly = median_ms(f0_f2_shared(*polys), rep)
            t_mask = median_ms(f0_f2_shared(ma, mb), rep)  # cheap: a median of many
            print(
                f"| {name}, polygons | {size}² | {t_mw:.2f} | {t_poly:.3f} | {t_mw / t_poly:.0f}× |"
            )
            print(
                f"| {name}, as masks | {size}² | {t_mw:.2f} | {t_mask:.3f} | {t_mw / t_mask:.1f}× |"
            )
    ma, mb = masks()
    t_mw = mw_ms(binary, ma, mb, max(3, rep // 4))
    t_mask = median_ms(f0_f2_shared(ma, mb), rep)
    print(
        f"| bench masks (star 60 + blob 90) | 512² | {t_mw:.2f} | {t_mask:.3f} | "
        f"{t_mw / t_mask:.1f}× |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    parser.add_argument(
        "--mw",
        default=os.environ.get("SCENESPEAK_MW_HOF"),
        help="Matsakis & Wendling raster binary (default $SCENESPEAK_MW_HOF; skipped if absent)",
    )
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall")
    parser.add_argument(
        "--numpy", action="store_true", help="time the NumPy reference (SCENESPEAK_NO_NUMBA=1)"
    )
    parser.add_argument(
        "--headline", action="store_true", help="only the first table (and the MW table)"
    )
    args = parser.parse_args()
    if args.clock == "cpu":
        CLOCK[0] = time.process_time
    if args.numpy:
        os.environ["SCENESPEAK_NO_NUMBA"] = "1"  # read on the first histogram
    else:
        # The steady state of a long process: compiled from the first call (by default a
        # process runs the reference until its work pays for loading Numba; see _jit).
        os.environ.setdefault("SCENESPEAK_NUMBA", "always")
    rep_small = 40 if args.quick else 200
    rep_big = 5 if args.quick else 21

    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    policy = "never" if args.numpy else os.environ["SCENESPEAK_NUMBA"]
    print(
        f"numpy {np.__version__}, 1 process, compiled kernel: {compiled()} "
        f"(SCENESPEAK_NUMBA={policy}), clock {args.clock}\n"
    )

    a30, b30 = convex(30, (0.0, 0.0), 1.0), convex(30, (3.0, 1.0), 1.2, 0.1)
    a200, b200 = star(200, (0.0, 0.0), 1.0, seed=2), star(200, (2.6, 0.8), 1.2, seed=3)
    ma, mb = masks()

    print("Median (best) of repeated runs, ms:\n")
    print("| case | F0+F2, two calls | F0+F2, force_histograms | F02 (hybrid) |")
    print("| --- | ---: | ---: | ---: |")
    for name, a, b, rep in (
        ("convex 30 + 30 vertices, 180 directions", a30, b30, rep_small),
        ("non-convex 200 + 200 vertices, 180 directions", a200, b200, rep_big),
        ("512 x 512 masks, 180 directions", ma, mb, rep_big),
    ):
        two = median_best(f0_f2_calls(a, b), rep)
        shared = median_best(f0_f2_shared(a, b), rep)
        hyb = median_best(lambda a=a, b=b: hybrid_histogram(a, b), rep)
        print(f"| {name} | {two} | {shared} | {hyb} |")

    if args.headline:
        if args.mw and os.path.exists(args.mw):
            mw_table(args.mw, rep_big)
        return

    print("\nMasks: outline simplification (mask_tolerance, pixels) vs time, F0+F2 two calls")
    print("(None: the measured per-ring rule, the default; see benchmarks/bench_masks.py):\n")
    print("| mask_tolerance | vertices (A + B) | F0+F2 |")
    print("| ---: | ---: | ---: |")
    for tol in (0.0, 0.25, 0.5, 1.0, None):
        verts = polygon_vertices(ma, tol) + polygon_vertices(mb, tol)
        t = median_ms(
            lambda tol=tol: (
                force_histogram(ma, mb, r=0.0, mask_tolerance=tol),
                force_histogram(ma, mb, r=2.0, mask_tolerance=tol),
            ),
            rep_big,
        )
        print(f"| {tol} | {verts} | {t:.3f} |")

    print("\nScaling with the vertex count (each polygon), 180 directions, F0+F2 two calls:\n")
    print("| vertices | convex | non-convex (star) |")
    print("| ---: | ---: | ---: |")
    for n in (8, 16, 30, 60, 120, 250, 500):
        rep = rep_small if n <= 60 else rep_big
        t_convex = median_ms(f0_f2_calls(convex(n, (0, 0), 1.0), convex(n, (3, 1), 1.2, 0.1)), rep)
        t_star = median_ms(f0_f2_calls(star(n, (0, 0), 1.0, 2), star(n, (2.6, 0.8), 1.2, 3)), rep)
        print(f"| {n} | {t_convex:.3f} | {t_star:.3f} |")

    print("\nScaling with the number of directions, F0+F2 two calls:\n")
    print("| directions | convex 30 | star 200 | masks 512² |")
    print("| ---: | ---: | ---: | ---: |")
    for d in (36, 90, 180, 360, 720):
        t30 = median_ms(f0_f2_calls(a30, b30, d), rep_small)
        t200 = median_ms(f0_f2_calls(a200, b200, d), rep_big)
        tm = median_ms(f0_f2_calls(ma, mb, d), rep_big)
        print(f"| {d} | {t30:.3f} | {t200:.3f} | {tm:.3f} |")

    print("\nThe 10 pairs of a 5-object scene (convex hulls, 8-22 vertices), F0+F2:\n")
    print("| case | per pair (force_histograms) | all pairs, one sweep |")
    print("| --- | ---: | ---: |")
    per_pair, all_pairs = scene_pairs()
    print(
        f"| 10 pairs, 180 directions | {median_best(per_pair, rep_small)} | "
        f"{median_best(all_pairs, rep_small)} |"
    )

    if args.mw and os.path.exists(args.mw):
        mw_table(args.mw, rep_big)
    else:
        print("\n(no MW binary given: --mw PATH or SCENESPEAK_MW_HOF; that table is skipped)")

    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
