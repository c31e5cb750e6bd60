"""Fingerprint of what scenespeak computes, for checking "same results" across commits.

One run of this script against one checkout (``PYTHONPATH=<checkout>/src``) records, for fixed
inputs, the outputs that the issue-9 refactor promised to keep:

``describe``
    ``describe_scene(...).to_dict()`` of the bench scenes (``benchmarks/bench_pipeline.py``'s
    12 generated scenes, seed 0), in the default mode and with ``dense=False, unknown=False``,
    against a database learnt from the dataset by the same checkout (``database_from_dataset``);
    timings stripped.
``evaluate``
    ``evaluate(DIR, workers=1).to_dict()`` of a fixed 100-scene folder (seed 2005), what
    ``scenespeak evaluate DIR --workers 1 --json`` prints, timings stripped, and the text of
    ``format_table`` (the table ``scenespeak evaluate DIR`` prints).
``stereo``
    The point arrays of ``benchmarks/bench_stereo.py``'s cases on the Middlebury motorcycle
    pair: the plain baseline's matches, ``stereo_points`` with ``verify=False``, default and
    ``dense_crop=True`` (left/right pixels and the 3-D points), the whole-image dense disparity
    and the bench's ``region_points`` region.
``generate`` (not in the default run)
    The scene generator: 3 fresh scenes, every file's SHA-1 and the truth files.
``forces``
    F0 and F2 histograms (180 directions) of ``benchmarks/bench_forces.py``'s shapes: convex 30,
    star 200, the two 512 x 512 masks, the convex/star scaling cases and the 10 pairs of the
    5-object scene.

Each part is written as canonical JSON (sorted keys, floats as ``repr``) into ``OUT.d/`` and its
SHA-1 into ``OUT`` (a small JSON file, the cache of that commit). The script imports only names
that exist both before the refactor (commit 687ee28: flat modules) and after it (packages),
so one copy of it runs against every commit of the history.

Run::

    # once, with the "before" checkout: the fixed inputs
    PYTHONPATH=/tmp/old/src python benchmarks/behaviour_fingerprint.py prepare /tmp/fp-inputs
    # for each commit
    SCENESPEAK_NUMBA=never SCENESPEAK_NO_NUMBA=1 PYTHONPATH=<checkout>/src nice -n 15 \\
        python benchmarks/behaviour_fingerprint.py run /tmp/fp-inputs /tmp/fp/<commit>.json
    # what changed between two commits (paths of the values that differ)
    python benchmarks/behaviour_fingerprint.py compare /tmp/fp/A.json /tmp/fp/B.json

``SCENESPEAK_NUMBA=never`` keeps the forces on the NumPy kernel (bit-stable: under ``auto`` a
histogram may come from the compiled sweep, which sums in another order and can differ in the
last bits). From af7085b (the forces package) until 8568102 the switch was spelled
``SCENESPEAK_NO_NUMBA=1``: set both when fingerprinting the history.
"""

from __future__ import annotations

import argparse
import difflib
import hashlib
import importlib
import itertools
import json
import math
import os
import re
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

#: Keys dropped from the JSON records: wall-clock measurements, different on every run.
TIMING_KEYS = ("timings", "seconds", "seconds_per_scene", "elapsed", "time_s", "wall_s", "cpu_s")

PARTS = ("describe", "evaluate", "stereo", "forces", "generate")


def _module(*names: str) -> Any:
    """The first of ``names`` that imports (new package path first, then the flat one)."""
    errors = []
    for name in names:
        try:
            return importlib.import_module(name)
        except ImportError as exc:
            errors.append(f"{name}: {exc}")
    raise ImportError("; ".join(errors))


def _is_timing(key: str) -> bool:
    return key in TIMING_KEYS or key.endswith("_seconds") or key.endswith("_ms")


def strip_timings(obj: Any) -> Any:
    """``obj`` without the timing entries of its dictionaries (recursively)."""
    if isinstance(obj, dict):
        return {k: strip_timings(v) for k, v in obj.items() if not _is_timing(str(k))}
    if isinstance(obj, list | tuple):
        return [strip_timings(v) for v in obj]
    return obj


