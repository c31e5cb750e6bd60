"""Where the wall time of ``describe_scene`` goes: a timeline of both threads' phases.

On the scenes of ``bench_pipeline.py``'s dataset (or ``--dataset``), this runs
``describe_scene`` ``--repeat`` times per scene with the functions it calls wrapped, in this
process only, by a recorder (``points_timeline.Recorder``): SIFT of each image, the pair-order
check, the left image's plain background (``plain_for``), the stereo stage
(``stereo.stereo_points``), geometry first's plane and segments (``geometry_for``), the first
labelling (``ObjectDatabase.label``), the finer search
(``look_closer``) and its boxes (``finer._look``), objects (``scene_objects``) and each
detection's (``scene_regions._known_object``, in either thread), the colour
naming and the keypoints' veto, the relations (``_relate_all``) and the summary. For each
phase it prints, per thread, the median start and end (ms from the call's start), wall and
the calling thread's CPU; per scene the whole call's wall and which thread finished last.

Run::

    python benchmarks/pipeline_timeline.py [--repeat 3] [--scenes 0 1 2] [--dataset DIR]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from bench_pipeline import dataset, load_scene, scenes_of
from points_timeline import Recorder
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
    (pipeline, "_keypoint_veto", "keypoint veto"),
    (pipeline, "_relate_all", "relations"),
    (language, "summarize_scene", "summary"),
    (pipeline_threads.Guess, "adopt", "adopt guess"),
)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenes", type=int, nargs="*", help="scene indices (default: all)")
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
    # per (phase, thread): lists over runs of start, end, wall, cpu (summed within a run)
    table: dict[tuple[str, str], list[tuple[float, float, float, float]]] = defaultdict(list)
    totals: list[float] = []
    with ObjectDatabase.open(db_path, readonly=True) as db:
        first = load_scene(scenes[0])
        pipeline.describe_scene(*first, db)  # warm up
        for scene in scenes:
            left, right, rig = load_scene(scene)
            walls = []
            for _ in range(args.repeat):
                rec.calls.clear()
                t0 = time.perf_counter()
                rec.t0 = t0
                desc = pipeline.describe_scene(left, right, rig, db)
                wall = time.perf_counter() - t0
                walls.append(wall)
                runs: dict[tuple[str, str], list[float]] = {}
                for name, thread, start, end, cpu in rec.calls:
                    row = runs.setdefault((name, thread), [start, end, 0.0, 0.0])
                    row[0], row[1] = min(row[0], start), max(row[1], end)
                    row[2] += end - start
                    row[3] += cpu
                for key, (s, e, w, c) in runs.items():
                    table[key].append((s, e, w, c))
            med = statistics.median(walls)
            totals.append(med)
            last = max(rec.calls, key=lambda c: c[3])
            print(
                f"{scene.name}: {1000 * med:6.1f} ms wall (median of {args.repeat}); "
                f"objects {len(desc.objects)}; detections "
                f"{len(desc.labelling.detections)} detections; "
                f"last phase: {last[0]} ({last[1]})"
            )
    n = len(scenes) * args.repeat
    print(f"\nmedian over {len(scenes)} scenes x {args.repeat} runs (ms from the call's start)")
    print(f"{'phase':<20}{'thread':<8}{'calls':>6}{'start':>8}{'end':>8}{'wall':>8}{'cpu':>8}")
    for key in sorted(table, key=lambda k: statistics.median(r[0] for r in table[k])):
        rows = table[key]
        s, e, w, c = (1000 * statistics.median(r[i] for r in rows) for i in range(4))
        print(f"{key[0]:<20}{key[1]:<8}{len(rows):>6}{s:8.1f}{e:8.1f}{w:8.1f}{c:8.1f}")
    print(f"whole describe_scene: median {1000 * statistics.median(totals):.1f} ms over {n} runs")


if __name__ == "__main__":
    main()
