"""The working memory on generated sequences: id stability, flicker and events.

Runs ``scenespeak.live.stream.SceneStream`` over every sequence of the chosen seeds (default:
the FROZEN evaluation set, seeds 200 and 201, every script, 24 frames at 640×480) and prints
the measures of ``scenespeak.tools.live_evaluation`` per sequence and in total (targets of
issue 14: ids stable on ≥ 99 % of frame-to-frame matches; no flicker on static stretches; every
scripted event within 3 frames; no false events).

Run::

    python benchmarks/eval_watch.py                      # frozen set (report this)
    python benchmarks/eval_watch.py --seeds 100 101      # tuning set
    python benchmarks/eval_watch.py --json out.json
    python benchmarks/eval_watch.py --rgbd               # RGB-D + masks (cache/rgbd)

The data are generated once into ``--cache`` (``benchmarks/livecache.py``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from livecache import DEFAULT_CACHE, FROZEN_SEEDS, database, sequences
from scenespeak.tools.live_evaluation import run_sequence, score_sequence, summarize


def run_rgbd_sequence(seq) -> tuple[list[dict], float]:
    """The sequence's RGB-D + masks frames (left camera: ``NNNN/depth.png``, ``masks.png``,
    ``labels.json``) through ``RGBDStream``; the JSON lines and the seconds in ``process``."""
    import time

    from scenespeak.live.rgbd_stream import RGBDStream
    from scenespeak.perception.depth import load_depth
    from scenespeak.perception.intrinsics import load_intrinsics
    from scenespeak.perception.masks import load_instances, load_labels

    stream = RGBDStream(load_intrinsics(Path(seq.root) / "intrinsics.json"))
    lines, spent = [], 0.0
    for k in range(len(seq.frames)):
        d = Path(seq.root) / f"{k:04d}"
        depth, masks = load_depth(d / "depth.png"), load_instances(d / "masks.png")
        labels = load_labels(d / "labels.json")
        t0 = time.perf_counter()
        frame = stream.process(depth, masks, labels, time_s=k / 30.0)
        spent += time.perf_counter() - t0
        lines.append(frame.to_dict())
    return lines, spent


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(FROZEN_SEEDS))
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--cache", type=Path, default=DEFAULT_CACHE)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument(
        "--rgbd", action="store_true", help="RGB-D + masks frames through RGBDStream (no database)"
    )
    args = ap.parse_args(argv)
    cache = args.cache / "rgbd" if args.rgbd else args.cache
    db = None if args.rgbd else database(args.cache)
    seqs = sequences(cache, tuple(args.seeds), args.frames)
    scores = []
    print(f"{'sequence':12} {'ids kept':>10} {'flicker':>8} {'static chg':>10} "
          f"{'events':>7} {'false':>6}  delays   missed / false")  # fmt: skip
    for seq in seqs:
        lines, _ = run_rgbd_sequence(seq) if args.rgbd else run_sequence(seq, db)
        s = score_sequence(seq, lines)
        scores.append(s)
        print(
            f"{s.name:12} {s.id_kept:>4}/{s.id_matches:<5} {s.flickers:>8} {s.static_changes:>10} "
            f"{s.reported:>3}/{s.scripted:<3} {s.false_events:>6}  {s.delays}  "
            f"{[(e['kind'], e['frame']) for e in s.missed]} / "
            f"{[(e['kind'], e['frame']) for e in s.false]}",
            flush=True,
        )
    total = summarize(scores)
    print(json.dumps(total, indent=1))
    if args.json is not None:
        args.json.write_text(
            json.dumps({"total": total, "sequences": [s.__dict__ for s in scores]}, indent=1)
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