def _plain(obj: Any) -> Any:
    """Arrays and NumPy scalars as lists and Python numbers (exact: floats keep every bit)."""
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    return obj


def canonical(obj: Any) -> str:
    """Sorted-key JSON of ``obj``; floats by ``repr`` (the shortest text that round-trips)."""
    return json.dumps(_plain(obj), sort_keys=True, ensure_ascii=False, allow_nan=True)


def sha1(text: str) -> str:
    return hashlib.sha1(text.encode()).hexdigest()


# ------------------------------------------------------------------------------------------
# inputs


def prepare(inputs: Path) -> None:
    """Generate the fixed inputs with the checkout on the path (do it once, with "before")."""
    scenes = _module("scenespeak.tools.scenes", "scenespeak.scenes")
    inputs.mkdir(parents=True, exist_ok=True)
    for name, n, seed in (("bench12", 12, 0), ("eval100", 100, 2005)):
        root = inputs / name
        if (root / "dataset.json").exists():
            print(f"{root}: present", flush=True)
            continue
        t0 = time.perf_counter()
        scenes.generate_dataset(root, n, seed=seed, progress=None)
        print(f"{root}: {n} scenes, seed {seed}, {time.perf_counter() - t0:.0f} s", flush=True)


def _scenes_of(root: Path) -> list[Path]:
    meta = json.loads((root / "dataset.json").read_text())
    return [root / s for s in meta["scenes"]]


# ------------------------------------------------------------------------------------------
# the parts


def part_describe(inputs: Path) -> dict[str, Any]:
    pipeline = _module("scenespeak.pipeline")
    features = _module("scenespeak.perception.features", "scenespeak.features")
    calibration = _module("scenespeak.perception.calibration", "scenespeak.calibration")
    recognition = _module(
        "scenespeak.perception.recognition", "scenespeak.perception.database", "scenespeak.database"
    )
    root = inputs / "bench12"
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="fingerprint-") as tmp:
        db_path = Path(tmp) / "objects.db"
        learnt = pipeline.database_from_dataset(root, db_path)
        out["learnt"] = sorted(learnt)
        with recognition.ObjectDatabase.open(db_path, readonly=True) as db:
            for scene in _scenes_of(root):
                left = features.load_image(scene / "left.png", gray=False)
                right = features.load_image(scene / "right.png", gray=False)
                rig = calibration.load_rig(scene / "calib.json")
                full = pipeline.describe_scene(left, right, rig, db).to_dict()
                sparse = pipeline.describe_scene(
                    left, right, rig, db, dense=False, unknown=False
                ).to_dict()
                out[scene.name] = strip_timings(full)
                out[scene.name + ":sparse"] = strip_timings(sparse)
    return out


def untimed_table(text: str) -> str:
    """``format_table``'s text with its two timing entries (wall clock, time per scene) masked."""
    text = re.sub(r"[0-9.]+ s wall clock", "... s wall clock", text)
    return re.sub(r"(\| time per scene[^|]*\|)[^|]*\|", r"\1 ... |", text)


def part_evaluate(inputs: Path) -> dict[str, Any]:
    evaluation = _module("scenespeak.tools.evaluation", "scenespeak.evaluation")
    result = evaluation.evaluate(inputs / "eval100", workers=1, progress=None)
    table = untimed_table(evaluation.format_table(result))
    return {"json": strip_timings(result.to_dict()), "table": table}


def _middlebury() -> tuple[Any, Any, Any, Any]:
    from skimage import data

    calibration = _module("scenespeak.perception.calibration", "scenespeak.calibration")
    f, cx, cy, doffs, b = 994.978, 311.193, 254.877, 31.086, 0.193001  # bench_stereo.py's
    k1 = [[f, 0, cx], [0, f, cy], [0, 0, 1]]
    k2 = [[f, 0, cx + doffs], [0, f, cy], [0, 0, 1]]
    rig = calibration.StereoRig(
        (741, 500), k1, k2, None, None, np.eye(3), [-b, 0, 0], source="middlebury"
    )
    left, right, _ = data.stereo_motorcycle()
    return left, right, rig, calibration.rectify(rig)


