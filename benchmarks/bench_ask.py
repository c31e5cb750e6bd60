"""How fast ``ask`` answers on a saved scene (issue 13: ≤ 50 ms, no image work).

Usage:

    python benchmarks/bench_ask.py SCENE.json [--repeat 30]

``SCENE.json`` is a saved ``scenespeak describe --format json`` output (with or without
``--viewer``). Two figures, medians over ``--repeat`` runs, side by side in one run:

- **library**: ``load_scene(path)`` + ``ask(question, scene)`` in this process, per question;
- **process**: the whole command ``scenespeak ask QUESTION --scene SCENE.json`` (interpreter
  start, imports, reading, answering), wall clock and CPU (user + system) of the child.

Prints the load (``uptime``) first: this machine is shared.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

QUESTIONS = (
    "where is the {a}?",
    "is the {a} to the left of the {b}?",
    "what is near the {b}?",
    "which object is closest to me?",
    "what do you see?",
    "where is the cup?",
)


def _questions(path: Path) -> list[str]:
    d = json.loads(path.read_text())
    names = [o.get("name", o["label"]) for o in d["objects"]] or ["mug"]
    a, b = names[0], names[-1]
    return [q.format(a=a, b=b) for q in QUESTIONS]


def library(path: Path, repeat: int) -> dict[str, float]:
    """Median milliseconds of load + ask per question, in this process."""
    from scenespeak.spatial.dialogue import ask, load_scene

    out = {}
    for q in _questions(path):
        ask(q, load_scene(path))  # warm: imports and any lazy viewer computation's imports
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            ask(q, load_scene(path))
            times.append(time.perf_counter() - t0)
        out[q] = 1000 * statistics.median(times)
    return out


def process(path: Path, repeat: int) -> dict[str, tuple[float, float]]:
    """Median milliseconds (wall, CPU user + system) of the whole ``scenespeak ask --scene``
    command per question."""
    out = {}
    for q in _questions(path)[:2]:
        walls, cpus = [], []
        for _ in range(max(3, repeat // 3)):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            subprocess.run(
                [sys.executable, "-m", "scenespeak", "ask", q, "--scene", str(path)],
                check=True,
                capture_output=True,
                env=os.environ.copy(),
            )
            walls.append(time.perf_counter() - t0)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        out[q] = (1000 * statistics.median(walls), 1000 * statistics.median(cpus))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("scene", type=Path)
    p.add_argument("--repeat", type=int, default=30)
    a = p.parse_args(argv)
    print("load:", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    lib = library(a.scene, a.repeat)
    proc = process(a.scene, a.repeat)
    print(f"scene {a.scene} ({a.scene.stat().st_size // 1024} KiB)")
    print("| question | library ms (median) | whole process ms, wall / CPU (median) |")
    print("| --- | --- | --- |")
    for q, ms in lib.items():
        pm = f"{proc[q][0]:.0f} / {proc[q][1]:.0f}" if q in proc else "–"
        print(f"| {q} | {ms:.2f} | {pm} |")
    print("load:", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    return 0


if __name__ == "__main__":
    sys.exit(main())
