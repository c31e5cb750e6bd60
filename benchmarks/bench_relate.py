"""Benchmark of ``language.relate_objects`` on scenes of n objects (every ordered pair).

Prints, for n = 10, 25, 50, 100 convex hulls of 8-22 vertices (5-25 cm across, laid out on a
floor like the pipeline's objects), the median wall-clock time of ``relate_objects`` and its
parts: preparing and sweeping all pairs (``forces.prepare`` + ``forces.f0_f2_pairs``) and the
rest (degrees of truth, rule base, sentences). The growth exponent between consecutive sizes
is ``log(t2 / t1) / log(n2 / n1)`` (2 means time grows as the number of pairs).

Run::

    python benchmarks/bench_relate.py            # a few minutes on a busy machine
    python benchmarks/bench_relate.py --quick
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from scenespeak.language import relate_objects
from scenespeak.spatial.forces import compiled, f0_f2_pairs, prepare


def scene(n: int, seed: int = 0) -> list[NDArray[np.float64]]:
    """``n`` convex hulls on a floor of about ``sqrt(n)`` x ``sqrt(n)`` metres, not overlapping."""
    rng = np.random.default_rng(seed)
    side = max(1, math.ceil(math.sqrt(n)))
    hulls = []
    for k in range(n):
        cx, cy = 0.5 * (k % side), 0.5 * (k // side) + 1.0
        m = int(rng.integers(8, 23))
        a = np.sort(rng.uniform(0, 2 * np.pi, m))
        r = rng.uniform(0.05, 0.12)
        hulls.append(np.column_stack([cx + r * np.cos(a), cy + 0.8 * r * np.sin(a)]))
    return hulls


def median_s(fn: Callable[[], object], repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    args = parser.parse_args()
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"compiled kernel: {compiled()}\n")
    print("| objects | ordered pairs | relate_objects (s) | of which forces (s) | growth |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    last: tuple[int, float] | None = None
    for n in (10, 25, 50, 100):
        hulls = scene(n)
        names = [f"object {k}" for k in range(n)]
        repeat = (3 if args.quick else 7) if n <= 50 else (2 if args.quick else 5)
        total = median_s(lambda h=hulls, nm=names: relate_objects(h, names=nm), repeat)
        forces_only = median_s(
            lambda h=hulls: f0_f2_pairs([prepare(p, "o") for p in h], directions=180), repeat
        )
        growth = "" if last is None else f"{math.log(total / last[1]) / math.log(n / last[0]):.2f}"
        print(f"| {n} | {n * (n - 1)} | {total:.3f} | {forces_only:.3f} | {growth} |")
        last = (n, total)
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