def _points(res: Any) -> dict[str, Any]:
    p = res.points
    return {"left_xy": p.left_xy, "right_xy": p.right_xy, "xyz": p.xyz}


def part_stereo(inputs: Path) -> dict[str, Any]:
    import cv2

    features = _module("scenespeak.perception.features", "scenespeak.features")
    stereo = _module("scenespeak.perception.stereo", "scenespeak.stereo")
    left, right, rig, rect = _middlebury()
    gl, gr = features.to_gray(left), features.to_gray(right)
    fl = features.detect(gl, precise_upscale=False)
    fr = features.detect(gr, precise_upscale=False)
    # bench_stereo.plain: BFMatcher kNN, ratio 0.6, band 1.5 px, d > 0
    bf = cv2.BFMatcher(cv2.NORM_L2)
    knn = bf.knnMatch(fl.descriptors.astype(np.float32), fr.descriptors.astype(np.float32), k=2)
    good = [m[0] for m in knn if len(m) == 2 and m[0].distance < 0.6 * m[1].distance]
    li, ri = [m.queryIdx for m in good], [m.trainIdx for m in good]
    lxy, rxy = fl.xy[li], fr.xy[ri]
    ok = (np.abs(lxy[:, 1] - rxy[:, 1]) <= 1.5) & (lxy[:, 0] - rxy[:, 0] > 0)
    out: dict[str, Any] = {
        "sift": {"left_xy": fl.xy, "right_xy": fr.xy},
        "plain": {"left_xy": lxy[ok], "right_xy": rxy[ok]},
        "verify_false": _points(stereo.stereo_points(left, right, rig, verify=False)),
        "default": _points(stereo.stereo_points(left, right, rig)),
        "dense_crop": _points(stereo.stereo_points(left, right, rig, dense_crop=True)),
    }
    strict = out["verify_false"]["left_xy"]
    disparity = strict[:, 0] - out["verify_false"]["right_xy"][:, 0]
    dense = stereo.dense_disparity(gl, gr, rect, keypoint_disparities=disparity)
    mask = np.zeros(gl.shape, bool)
    mask[300:380, 420:520] = True
    xyz, _ = stereo.region_points(dense, mask)
    out["dense"] = {
        "disparity_sha1": hashlib.sha1(np.ascontiguousarray(dense.disparity).tobytes()).hexdigest()
    }
    out["region_points"] = {"xyz": xyz}
    return out


def _convex(n: int, centre: tuple[float, float], radius: float, phase: float = 0.0) -> Any:
    a = phase + 2 * np.pi * np.arange(n) / n
    return np.column_stack([centre[0] + radius * np.cos(a), centre[1] + 0.7 * radius * np.sin(a)])


def _star(n: int, centre: tuple[float, float], radius: float, seed: int) -> Any:
    rng = np.random.default_rng(seed)
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = rng.uniform(0.5 * radius, radius, n)
    return np.column_stack([centre[0] + rad * np.cos(ang), centre[1] + rad * np.sin(ang)])


