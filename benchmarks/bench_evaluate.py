"""How fast is the evaluation, and what do two processes buy? Prints figures; asserts nothing.

    python benchmarks/bench_evaluate.py                 # generates 8 scenes into a temp folder
    python benchmarks/bench_evaluate.py /tmp/eval100 --repeat 1

For each worker count it runs :func:`scenespeak.tools.evaluation.evaluate` ``--repeat`` times and
prints the median wall-clock time, scenes per second, and the median per-scene time measured
inside the workers. The machine is shared: read ratios rather than absolute times.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from scenespeak.tools.evaluation import evaluate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", nargs="?", type=Path, help="dataset folder (default: make one)")
    parser.add_argument("--n", type=int, default=8, help="scenes to generate without a dataset")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        dataset = args.dataset
        if dataset is None:
            from scenespeak.tools.scenes import generate_dataset

            dataset = Path(tmp) / "scenes"
            t0 = time.perf_counter()
            generate_dataset(dataset, args.n, seed=1, pitched=False, progress=None)
            print(f"generated {args.n} scenes in {time.perf_counter() - t0:.1f} s")
        from scenespeak.pipeline import database_from_dataset

        db = Path(tmp) / "objects.db"
        t0 = time.perf_counter()
        database_from_dataset(dataset, db)
        print(f"object database learnt in {time.perf_counter() - t0:.2f} s")

        base = None
        for workers in args.workers:
            walls, inner = [], []
            for _ in range(args.repeat):
                result = evaluate(dataset, db=db, workers=workers)
                walls.append(result.wall_seconds)
                inner.append(statistics.median(result.seconds))
            wall = statistics.median(walls)
            base = base or wall
            print(
                f"workers={workers}: {result.n_scenes} scenes, wall median {wall:.2f} s "
                f"({result.n_scenes / wall:.2f} scenes/s, speed-up {base / wall:.2f}x), "
                f"per-scene median {statistics.median(inner):.3f} s, "
                f"usable {result.n_usable}/{result.n_scenes}"
            )


if __name__ == "__main__":
    main()
