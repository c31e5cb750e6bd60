"""What ``relate_objects`` says on fixed scenes, saved and checked (the same floats).

``--write FILE`` relates every ordered pair of each scene below and saves, per scene, the
number of pairs and the SHA-256 of the results: every relation's ``to_dict()`` (floats as
``repr``, so every bit counts), its type, and every histogram's bytes, hybrid flag,
intersection and areas. ``--check FILE`` recomputes them and prints every scene whose
results differ; it exits 1 if any does. The scenes: ``bench_relate.py``'s floors of 10, 25,
50 and 100 convex hulls; the same hulls grown about their centres until many overlap, touch
or nest (the hybrid F02, surrounds), with heights (vertical relations); and every layout of
``spatial.layouts`` among a few other objects, with its heights. Both force kernels are
run (``SCENESPEAK_NUMBA=always`` and ``never``: they agree to 1e-9, not bit for bit, so each
has its own hashes). ``benchmarks/relate_golden.json`` holds main at b0e086b: the results of
e1d715b (before issue 16 session 7 changed ``relate_objects``; identical on all 56 up to
70a53c5) but for the compiled kernel's on layouts 3 and 15 (non-convex shapes), which the
non-convex walk of fd70a6f changed within its 1e-9. The hashes are of one machine's floats (its
BLAS): write the file again on another kind of machine, from the old commit.

Run::

    python benchmarks/relate_golden.py --check benchmarks/relate_golden.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_relate import scene
from scenespeak.language import relate_objects
from scenespeak.spatial.layouts import LAYOUTS, disc, rect

GOLDEN = Path(__file__).resolve().parent / "relate_golden.json"

Scene = tuple[list[NDArray[np.float64]], list[str], list[NDArray[np.float64]] | None]


def scenes() -> Iterator[tuple[str, Scene]]:
    """(name, (hulls, names, heights)) of every fixed scene."""
    for n in (10, 25, 50, 100):
        hulls = scene(n)
        yield f"floor-{n}", (hulls, [f"object {k}" for k in range(n)], None)
    rng = np.random.default_rng(7)
    for n in (12, 40):
        grown = []
        for k, h in enumerate(scene(n, seed=n)):
            c = h.mean(axis=0)
            # Every third hull grown 2.5-6 times: overlaps, touches and nests among them.
            grown.append((h - c) * (rng.uniform(2.5, 6.0) if k % 3 == 0 else 1.0) + c)
        heights = [
            float(rng.choice([0.0, 0.0, 0.12, 0.5])) + rng.uniform(0.0, 0.12, 8) for _ in grown
        ]
        yield f"crowded-{n}", (grown, [f"thing {k}" for k in range(n)], heights)
    for index, lay in enumerate(LAYOUTS):
        hulls = [lay.a, lay.b, *(h for _, h in lay.others), disc(0.6, 1.4, 0.05)]
        hulls.append(rect(-1, 2, -0.8, 2.3))
        names = [lay.argument, lay.referent, *(k for k, _ in lay.others), "unknown object 1"]
        names.append("tray")
        heights = None
        if lay.a_heights is not None and lay.b_heights is not None:
            rest = [np.linspace(0.0, 0.1, 5)] * (len(hulls) - 2)
            heights = [lay.a_heights, lay.b_heights, *rest]
        yield f"layout-{index}", (hulls, names, heights)


def digest(found: list[Any]) -> str:
    """SHA-256 of the results: each relation's dict (floats as repr) and histograms' bytes."""
    sha = hashlib.sha256()
    for rel, hist in found:
        sha.update(type(rel).__name__.encode() + type(hist).__name__.encode())
        sha.update(json.dumps(rel.to_dict(), sort_keys=False).encode())
        sha.update(repr(rel).encode())
        sha.update(hist.f0.tobytes() + hist.f2.tobytes())
        sha.update(repr((hist.hybrid, hist.intersection, hist.area_a, hist.area_b)).encode())
    return sha.hexdigest()


def compute() -> dict[str, dict[str, Any]]:
    """{kernel: {scene: {"pairs": ..., "sha256": ...}}} for both force kernels."""
    out: dict[str, dict[str, Any]] = {}
    for kernel in ("always", "never"):
        os.environ["SCENESPEAK_NUMBA"] = kernel  # read at every sweep
        out[kernel] = {}
        for name, (hulls, names, heights) in scenes():
            found = relate_objects(hulls, names=names, heights=heights)
            out[kernel][name] = {"pairs": len(found), "sha256": digest(list(found))}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write", type=Path, help="save the hashes to this file")
    group.add_argument("--check", type=Path, help="compare with the hashes in this file")
    args = parser.parse_args()
    got = compute()
    if args.write:
        args.write.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
        print(f"wrote {sum(len(v) for v in got.values())} scenes to {args.write}")
        return
    want = json.loads(args.check.read_text())
    bad = [
        f"{kernel} {name}"
        for kernel, table in want.items()
        for name, entry in table.items()
        if got.get(kernel, {}).get(name) != entry
    ]
    for line in bad:
        print(f"differs: {line}")
    total = sum(len(v) for v in want.values())
    print(f"{total - len(bad)} of {total} scenes the same")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