def _force_cases() -> Iterator[tuple[str, Any, Any]]:
    """bench_forces.py's shapes (same builders, same seeds)."""
    from skimage.draw import polygon as raster_polygon

    yield "convex 30", _convex(30, (0.0, 0.0), 1.0), _convex(30, (3.0, 1.0), 1.2, 0.1)
    yield "star 200", _star(200, (0.0, 0.0), 1.0, 2), _star(200, (2.6, 0.8), 1.2, 3)
    for n in (8, 16, 60, 120, 250, 500):
        yield f"convex {n}", _convex(n, (0, 0), 1.0), _convex(n, (3, 1), 1.2, 0.1)
        yield f"star {n}", _star(n, (0, 0), 1.0, 2), _star(n, (2.6, 0.8), 1.2, 3)
    shape = (512, 512)
    a = np.zeros(shape, bool)
    b = np.zeros(shape, bool)
    pa = _star(60, (150.0, -200.0), 110.0, seed=1)
    rr, cc = raster_polygon(-pa[:, 1], pa[:, 0], shape)
    a[rr, cc] = True
    pb = _convex(90, (370.0, -330.0), 100.0)
    rr, cc = raster_polygon(-pb[:, 1], pb[:, 0], shape)
    b[rr, cc] = True
    yield "masks 512", a, b
    rng = np.random.default_rng(4)
    hulls = []
    for k, n in enumerate((17, 13, 8, 22, 20)):
        centre = (0.35 * k - 0.7 + rng.uniform(-0.05, 0.05), 1.0 + rng.uniform(-0.3, 0.3))
        hulls.append(_convex(n, centre, rng.uniform(0.05, 0.12), rng.uniform(0, 1)))
    for i in range(5):
        for j in range(i + 1, 5):
            yield f"scene {i}-{j}", hulls[i], hulls[j]


def part_forces(inputs: Path) -> dict[str, Any]:
    forces = _module("scenespeak.spatial.forces", "scenespeak.forces")
    out: dict[str, Any] = {}
    for name, a, b in _force_cases():
        h = forces.force_histograms(a, b, r=(0.0, 2.0), directions=180)
        out[name] = {"f0": np.asarray(h[0]), "f2": np.asarray(h[1])}
    return out


def part_generate(inputs: Path) -> dict[str, Any]:
    """The scene generator itself: 3 scenes (seed 2005) written afresh; every file's SHA-1
    (images, training views, calibrations) and the truth files' content."""
    scenes = _module("scenespeak.tools.scenes", "scenespeak.scenes")
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="fingerprint-gen-") as tmp:
        root = Path(tmp) / "gen3"
        scenes.generate_dataset(root, 3, seed=2005, progress=None)
        for f in sorted(p for p in root.rglob("*") if p.is_file()):
            name = str(f.relative_to(root))
            if f.suffix == ".json":
                out[name] = json.loads(f.read_text())
            else:
                out[name] = hashlib.sha1(f.read_bytes()).hexdigest()
    return out


RUNNERS: dict[str, Callable[[Path], dict[str, Any]]] = {
    "describe": part_describe,
    "evaluate": part_evaluate,
    "stereo": part_stereo,
    "forces": part_forces,
    "generate": part_generate,
}


def run(inputs: Path, out: Path, parts: list[str]) -> None:
    """Compute ``parts`` and write their canonical JSON and SHA-1s (kept across runs)."""
    record: dict[str, Any] = json.loads(out.read_text()) if out.exists() else {}
    folder = out.with_suffix(".d")
    folder.mkdir(parents=True, exist_ok=True)
    for part in parts:
        t0 = time.perf_counter()
        text = canonical(RUNNERS[part](inputs))
        (folder / f"{part}.json").write_text(text)
        record[part] = sha1(text)
        record[part + "_cpu_s"] = round(time.process_time(), 1)
        print(f"{part}: {record[part]}  ({time.perf_counter() - t0:.0f} s)", flush=True)
        out.write_text(json.dumps(record, indent=1, sort_keys=True))
    record["numba"] = {
        k: os.environ.get(k, "") for k in ("SCENESPEAK_NUMBA", "SCENESPEAK_NO_NUMBA")
    }
    out.write_text(json.dumps(record, indent=1, sort_keys=True))


# ------------------------------------------------------------------------------------------
# comparison


#: Floats that differ by at most this relative amount are counted as "last bits" (summation
#: order, fused loops): reported apart from real changes, never hidden.
LAST_BITS = 1e-9


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _only_lines_added(a: str, b: str) -> bool:
    """Whether ``b`` is ``a`` with lines inserted (a table that gained rows, none changed)."""
    ops = difflib.SequenceMatcher(a=a.splitlines(), b=b.splitlines(), autojunk=False).get_opcodes()
    return all(op in ("equal", "insert") for op, *_ in ops)


