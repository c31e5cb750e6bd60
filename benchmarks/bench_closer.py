"""What the closer look at unknown objects costs (``perception/recognition/closer.py``).

Over the scenes of a generated dataset (its own objects learnt, no masks), interleaved in one
process, one thread per scene (``threads=1``, so the CPU clock counts the whole call):

- ``describe_scene`` with the closer look (the default) and without it
  (``LabelOptions(closer=False)``), CPU seconds per call;
- ``closer_look`` alone on the objects the scene had without it.

Prints the medians over the scenes (each scene's median over ``--runs`` runs), the ratio of the
whole call with / without it, and how many unknown objects were looked at.

Run::

    python benchmarks/bench_closer.py /tmp/sets/tune40 --scenes 20 --runs 3
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np

from scenespeak.perception.calibration import load_rig
from scenespeak.perception.features import load_image
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.recognition.closer import closer_look
from scenespeak.perception.recognition.options import LabelOptions
from scenespeak.pipeline import PipelineOptions, database_from_dataset, describe_scene
from scenespeak.tools.evaluation import find_scenes


def _cpu(fn: Callable[[], object]) -> float:
    """CPU seconds of one call."""
    t0 = time.process_time()
    fn()
    return time.process_time() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("dataset", type=Path)
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    on = PipelineOptions(threads=1)
    off = dataclasses.replace(on, labels=LabelOptions(closer=False))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        db_path = Path(tmp) / "objects.db"
        database_from_dataset(args.dataset, db_path)
        with ObjectDatabase.open(db_path, readonly=True) as db:
            look = db.labeller()
            for scene in find_scenes(args.dataset)[: args.scenes]:
                left = load_image(scene / "left.png", gray=False)
                right = load_image(scene / "right.png", gray=False)
                rig = load_rig(scene / "calib.json")
                before = describe_scene(left, right, rig, db, options=off).objects
                k = np.asarray(rig.K_left, np.float64)
                n_unknown = sum(o.label.startswith("unknown object") for o in before)
                t_on, t_off, t_look = [], [], []
                with_it = partial(describe_scene, left, right, rig, db, options=on)
                without = partial(describe_scene, left, right, rig, db, options=off)
                alone = partial(closer_look, before, left, k, look)
                for _ in range(args.runs):
                    t_on.append(_cpu(with_it))
                    t_off.append(_cpu(without))
                    t_look.append(_cpu(alone))
                rows.append(
                    (
                        statistics.median(t_on),
                        statistics.median(t_off),
                        statistics.median(t_look),
                        n_unknown,
                    )
                )
    on_m = statistics.median(r[0] for r in rows)
    off_m = statistics.median(r[1] for r in rows)
    look_m = statistics.median(r[2] for r in rows)
    ratio = statistics.median(r[0] / r[1] for r in rows)
    print(f"{len(rows)} scenes of {args.dataset}, {args.runs} runs each, CPU clock, threads=1")
    print(f"describe with the closer look    median {1000 * on_m:7.1f} ms")
    print(f"describe without it              median {1000 * off_m:7.1f} ms")
    print(f"with / without, per scene        median {ratio:7.3f}")
    print(f"closer_look alone                median {1000 * look_m:7.1f} ms")
    print(f"                                 max    {1000 * max(r[2] for r in rows):7.1f} ms")
    print(f"unknown objects looked at        total  {sum(r[3] for r in rows)}")


if __name__ == "__main__":
    main()
