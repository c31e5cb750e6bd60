"""Where the wall time of ``describe_scene`` goes: a timeline of both threads' phases.

On the scenes of ``bench_pipeline.py``'s dataset (or ``--dataset``), this runs
``describe_scene`` ``--repeat`` times per scene with the functions it calls wrapped, in this
process only, by a recorder: SIFT of each image, the pair-order check, the left image's plain
background (``plain_for``), the stereo stage (``stereo.stereo_points``), geometry first's plane
and segments (``geometry_for``), the first labelling (``ObjectDatabase.label``), the finer
search (``look_closer``) and its boxes (``finer._look``), objects (``scene_objects``) and each
detection's (``scene_regions._known_object``, in either thread), the colour naming and the
keypoints' veto, the relations (``_relate_all``) and the summary.

For each phase it prints, per thread, the median start and end (ms from the call's start),
wall, and how the calling thread spent that wall (Linux's ``/proc/thread-self/schedstat``):
on a CPU, runnable but waiting for one (the machine's load), and blocked (neither: waiting
for the GIL, a lock or a future). On an idle machine the second is near 0; the third is what
the two threads cost each other. OpenCV's and FAISS's own worker threads are not in these
columns.

``--slices`` compares the pipeline with and without short GIL slices around the call
(``pipeline_threads.short_gil_slices``, 0.5 ms instead of 5), run after run in one process.
``describe_scene`` no longer sets them itself: idle (2 Dec 19:26 UTC) two A/B runs gave 148
vs 146 ms and 132 vs 139 ms (on vs off), no measurable gain for a process-wide setting.

Run::

    python benchmarks/pipeline_timeline.py [--repeat 3] [--scenes 0 1 2] [--dataset DIR]
    python benchmarks/pipeline_timeline.py --slices on off
"""

from __future__ import annotations

import argparse
import functools
import statistics
import tempfile
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from contextlib import nullcontext
from pathlib import Path
from typing import Any

from bench_pipeline import dataset, load_scene, scenes_of
from scenespeak import pipeline, pipeline_threads
from scenespeak.perception import plausibility, scene_regions, stereo
from scenespeak.perception.recognition import ObjectDatabase, finer
from scenespeak.spatial import language

#: (owner, attribute, phase name) of the calls recorded.
PHASES: tuple[tuple[Any, str, str], ...] = (
    (pipeline, "detect", "SIFT"),
    (pipeline, "plain_for", "plain background"),
    (plausibility, "check_pair_order", "pair-order check"),
    (stereo, "stereo_points", "stereo_points"),
    (pipeline_threads, "geometry_for", "plane + segments"),
    (ObjectDatabase, "label", "label (first)"),
    (ObjectDatabase, "look_closer", "finer search"),
    (finer, "_look", "  finer box"),
    (pipeline, "scene_objects", "scene_objects"),
    (scene_regions, "_known_object", "  detection object"),
    (pipeline, "name_unknown_objects", "colour naming"),
    (pipeline, "closer_look", "closer look"),
    (pipeline, "_relate_all", "relations"),
    (language, "summarize_scene", "summary"),
    (pipeline_threads.Guess, "adopt", "adopt guess"),
)


def _schedstat() -> tuple[float, float]:
    """This thread's time on a CPU and waiting for one, in seconds (0, 0 where unknown)."""
    try:
        with open("/proc/thread-self/schedstat") as fh:
            on_cpu, waiting, _slices = fh.read().split()
    except (OSError, ValueError):
        return 0.0, 0.0
    return int(on_cpu) / 1e9, int(waiting) / 1e9


