"""The scene service under load, from a client on 127.0.0.1.

Starts ``scenespeak serve`` (without ``--calib``: each request sends its calibration) as its
own process on 127.0.0.1 (a free port), then:

1. 200 ``POST /api/describe`` requests, ``--concurrency`` (4) at a time, over four distinct
   640×480 pairs of a rendered sequence (``benchmarks/livecache.py``); every response is
   compared with ``scenespeak describe --format json`` run on the same files (all fields but
   ``timings_ms``, which are each run's own);
2. the 50 malformed requests of ``tests/live/servehelp.py`` (wrong fields, corrupt, truncated
   and huge images, 10,000×10,000 headers, truncated multipart, over-limit bodies): each must
   be a 4xx with a one-line JSON error;
3. ``GET /api/health`` after all of it.

Prints the errors, mismatches, the latency median and 95th percentile, the throughput and
the load. Run::

    python benchmarks/bench_serve.py
    python benchmarks/bench_serve.py --requests 400 --concurrency 8 --workers 2
    python benchmarks/bench_serve.py --rgbd     # colour + depth + masks requests
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests" / "live"))

from servehelp import free_port, malformed_requests, send, without_timings  # noqa: E402

from livecache import DEFAULT_CACHE, TUNING_SEEDS, database, sequences  # noqa: E402


def _cli_json(db: Path, calib: Path, left: Path, right: Path) -> dict:
    out = subprocess.run(
        [sys.executable, "-m", "scenespeak", "describe", "--db", str(db), "--calib", str(calib),
         str(left), str(right), "--format", "json"],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return json.loads(out.stdout)


def _rgbd_files(seq, k: int) -> dict[str, Path]:
    d = Path(seq.root) / f"{k:04d}"
    return {
        "color": d / "left.png",
        "depth": d / "depth.png",
        "masks": d / "masks.png",
        "labels": d / "labels.json",
        "intrinsics": Path(seq.root) / "intrinsics.json",
    }


def _rgbd_cli_json(files: dict[str, Path]) -> dict:
    args = [str(files["color"])]
    for key in ("depth", "masks", "labels", "intrinsics"):
        args += [f"--{key}", str(files[key])]
    out = subprocess.run(
        [sys.executable, "-m", "scenespeak", "describe", *args, "--format", "json"],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return json.loads(out.stdout)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--requests", type=int, default=200)
    ap.add_argument("--concurrency", type=int, default=4)
    ap.add_argument("--workers", type=int, default=2, help="the server's --workers")
    ap.add_argument("--cache", type=Path, default=DEFAULT_CACHE)
    ap.add_argument(
        "--rgbd", action="store_true", help="RGB-D + masks requests (color, depth, masks, ...)"
    )
    args = ap.parse_args(argv)
    db = database(args.cache)
    seq = sequences(args.cache, (TUNING_SEEDS[0],), scripts=("appear",))[0]
    inputs = [seq.pair(k) for k in (0, 8, 16, 23)]
    if args.rgbd:  # the same script and seed rendered with depth + masks (cache/rgbd)
        rseq = sequences(args.cache / "rgbd", (TUNING_SEEDS[0],), scripts=("appear",))[0]
        rgbd = [_rgbd_files(rseq, k) for k in (0, 8, 16, 23)]
        expected = [without_timings(_rgbd_cli_json(f)) for f in rgbd]
    else:
        expected = [without_timings(_cli_json(db, seq.calib, a, b)) for a, b in inputs]
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    server = subprocess.Popen(
        [sys.executable, "-m", "scenespeak", "serve", "--db", str(db),
         "--port", str(port), "--workers", str(args.workers)],
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(base + "/api/health").json() == {"status": "ok"}:
                    break
            except httpx.HTTPError:
                pass
            if time.monotonic() > deadline or server.poll() is not None:
                raise SystemExit("the server did not start")
            time.sleep(0.2)
        calib = ("calib.json", seq.calib.read_bytes())
        bodies = [{"left": ("left.png", a.read_bytes()), "right": ("right.png", b.read_bytes()),
                   "calib": calib} for a, b in inputs]  # fmt: skip
        if args.rgbd:
            bodies = [{k: (p.name, p.read_bytes()) for k, p in f.items()} for f in rgbd]

        def one(i: int) -> tuple[int, float, str]:
            k = i % len(inputs)
            with httpx.Client(base_url=base, timeout=600) as c:
                t = time.perf_counter()
                r = c.post("/api/describe", files=bodies[k])
                dt = time.perf_counter() - t
            if r.status_code != 200:
                return k, dt, f"HTTP {r.status_code}: {r.text[:120]}"
            return k, dt, "" if without_timings(r.json()) == expected[k] else "differs from CLI"

        print(f"load before: {os.getloadavg()[0]:.2f} (1-min average, {os.cpu_count()} cores)")
        t0 = time.perf_counter()
        with ThreadPoolExecutor(args.concurrency) as pool:
            results = list(pool.map(one, range(args.requests)))
        wall = time.perf_counter() - t0
        lat = np.array([dt for _, dt, _ in results])
        problems = [p for _, _, p in results if p]
        print(f"describe: {args.requests} requests, {args.concurrency} at a time, "
              f"server --workers {args.workers}: {len(problems)} errors/mismatches")  # fmt: skip
        for p in sorted(set(problems))[:5]:
            print("   ", p)
        p50, p95 = 1000 * np.median(lat), 1000 * np.percentile(lat, 95)
        print(f"latency p50 {p50:.0f} ms, p95 {p95:.0f} ms; {args.requests / wall:.2f} requests/s")
        bad = 0
        with httpx.Client(base_url=base, timeout=600) as c:
            cases = malformed_requests(*inputs[0], seq.calib)
            statuses: dict[int, int] = {}
            for name, kwargs in cases:
                status, text = send(c, base, kwargs)
                ok = 400 <= status < 500
                try:
                    body = json.loads(text)
                    ok = ok and set(body) == {"error"} and "\n" not in body["error"]
                except ValueError:
                    ok = False
                statuses[status] = statuses.get(status, 0) + 1
                if not ok:
                    bad += 1
                    print(f"    NOT a one-line 4xx: {name}: {status} {text[:100]}")
            health = c.get("/api/health").json()
        print(f"malformed: {len(cases)} requests, {len(cases) - bad} one-line 4xx "
              f"(statuses {dict(sorted(statuses.items()))}); health after: {health}")  # fmt: skip
        print(f"load after: {os.getloadavg()[0]:.2f}")
        return 0 if not problems and not bad and health == {"status": "ok"} else 1
    finally:
        server.terminate()
        server.wait(timeout=30)


if __name__ == "__main__":
    raise SystemExit(main())
