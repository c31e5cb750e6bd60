"""What the GIL costs the pipeline's objects stage when the other thread runs Python.

The objects stage (``scene_objects``, geometry first) of the first ``--scenes`` bench scenes
(``bench_pipeline.py``'s dataset), made once with ``describe_scene``, is timed again and
again in this thread: alone, beside a thread multiplying matrices (BLAS, one thread: no GIL,
only the CPU shared) and beside a thread running a Python loop (the GIL shared), each with
the interpreter's default 5 ms switch interval and with the pipeline's
``pipeline_threads.GIL_SLICE``. Runs are interleaved; medians of wall and this thread's CPU.

Each NumPy or OpenCV call lets the GIL go and must take it back; beside a thread running
Python that waits for the end of the other's slice (the convoy effect), which the shorter
slice shortens.

Run::

    python benchmarks/gil_slices.py [--scenes 6] [--runs 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from bench_pipeline import dataset, load_scene, scenes_of
from scenespeak import pipeline
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.scene_objects import scene_objects
from scenespeak.pipeline_threads import GIL_SLICE, geometry_for


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=6)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "scenespeak-bench")
    args = ap.parse_args(argv)
    root, db_path = dataset(args.cache, 12, 0, False)
    with ObjectDatabase.open(db_path, readonly=True) as db:
        id_to_label = {o.id: o.label for o in db.list_objects()}
        made = [pipeline.describe_scene(*load_scene(s), db) for s in scenes_of(root)]
    made = made[: args.scenes]
    opts = pipeline.PipelineOptions()
    geos = [geometry_for(d.left.shape[:2], d.stereo, opts.strategy, d.left) for d in made]

    def stage() -> None:
        for d, g in zip(made, geos, strict=True):
            scene_objects(
                (d.left, d.right), d.stereo, d.labelling, id_to_label, opts.strategy,
                opts.objects, g,
            )  # fmt: skip

    stop = threading.Event()
    big = np.random.default_rng(0).random((600, 600))

    def python_loop() -> None:
        while not stop.is_set():
            total = 0
            for i in range(1000):
                total += i

    def blas_loop() -> None:
        while not stop.is_set():
            big @ big

    others = {"alone": None, "beside BLAS": blas_loop, "beside Python": python_loop}
    before = sys.getswitchinterval()
    results: dict[tuple[str, float], list[tuple[float, float]]] = {}
    try:
        with threadpool_limits(1):
            for _ in range(args.runs):
                for name, other in others.items():
                    for interval in (before, GIL_SLICE):
                        sys.setswitchinterval(interval)
                        stop.clear()
                        th = threading.Thread(target=other) if other else None
                        if th:
                            th.start()
                        t0, c0 = time.perf_counter(), time.thread_time()
                        stage()
                        got = (time.perf_counter() - t0, time.thread_time() - c0)
                        stop.set()
                        if th:
                            th.join()
                        results.setdefault((name, interval), []).append(got)
    finally:
        sys.setswitchinterval(before)
    print(f"objects stage of {len(made)} scenes, median of {args.runs} runs")
    for (name, interval), rows in results.items():
        wall = 1000 * statistics.median(r[0] for r in rows)
        cpu = 1000 * statistics.median(r[1] for r in rows)
        print(f"  {name:<14} switch interval {1000 * interval:4.1f} ms: {wall:7.1f} ms wall, "
              f"{cpu:6.1f} ms CPU")  # fmt: skip


if __name__ == "__main__":
    main()