Diff = tuple[str, str, float]  # (path, what differs, relative difference or inf)


def _walk(a: Any, b: Any, path: str, out: list[Diff], scale: float = 0.0) -> None:
    """Append ``(path, what, difference)`` for every value that differs.

    The difference of two numbers is relative to ``scale``, the largest magnitude in the list
    that holds them (a histogram's peak, an array's extent), or to the numbers themselves; it
    is ``inf`` for text, flags, lengths and keys that differ.
    """
    if isinstance(a, dict) and isinstance(b, dict):
        _walk_dict(a, b, path, out)
    elif isinstance(a, list) and isinstance(b, list):
        _walk_list(a, b, path, out)
    elif a != b:
        out.append(_leaf(a, b, path, scale))


def _walk_dict(a: dict[str, Any], b: dict[str, Any], path: str, out: list[Diff]) -> None:
    for k in sorted(set(a) | set(b)):
        if k not in a:
            out.append((f"{path}.{k}", "added", math.inf))
        elif k not in b:
            out.append((f"{path}.{k}", "removed", math.inf))
        else:
            _walk(a[k], b[k], f"{path}.{k}", out)


def _walk_list(a: list[Any], b: list[Any], path: str, out: list[Diff]) -> None:
    if len(a) != len(b):
        out.append((path, f"length {len(a)} -> {len(b)}", math.inf))
        return
    inner = max((abs(v) for v in a + b if _number(v)), default=0.0)
    for i, (x, y) in enumerate(zip(a, b, strict=True)):
        _walk(x, y, f"{path}[{i}]", out, inner)


def _leaf(a: Any, b: Any, path: str, scale: float) -> Diff:
    if isinstance(a, str) and isinstance(b, str) and "\n" in a and _only_lines_added(a, b):
        return (f"{path} (lines)", "added", math.inf)
    if _number(a) and _number(b) and not (isinstance(a, int) and isinstance(b, int)):
        rel = abs(a - b) / max(scale, abs(a), abs(b), 1e-300)
        return (path, f"{a!r} -> {b!r} (rel {rel:.1e})", rel)
    return (path, f"{str(a)[:70]!r} -> {str(b)[:70]!r}", math.inf)


def _kinds(diffs: list[Diff]) -> dict[str, list[Diff]]:
    """The differences by kind: added, removed, discrete (text, counts, flags, lengths),
    numbers (beyond :data:`LAST_BITS`) and bits (within it)."""
    structural = ("added", "removed")
    return {
        "added": [d for d in diffs if d[1] == "added"],
        "removed": [d for d in diffs if d[1] == "removed"],
        "discrete": [d for d in diffs if math.isinf(d[2]) and d[1] not in structural],
        "numbers": [d for d in diffs if LAST_BITS < d[2] < math.inf],
        "bits": [d for d in diffs if d[2] <= LAST_BITS],
    }


def _diffs(a: Path, b: Path, part: str) -> list[Diff] | None:
    """The differences of one part between two runs (``None``: not in both)."""
    fa, fb = a.with_suffix(".d") / f"{part}.json", b.with_suffix(".d") / f"{part}.json"
    if not (fa.exists() and fb.exists()):
        return None
    ta, tb = _normalised(fa.read_text(), part), _normalised(fb.read_text(), part)
    diffs: list[Diff] = []
    if ta != tb:
        _walk(json.loads(ta), json.loads(tb), "", diffs)
    return diffs


def _top(path: str) -> str:
    """The first component of a path (a scene, a case, "json"/"table")."""
    head = path[1:].split(".")[0]
    return head.split("[")[0]


def _normalised(text: str, part: str) -> str:
    """A stored part as compared: the evaluation table's timings masked (older records)."""
    if part != "evaluate":
        return text
    data = json.loads(text)
    data = {"json": strip_timings(data["json"]), "table": untimed_table(data["table"])}
    return canonical(data)


