"""Benchmark of ``language.relate_objects`` on scenes of n objects (every ordered pair).

Prints, for n = 10, 25, 50, 100 convex hulls of 8-22 vertices (5-25 cm across, laid out on a
floor like the pipeline's objects), the median (and best) time of ``relate_objects`` and its
parts: preparing and sweeping all pairs (``forces.prepare`` + ``forces.f0_f2_pairs``) and the
rest (overlaps, degrees of truth, rule base, sentences), what a caller pays who has every
result object made (``list(relate_objects(...))``: ``relate_objects`` returns a sequence whose
objects are made on its first read) and who reads every result (every relation's
``to_dict()``); the results are freed inside the timer in all. The sizes are timed in
rounds (each size once per round), so that a busy machine's swings fall on all sizes alike.
The growth exponent between consecutive sizes is ``log(t2 / t1) / log(n2 / n1)`` (2 means
time grows as the number of pairs). For the smaller scenes it also times the per-pair path
that ``relate_objects`` replaces and is tested against (``pair_histograms`` +
``relations_of_pair`` for each pair), in the same run, and checks that both say the same
sentences. The peak memory of one call (``tracemalloc``, results included) is measured in a
separate call (every result made). The speed-up is the per-pair path's time over the time with
every result made.

Run::

    python benchmarks/bench_relate.py              # a few minutes on a busy machine
    python benchmarks/bench_relate.py --quick      # fewer repeats
    python benchmarks/bench_relate.py --clock cpu  # process CPU time instead of wall clock
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time
import tracemalloc
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from scenespeak.language import pair_histograms, relate_objects, relations_of_pair
from scenespeak.spatial.forces import compiled, f0_f2_pairs, prepare

#: The issue's target for 100 objects (seconds).
TARGET_S = 0.2


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


def per_pair(hulls: list[NDArray[np.float64]], names: list[str]) -> list[str]:
    """The sentences of every ordered pair through the per-pair functions (the reference)."""
    found: dict[tuple[int, int], str] = {}
    for i in range(len(hulls)):
        for j in range(i + 1, len(hulls)):
            pair = pair_histograms(hulls[i], hulls[j])
            ab, ba = relations_of_pair(pair, argument=names[i], referent=names[j])
            found[i, j], found[j, i] = ab.sentence, ba.sentence
    n = len(hulls)
    return [found[i, j] for i in range(n) for j in range(n) if i != j]


def made_all(hulls: list[NDArray[np.float64]], names: list[str]) -> int:
    """``relate_objects`` with every result object made (its first read); freed before it
    returns."""
    return len(list(relate_objects(hulls, names=names)))


def read_all(hulls: list[NDArray[np.float64]], names: list[str]) -> int:
    """``relate_objects``, then every relation's ``to_dict()`` (what a caller that reads every
    result, e.g. for JSON, pays); the dicts and results are freed before it returns."""
    return len([rel.to_dict() for rel, _ in relate_objects(hulls, names=names)])


def median_s(fn: Callable[[], object], repeat: int, clock: Callable[[], float]) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return statistics.median(times)


def timed(fn: Callable[[], object], clock: Callable[[], float]) -> float:
    t0 = clock()
    fn()
    return clock() - t0


def peak_mb(fn: Callable[[], object]) -> float:
    """Peak traced memory (MB) of one call, its result included."""
    tracemalloc.start()
    try:
        result = fn()
        peak = tracemalloc.get_traced_memory()[1]
        del result
    finally:
        tracemalloc.stop()
    return peak / 1e6


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    parser.add_argument("--clock", choices=["wall", "cpu"], default="wall")
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 25, 50, 100])
    parser.add_argument(
        "--per-pair-up-to", type=int, default=25, help="time the per-pair path up to this n"
    )
    args = parser.parse_args()
    # Compiled from the first scene (by default a process runs the NumPy reference until its
    # work pays for loading Numba, which would switch kernels in the middle of the sizes).
    os.environ.setdefault("SCENESPEAK_NUMBA", "always")
    clock = time.perf_counter if args.clock == "wall" else time.process_time
    print(f"load average before: {load()}")
    print(f"compiled kernel: {compiled()}; clock: {args.clock}; medians\n")
    print(
        "| objects | ordered pairs | relate_objects, median (best) (s) | of which forces (s) "
        "| rest (s) | every result made (s) | with every to_dict() (s) "
        "| growth | per-pair path (s) | speed-up | peak memory (MB) | per pair (kB) |"
    )
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    scenes = {n: (scene(n), [f"object {k}" for k in range(n)]) for n in args.sizes}
    # Rounds: every size once per round, so that the load's swings fall on all sizes alike.
    rounds = 3 if args.quick else 7
    times: dict[int, list[tuple[float, float, float, float]]] = {n: [] for n in args.sizes}
    for hulls, names in scenes.values():
        relate_objects(hulls, names=names)  # warm: imports, kernel, caches
    for _ in range(rounds):
        for n, (hulls, names) in scenes.items():
            total = timed(lambda h=hulls, nm=names: relate_objects(h, names=nm), clock)
            forces_only = timed(
                lambda h=hulls: f0_f2_pairs([prepare(p, "o") for p in h], directions=180), clock
            )
            made = timed(lambda h=hulls, nm=names: made_all(h, nm), clock)
            read = timed(lambda h=hulls, nm=names: read_all(h, nm), clock)
            times[n].append((total, forces_only, made, read))
    last: tuple[int, float] | None = None
    first: tuple[int, float] | None = None
    for n, (hulls, names) in scenes.items():
        total = statistics.median(t for t, _, _, _ in times[n])
        best = min(t for t, _, _, _ in times[n])
        forces_only = statistics.median(f for _, f, _, _ in times[n])
        made = statistics.median(m for _, _, m, _ in times[n])
        read = statistics.median(r for _, _, _, r in times[n])
        reference, ratio = "", ""
        if n <= args.per_pair_up_to:
            said = [rel.sentence for rel, _ in relate_objects(hulls, names=names)]
            assert said == per_pair(hulls, names), "relate_objects and the per-pair path differ"
            slow = median_s(
                lambda h=hulls, nm=names: per_pair(h, nm), 1 if args.quick else 3, clock
            )
            reference, ratio = f"{slow:.3f}", f"{slow / made:.0f}×"  # both make every result
        memory = peak_mb(lambda h=hulls, nm=names: list(relate_objects(h, names=nm)))
        growth = "" if last is None else f"{math.log(total / last[1]) / math.log(n / last[0]):.2f}"
        print(
            f"| {n} | {n * (n - 1)} | {total:.3f} ({best:.3f}) | {forces_only:.3f} "
            f"| {total - forces_only:.3f} | {made:.3f} | {read:.3f} | {growth} | {reference} "
            f"| {ratio} "
            f"| {memory:.1f} "
            f"| {1e3 * memory / max(n * (n - 1), 1):.1f} |"
        )
        first = first or (n, total)
        last = (n, total)
    if first is not None and last is not None and last[0] > first[0]:
        overall = math.log(last[1] / first[1]) / math.log(last[0] / first[0])
        print(f"\ngrowth {first[0]} -> {last[0]} objects: n^{overall:.2f}")
    if last is not None and last[0] == 100:
        verdict = "met" if last[1] <= TARGET_S else "NOT met"
        print(f"target: 100 objects <= {TARGET_S} s: {verdict} ({last[1]:.3f} s, median)")
    print(f"load average after: {load()}")


if __name__ == "__main__":
    main()