class Recorder:
    """Start, end, CPU and run-queue wait of every recorded call, from ``t0``."""

    def __init__(self) -> None:
        self.t0 = time.perf_counter()
        self.calls: list[tuple[str, str, float, float, float, float]] = []
        self._lock = threading.Lock()

    def wrap(self, name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        """``fn`` recording each of its calls as phase ``name``."""

        @functools.wraps(fn)
        def recorded(*args: Any, **kwargs: Any) -> Any:
            start, (cpu0, wait0) = time.perf_counter(), _schedstat()
            try:
                return fn(*args, **kwargs)
            finally:
                end, (cpu1, wait1) = time.perf_counter(), _schedstat()
                main = threading.current_thread() is threading.main_thread()
                with self._lock:
                    self.calls.append(
                        (
                            name,
                            "main" if main else "worker",
                            start - self.t0,
                            end - self.t0,
                            cpu1 - cpu0,
                            wait1 - wait0,
                        )
                    )

        return recorded


Table = dict[tuple[str, str], list[tuple[float, float, float, float, float]]]


def _collect(rec: Recorder, table: Table) -> None:
    """One run's calls into ``table``: per (phase, thread) first start, last end, summed wall,
    CPU and run-queue wait."""
    runs: dict[tuple[str, str], list[float]] = {}
    for name, thread, start, end, cpu, wait in rec.calls:
        row = runs.setdefault((name, thread), [start, end, 0.0, 0.0, 0.0])
        row[0], row[1] = min(row[0], start), max(row[1], end)
        row[2] += end - start
        row[3] += cpu
        row[4] += wait
    for key, (s, e, w, c, q) in runs.items():
        table[key].append((s, e, w, c, q))


def _print(table: Table, totals: list[float], title: str) -> None:
    print(f"\n{title}")
    head = f"{'phase':<20}{'thread':<8}{'calls':>6}{'start':>8}{'end':>8}{'wall':>8}"
    print(head + f"{'cpu':>8}{'runq':>8}{'blocked':>9}")
    for key in sorted(table, key=lambda k: statistics.median(r[0] for r in table[k])):
        rows = table[key]
        s, e, w, c, q = (1000 * statistics.median(r[i] for r in rows) for i in range(5))
        blocked = 1000 * statistics.median(r[2] - r[3] - r[4] for r in rows)
        print(
            f"{key[0]:<20}{key[1]:<8}{len(rows):>6}{s:8.1f}{e:8.1f}{w:8.1f}{c:8.1f}{q:8.1f}"
            f"{blocked:9.1f}"
        )
    print(f"whole describe_scene: median {1000 * statistics.median(totals):.1f} ms")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenes", type=int, nargs="*", help="scene indices (default: all)")
    ap.add_argument("--slices", nargs="+", choices=["on", "off"], default=["on"])
    ap.add_argument("--dataset", type=Path)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "scenespeak-bench")
    args = ap.parse_args(argv)
    if args.dataset is not None:
        root, db_path = args.dataset, args.dataset / "objects.db"
    else:
        root, db_path = dataset(args.cache, 12, 0, False)
    scenes = scenes_of(root)
    if args.scenes:
        scenes = [scenes[i] for i in args.scenes]
    rec = Recorder()
    for owner, attr, name in PHASES:
        setattr(owner, attr, rec.wrap(name, getattr(owner, attr)))
    slices = {"on": pipeline_threads.short_gil_slices, "off": nullcontext}
    tables: dict[str, Table] = {mode: defaultdict(list) for mode in args.slices}
    totals: dict[str, list[float]] = {mode: [] for mode in args.slices}
    with ObjectDatabase.open(db_path, readonly=True) as db:
        pipeline.describe_scene(*load_scene(scenes[0]), db)  # warm up
        for scene in scenes:
            left, right, rig = load_scene(scene)
            for k in range(args.repeat):
                modes = args.slices if k % 2 == 0 else args.slices[::-1]
                for mode in modes:
                    rec.calls.clear()
                    rec.t0 = t0 = time.perf_counter()
                    with slices[mode]():  # around the call: the interval is the process's
                        pipeline.describe_scene(left, right, rig, db)
                    totals[mode].append(time.perf_counter() - t0)
                    _collect(rec, tables[mode])
    n = len(scenes) * args.repeat
    for mode in args.slices:
        title = f"short GIL slices {mode}: median over {len(scenes)} scenes x {args.repeat} runs"
        _print(tables[mode], totals[mode], f"{title} ({n} calls; ms from the call's start)")


if __name__ == "__main__":
    main()