def verdict(a: Path, b: Path, part: str) -> str:
    """One word for a part between two runs: ``same``, ``keys+`` (only keys or table rows
    added), ``bits`` (numbers within :data:`LAST_BITS`, maybe keys added), ``keys-`` (keys
    removed), ``CHANGED``, or ``-`` (not in both)."""
    diffs = _diffs(a, b, part)
    if diffs is None:
        return "-"
    k = _kinds(diffs)
    if k["discrete"] or k["numbers"]:
        return "CHANGED"
    if k["removed"]:
        return "keys-"
    if k["bits"]:
        return "bits"
    return "keys+" if k["added"] else "same"


def ledger(runs: list[Path]) -> None:
    """A Markdown table: each part's verdict between consecutive runs."""
    print("| from | to | " + " | ".join(PARTS) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in PARTS) + " |")
    for a, b in itertools.pairwise(runs):
        cells = [verdict(a, b, part) for part in PARTS]
        print(f"| {a.stem} | {b.stem} | " + " | ".join(cells) + " |")


def _report(part: str, diffs: list[Diff], limit: int) -> None:
    k = _kinds(diffs)
    print(
        f"{part}: DIFFERENT: {len(k['discrete'])} texts/counts/flags/lengths changed, "
        f"{len(k['numbers'])} numbers changed (max rel "
        f"{max((d[2] for d in k['numbers']), default=0):.1e}), "
        f"{len(k['bits'])} only in the last bits (rel <= {LAST_BITS:g}, max "
        f"{max((d[2] for d in k['bits']), default=0):.1e}), {len(k['added'])} keys added, "
        f"{len(k['removed'])} removed"
    )
    names = sorted({p.rsplit(".", 1)[-1] for p, _, _ in k["added"] + k["removed"]})
    if names:
        print(f"  keys added/removed: {', '.join(names)[:300]}")
    real = k["discrete"] + k["numbers"]
    tops = sorted({_top(p) for p, _, _ in real})
    if tops:
        print(f"  real changes in {len(tops)}: {', '.join(tops)[:300]}")
    for path, what, _ in real[:limit]:
        print(f"  {path}: {what}")


def compare(a: Path, b: Path, limit: int) -> int:
    """Print, part by part, what differs (last bits apart); return how many parts differ."""
    differing = 0
    for part in PARTS:
        diffs = _diffs(a, b, part)
        if diffs is None:
            print(f"{part}: not in both")
        elif not diffs:
            print(f"{part}: identical")
        else:
            differing += 1
            _report(part, diffs, limit)
    return differing


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("prepare", help="generate the fixed inputs")
    p.add_argument("inputs", type=Path)
    r = sub.add_parser("run", help="fingerprint the checkout on PYTHONPATH")
    r.add_argument("inputs", type=Path)
    r.add_argument("out", type=Path)
    r.add_argument("--parts", default=",".join(PARTS[:4]), help="comma-separated subset")
    c = sub.add_parser("compare", help="the values that differ between two runs")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    c.add_argument("--limit", type=int, default=25, help="paths printed per part")
    t = sub.add_parser("ledger", help="verdicts between consecutive runs, as a table")
    t.add_argument("runs", type=Path, nargs="+")
    args = ap.parse_args(argv)
    if args.cmd == "ledger":
        ledger(args.runs)
        return 0
    if args.cmd == "prepare":
        prepare(args.inputs)
        return 0
    if args.cmd == "run":
        parts = [s for s in args.parts.split(",") if s]
        unknown = sorted(set(parts) - set(PARTS))
        if unknown:
            ap.error(f"unknown part(s) {', '.join(unknown)}; choose from {', '.join(PARTS)}")
        run(args.inputs, args.out, parts)
        return 0
    return 1 if compare(args.a, args.b, args.limit) else 0


if __name__ == "__main__":
    sys.exit(main())
