"""Start-up of the command line and of the compiled force kernel, as whole processes.

* ``scenespeak --help`` (target <= 0.15 s; from the help cache, warmed first, and with the
  cache off) and ``python -c pass`` (the interpreter alone);
* ``scenespeak ask QUESTION --scene FILE`` for each ``--scene`` given (target <= 0.3 s; the quick
  path of ``cli/_quick.py``), and the same line through the full Typer command line
  (``scenespeak.cli._full.main``) beside it;
* the first force histogram of a process: by default (``SCENESPEAK_NUMBA=auto``: the NumPy
  reference until the process's work pays for loading Numba), with Numba forced
  (``SCENESPEAK_NUMBA=always``) and its on-disk cache warm or cold (a fresh
  ``NUMBA_CACHE_DIR``: the kernel is compiled), and without Numba (``SCENESPEAK_NO_NUMBA=1``).

Medians of several runs of each, interleaved, so that they share the machine's load.

Run::

    python benchmarks/bench_startup.py [--repeat 7] [--scene scene.json [--scene viewer.json]]
        [--only-cli]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

FIRST_HISTOGRAM = (
    "import numpy as np\n"
    "from scenespeak.spatial.forces import force_histograms\n"
    "sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])\n"
    "force_histograms(sq + [3.0, 0.0], sq)\n"
)


def run_s(cmd: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """(wall-clock, CPU user + system) seconds of one process.

    On a shared machine the wall clock mostly measures the queue for a core; the process's
    own CPU time is what it would take on an idle core (to within cache effects).
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env={**os.environ, **(env or {})})
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument(
        "--scene", action="append", default=[], help="a saved scene for `ask --scene` (repeat)"
    )
    parser.add_argument(
        "--only-cli", action="store_true", help="only the command-line cases (no histograms)"
    )
    args = parser.parse_args()
    py = sys.executable
    cases: dict[str, tuple[list[str], dict[str, str] | None]] = {
        "python -c pass": ([py, "-c", "pass"], None),
        "scenespeak --help": ([py, "-m", "scenespeak", "--help"], None),
        "scenespeak --help, help cache off (renders with Typer)": (
            [py, "-m", "scenespeak", "--help"],
            {"SCENESPEAK_NO_HELP_CACHE": "1"},
        ),
        "first histogram, default (auto: reference for small work)": (
            [py, "-c", FIRST_HISTOGRAM],
            {"SCENESPEAK_NUMBA": "auto"},
        ),
        "first histogram, Numba forced, cache warm": (
            [py, "-c", FIRST_HISTOGRAM],
            {"SCENESPEAK_NUMBA": "always"},
        ),
        "first histogram, NumPy reference (no Numba)": (
            [py, "-c", FIRST_HISTOGRAM],
            {"SCENESPEAK_NO_NUMBA": "1"},
        ),
    }
    for scene in args.scene:
        line = ["ask", "where is the mug?", "--scene", scene]
        cases[f"scenespeak ask --scene {scene}"] = ([py, "-m", "scenespeak", *line], None)
        full = f"import sys; from scenespeak.cli._full import main; sys.exit(main({line!r}))"
        cases[f"the same through the full CLI (Typer) {scene}"] = ([py, "-c", full], None)
    if args.only_cli:
        for name in [n for n in cases if "histogram" in n]:
            del cases[name]
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}\n")
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in cases}
    cold: list[tuple[float, float]] = []
    run_s([py, "-m", "scenespeak", "--help"])  # the help cache is warm
    if not args.only_cli:
        run_s([py, "-c", FIRST_HISTOGRAM], {"SCENESPEAK_NUMBA": "always"})  # warm the cache
    for _ in range(args.repeat):
        for name, (cmd, env) in cases.items():
            times[name].append(run_s(cmd, env))
    for _ in range(0 if args.only_cli else max(1, args.repeat // 3)):
        with tempfile.TemporaryDirectory() as cache:
            env = {"NUMBA_CACHE_DIR": cache, "SCENESPEAK_NUMBA": "always"}
            cold.append(run_s([py, "-c", FIRST_HISTOGRAM], env))
    if cold:
        times["first histogram, Numba cache cold (compiles)"] = cold
    print("| process | wall median (s) | wall best (s) | CPU median (s) |")
    print("| --- | ---: | ---: | ---: |")
    for name, ts in times.items():
        wall = [w for w, _ in ts]
        cpu = [c for _, c in ts]
        print(
            f"| {name} | {statistics.median(wall):.3f} | {min(wall):.3f} | "
            f"{statistics.median(cpu):.3f} |"
        )
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
