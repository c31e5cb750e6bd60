"""The points of ``scenespeak points`` on every real stereo pair, saved and checked.

``--write FILE`` runs the command's stage (``cli.points._stereo_points``, the pipeline's stereo
stage) on every pair of ``../shared/data/real/stereo`` (34 Middlebury, 2 KITTI; resized as
``bench_points.py`` and ``points_crop.py`` resize them) at each size and saves, per pair and
size, the number of points and the SHA-256 of their JSON (``points_to_json``, keys sorted).
``--check FILE`` recomputes them and prints every pair whose points differ; it exits 1 if any
does. ``benchmarks/points_golden.json`` holds the points of main at 55e6388 (before issue 16
session 6 changed the stage), so a faster stage can show it gives the same points, bit for bit.

Run::

    python benchmarks/points_golden.py --check benchmarks/points_golden.json [--pairs Art]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import cv2

from scenespeak.cli.points import _stereo_points
from scenespeak.perception import calibration, stereo
from scenespeak.perception.features import load_image

#: the real data (``SCENESPEAK_REAL_DATA``, as the tests take it, or ``../shared/data/real``)
REAL = Path(
    os.environ.get("SCENESPEAK_REAL_DATA")
    or Path(__file__).resolve().parents[1] / "../shared/data/real"
)
ROOT = REAL / "stereo"
GOLDEN = Path(__file__).resolve().parent / "points_golden.json"
#: (left, right) file names of each set (the data README).
LAYOUTS = (
    ("view1.png", "view5.png"),
    ("imL.png", "imR.png"),
    ("im2.ppm", "im6.ppm"),
    ("left.png", "right.png"),
)


def pairs(names: list[str] | None = None) -> list[tuple[str, Path, Path]]:
    """(name, left, right) of every real pair (or of the named folders)."""
    out = []
    for sub in ("middeval2", "kitti2012"):
        for d in sorted((ROOT / sub).iterdir()):
            if not d.is_dir() or (names and d.name not in names):
                continue
            for left, right in LAYOUTS:
                if (d / left).exists() and (d / right).exists():
                    out.append((f"{sub}/{d.name}", d / left, d / right))
                    break
    return out


def resized(path: Path, size: tuple[int, int]) -> Any:
    """The image in colour, resized as the benchmarks resize it."""
    img = load_image(path, gray=False)
    interp = cv2.INTER_AREA if size[0] < img.shape[1] else cv2.INTER_LINEAR
    return cv2.resize(img, size, interpolation=interp)


def digest(points: Any) -> dict[str, Any]:
    """Number of points and the SHA-256 of their JSON."""
    doc = stereo.points_to_json(points)
    text = json.dumps(doc, sort_keys=True).encode()
    return {"n": len(doc["points"]), "sha256": hashlib.sha256(text).hexdigest()}


def run_one(left: Any, right: Any, size: tuple[int, int]) -> Any:
    """The command's points of one resized pair (nominal rig, as in ``bench_points.py``)."""
    rig = calibration.rig_from_short(0.16, 60.0, size)
    names = (Path("left"), Path("right"))
    return _stereo_points(stereo, left, right, rig, ratio=0.6, sources=names)


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", type=Path)
    mode.add_argument("--check", type=Path)
    parser.add_argument(
        "--sizes", nargs="+", type=_size, default=[(640, 480), (1280, 960), (1920, 1080)]
    )
    parser.add_argument("--pairs", nargs="*", help="folder names (default: every pair)")
    args = parser.parse_args()
    saved: dict[str, Any] = json.loads(args.check.read_text()) if args.check else {}
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    got: dict[str, Any] = {}
    bad = checked = 0
    t0 = time.perf_counter()
    for size in args.sizes:
        key = f"{size[0]}x{size[1]}"
        for name, lp, rp in pairs(args.pairs):
            d = digest(run_one(resized(lp, size), resized(rp, size), size))
            got.setdefault(key, {})[name] = d
            if args.check:
                want = saved.get(key, {}).get(name)
                if want is None:
                    print(f"{key} {name}: not in {args.check}", flush=True)
                    continue
                checked += 1
                if want != d:
                    bad += 1
                    print(f"{key} {name}: DIFFERENT ({want['n']} -> {d['n']} points)", flush=True)
        print(f"{key}: {len(got[key])} pairs done ({time.perf_counter() - t0:.0f} s)", flush=True)
    if args.write:
        args.write.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
        print(f"wrote {args.write}")
    else:
        print(f"{checked} pair-sizes checked, {bad} different, {checked - bad} identical")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
