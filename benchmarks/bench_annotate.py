"""Benchmark of ``scenespeak annotate``: throughput, client memory, engine overhead.

Three parts (all by default; choose with ``--only``), each configuration in its own process:

``throughput``
    Scenes per second over the generated dataset (``--dataset``, e.g. 100 scenes made by
    ``scenespeak scenes generate DIR --n 100 --seed 2005``): a plain loop in one process
    (describe each folder, write its lines), then the engine on a local Dask cluster of 1 and
    of 2 worker processes (the cluster started first and timed apart; ``annotate`` is given
    its address). Also the CPU seconds per scene the workers spent (summed over the workers)
    and the client's peak memory. Target of issue 15: ≥ 1.8× scenes/s from 1 to 2 workers on
    an idle machine; the CPU per scene tells whether a shortfall is the engine or the load.
``memory``
    Peak resident memory of the client with 1,000 and 10,000 scenes (folders of links to the
    dataset's scenes). The workers *replay* the recorded lines of the real scenes
    (``_annotate_replay.py``) instead of describing them again, so 10,000 scenes take minutes
    and the client sees exactly the traffic of a real run. RSS is sampled every 0.1 s.
``labels``
    How honest the labels of the 2-worker run are against the generator's truth
    (``truth.json``): primary direction right on pairs flagged ``ambiguous`` and not, and how
    the flag agrees with the truth's own ambiguous count (diagonal ±20°, overlap, hidden).
    The rule was fixed before this was first run (``tools.annotate.is_ambiguous``).
``overhead``
    What the engine adds per scene: the replayed task over 1,000 linked scenes in a plain loop
    (buffered writes, no Dask) against the engine in this process and on a 1-worker cluster.

Run::

    python benchmarks/bench_annotate.py --dataset /tmp/eval100
    python benchmarks/bench_annotate.py --dataset /tmp/eval100 --only memory,overhead

The machine is shared and noisy: the load (``uptime``) is printed before and after each part.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent


def _load() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def _child(args: list[str]) -> dict[str, Any]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in [str(HERE), env.get("PYTHONPATH", "")] if p
    )  # the workers import _annotate_replay
    proc = subprocess.run(
        [sys.executable, __file__, "_child", *args], env=env, capture_output=True, text=True
    )
    if proc.returncode != 0:
        raise SystemExit(f"child {args} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


class _RssSampler:
    """Peak and sampled RSS of this process (psutil, every 0.1 s)."""

    def __init__(self) -> None:
        import psutil

        self.proc = psutil.Process()
        self.samples: list[tuple[float, int]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop.is_set():
            self.samples.append((time.perf_counter(), self.proc.memory_info().rss))
            self._stop.wait(0.1)

    def __enter__(self) -> _RssSampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    @property
    def peak_mb(self) -> float:
        return max(r for _, r in self.samples) / 2**20


# --------------------------------------------------------------------------------------------
# children (one configuration each)


def _plain_loop(dataset: Path, db: Path, out: Path) -> dict[str, Any]:
    from scenespeak.perception.database import ObjectDatabase
    from scenespeak.scene_folder import describe_scene_folder, find_scene_folders
    from scenespeak.tools.annotate import pair_record

    scenes = find_scene_folders(dataset)
    t0, c0 = time.perf_counter(), time.process_time()
    with ObjectDatabase.open(db, readonly=True) as opened, out.open("w") as fh:
        for s in scenes:
            desc = describe_scene_folder(s, opened, summary=False)
            for rel in desc.relations:
                fh.write(json.dumps(pair_record(s.name, rel)) + "\n")
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"scenes": len(scenes), "wall_s": wall, "cpu_s": cpu}


def _on_cluster(
    dataset: Path, db: Path, out: Path, workers: int, batch: int, task: str
) -> dict[str, Any]:
    from distributed import Client, LocalCluster

    from scenespeak.tools.annotate import annotate, annotate_batch
    from scenespeak.tools.engine import EngineOptions, open_client

    fn = annotate_batch
    if task == "replay":
        from _annotate_replay import replay_batch

        fn = replay_batch
    t0 = time.perf_counter()
    options = EngineOptions(workers=workers, batch=batch, in_process=False)
    with open_client(options) as client:
        startup = time.perf_counter() - t0
        address = client.scheduler.address
        del client  # annotate connects its own client to the scheduler, as --scheduler does
        with Client(address) as probe:
            cpu0 = sum(probe.run(time.process_time).values())
            with _RssSampler() as rss:
                summary = annotate(
                    dataset,
                    out,
                    db=db,
                    engine=EngineOptions(scheduler=address, batch=batch),
                    task=fn,
                )
            cpu1 = sum(probe.run(time.process_time).values())
    del LocalCluster
    return {
        "scenes": summary.described + summary.failed,
        "failed": summary.failed,
        "pairs": summary.pairs,
        "wall_s": summary.seconds,
        "startup_s": startup,
        "worker_cpu_s": cpu1 - cpu0,
        "client_peak_mb": rss.peak_mb,
        "client_maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "rss_samples_mb": _thin(rss.samples),
    }


def _thin(samples: list[tuple[float, int]], n: int = 11) -> list[float]:
    if not samples:
        return []
    idx = [round(k * (len(samples) - 1) / (n - 1)) for k in range(n)]
    return [round(samples[i][1] / 2**20, 1) for i in idx]


def _replay_loop(dataset: Path, out: Path) -> dict[str, Any]:
    from _annotate_replay import replay_batch
    from scenespeak.scene_folder import find_scene_folders

    scenes = [str(s) for s in find_scene_folders(dataset)]
    t0 = time.perf_counter()
    with out.open("w") as fh:
        for s in scenes:
            for record in replay_batch([s], None):
                fh.write("".join(line + "\n" for line in record.lines))
    return {"scenes": len(scenes), "wall_s": time.perf_counter() - t0}


def _replay_in_process(dataset: Path, db: Path, out: Path) -> dict[str, Any]:
    from _annotate_replay import replay_batch
    from scenespeak.tools.annotate import annotate
    from scenespeak.tools.engine import EngineOptions

    summary = annotate(dataset, out, db=db, engine=EngineOptions(workers=1), task=replay_batch)
    return {"scenes": summary.described, "wall_s": summary.seconds}


def child_main(argv: list[str]) -> None:
    p = argparse.ArgumentParser()
    p.add_argument("kind")
    p.add_argument("--dataset", type=Path)
    p.add_argument("--db", type=Path)
    p.add_argument("--out", type=Path)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--batch", type=int, default=2)
    a = p.parse_args(argv)
    if a.kind == "loop":
        res = _plain_loop(a.dataset, a.db, a.out)
    elif a.kind == "cluster":
        res = _on_cluster(a.dataset, a.db, a.out, a.workers, a.batch, "real")
    elif a.kind == "replay-cluster":
        res = _on_cluster(a.dataset, a.db, a.out, a.workers, a.batch, "replay")
    elif a.kind == "replay-loop":
        res = _replay_loop(a.dataset, a.out)
    elif a.kind == "replay-here":
        res = _replay_in_process(a.dataset, a.db, a.out)
    else:
        raise SystemExit(f"unknown child {a.kind}")
    print(json.dumps(res))


# --------------------------------------------------------------------------------------------
# parts


def _fresh(path: Path) -> Path:
    from scenespeak.tools.output import log_path

    for p in (path, log_path(path)):
        p.unlink(missing_ok=True)
    return path


def throughput(dataset: Path, db: Path, work: Path, batch: int) -> dict[str, Any]:
    print(f"## throughput on {dataset}\nload before: {_load()}", flush=True)
    rows: dict[str, Any] = {}
    rows["plain loop"] = _child(
        [
            "loop",
            "--dataset",
            str(dataset),
            "--db",
            str(db),
            "--out",
            str(_fresh(work / "loop.jsonl")),
        ]
    )
    for n in (1, 2):
        out = _fresh(work / f"dask{n}.jsonl")
        rows[f"dask, {n} worker(s)"] = _child(
            ["cluster", "--dataset", str(dataset), "--db", str(db), "--out", str(out),
             "--workers", str(n), "--batch", str(batch)]
        )  # fmt: skip
    print(f"load after: {_load()}")
    base = rows["dask, 1 worker(s)"]
    print("\n| run | scenes | wall s | scenes/s | vs 1 worker | CPU s/scene | client peak MB |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, r in rows.items():
        rate = r["scenes"] / r["wall_s"]
        cpu = r.get("worker_cpu_s", r.get("cpu_s", float("nan"))) / r["scenes"]
        speed = (base["wall_s"] / r["wall_s"]) if "startup_s" in r else float("nan")
        peak = r.get("client_peak_mb", float("nan"))
        print(
            f"| {name} | {r['scenes']} | {r['wall_s']:.1f} | {rate:.3f} | {speed:.2f}× "
            f"| {cpu:.2f} | {peak:.0f} |"
        )
    print(
        "cluster start-up (not in the wall times): "
        + ", ".join(f"{k}: {v['startup_s']:.1f} s" for k, v in rows.items() if "startup_s" in v)
    )
    same = sorted((work / "loop.jsonl").read_text().splitlines()) == sorted(
        (work / "dask2.jsonl").read_text().splitlines()
    )
    print(f"2-worker lines identical to the plain loop's: {same}\n", flush=True)
    rows["identical"] = same
    return rows


def _links(dataset: Path, n: int, work: Path) -> Path:
    from scenespeak.scene_folder import find_scene_folders

    root = work / f"links{n}"
    if root.is_dir() and len(os.listdir(root)) == n:
        return root
    root.mkdir(exist_ok=True)
    scenes = find_scene_folders(dataset)
    for k in range(n):
        link = root / f"s{k:05d}"
        if not link.exists():
            link.symlink_to(scenes[k % len(scenes)].resolve())
    return root


def memory(dataset: Path, db: Path, work: Path, replay: Path, batch: int) -> dict[str, Any]:
    print(f"## client memory (replayed scenes)\nload before: {_load()}", flush=True)
    os.environ["SCENESPEAK_REPLAY"] = str(replay)
    rows = {}
    for n in (1000, 10000):
        root = _links(dataset, n, work)
        out = _fresh(work / f"mem{n}.jsonl")
        rows[n] = _child(
            ["replay-cluster", "--dataset", str(root), "--db", str(db), "--out", str(out),
             "--workers", "2", "--batch", str(batch)]
        )  # fmt: skip
    print(f"load after: {_load()}")
    print("\n| scenes | pairs | wall s | client peak RSS MB | RSS over the run (MB, 11 samples) |")
    print("| --- | --- | --- | --- | --- |")
    for n, r in rows.items():
        print(
            f"| {n} | {r['pairs']} | {r['wall_s']:.1f} | {r['client_peak_mb']:.0f} | "
            f"{' '.join(str(v) for v in r['rss_samples_mb'])} |"
        )
    print(flush=True)
    return rows


def overhead(dataset: Path, db: Path, work: Path, replay: Path, batch: int) -> dict[str, Any]:
    print(f"## engine overhead per scene (replayed scenes)\nload before: {_load()}", flush=True)
    os.environ["SCENESPEAK_REPLAY"] = str(replay)
    root = _links(dataset, 1000, work)
    rows = {
        "plain loop": _child(
            ["replay-loop", "--dataset", str(root), "--out", str(_fresh(work / "o1.jsonl"))]
        ),
        "engine, in this process": _child(
            [
                "replay-here",
                "--dataset",
                str(root),
                "--db",
                str(db),
                "--out",
                str(_fresh(work / "o2.jsonl")),
            ]
        ),
        "engine, 1-worker cluster": _child(
            [
                "replay-cluster",
                "--dataset",
                str(root),
                "--db",
                str(db),
                "--out",
                str(_fresh(work / "o3.jsonl")),
                "--workers",
                "1",
                "--batch",
                str(batch),
            ]
        ),
    }
    print(f"load after: {_load()}")
    base = rows["plain loop"]["wall_s"] / rows["plain loop"]["scenes"]
    print("\n| run | scenes | wall s | ms per scene | added ms per scene |")
    print("| --- | --- | --- | --- | --- |")
    for name, r in rows.items():
        per = r["wall_s"] / r["scenes"]
        print(
            f"| {name} | {r['scenes']} | {r['wall_s']:.2f} | {1000 * per:.2f} | "
            f"{1000 * (per - base):.2f} |"
        )
    print(flush=True)
    return rows


def labels(dataset: Path, work: Path) -> dict[str, Any]:
    print(f"## labels against the truth ({dataset})", flush=True)
    truth: dict[tuple[str, str, str], tuple[str, bool]] = {}
    for scene in sorted(dataset.glob("scene_*")):
        t = json.loads((scene / "truth.json").read_text())
        for r in t["relations"]:
            truth[(scene.name, r["argument"], r["referent"])] = (r["primary"], r["ambiguous"])
    table: dict[tuple[bool, bool], list[int]] = {}
    extra = 0
    for line in (work / "dask2.jsonl").read_text().splitlines():
        d = json.loads(line)
        key = (d["scene"], d["argument"], d["referent"])
        if key not in truth:
            extra += 1  # a pair with an unknown object
            continue
        primary, t_amb = truth[key]
        cell = table.setdefault((d["ambiguous"], t_amb), [0, 0])
        cell[0] += d["primary"] == primary
        cell[1] += 1
    print("\n| flagged ambiguous | truth ambiguous | pairs | primary right |")
    print("| --- | --- | --- | --- |")
    for (flag, t_amb), (right, n) in sorted(table.items()):
        print(f"| {flag} | {t_amb} | {n} | {right} ({100 * right / n:.1f} %) |")
    for flag in (False, True):
        right = sum(v[0] for k, v in table.items() if k[0] == flag)
        n = sum(v[1] for k, v in table.items() if k[0] == flag)
        if n:
            print(f"flagged ambiguous={flag}: {right}/{n} right ({100 * right / n:.1f} %)")
    print(f"pairs with an object not in the truth (not scored): {extra}\n", flush=True)
    return {f"{k[0]}/{k[1]}": v for k, v in table.items()} | {"extra": extra}


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "_child":
        child_main(sys.argv[2:])
        return
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dataset", type=Path, required=True, help="a generated dataset folder")
    p.add_argument("--only", default="throughput,memory,overhead,labels")
    p.add_argument("--work", type=Path, default=Path("/tmp/scenespeak-bench-annotate"))
    p.add_argument("--batch", type=int, default=2, help="scenes per task")
    p.add_argument("--json", type=Path, help="also write every figure here")
    a = p.parse_args()
    from scenespeak.pipeline import database_from_dataset

    a.work.mkdir(parents=True, exist_ok=True)
    db = a.work / "objects.db"
    if not db.exists():
        database_from_dataset(a.dataset, db)
    parts = set(a.only.split(","))
    figures: dict[str, Any] = {}
    if "throughput" in parts:
        figures["throughput"] = throughput(a.dataset, db, a.work, a.batch)
    replay = a.work / "dask2.jsonl"
    if parts & {"memory", "overhead", "labels"} and not replay.exists():
        raise SystemExit(f"run --only throughput first: {replay} is the recording to replay")
    if "memory" in parts:
        figures["memory"] = memory(a.dataset, db, a.work, replay, a.batch)
    if "overhead" in parts:
        figures["overhead"] = overhead(a.dataset, db, a.work, replay, a.batch)
    if "labels" in parts:
        figures["labels"] = labels(a.dataset, a.work)
    if a.json:
        a.json.write_text(json.dumps(figures, indent=1, default=str))


if __name__ == "__main__":
    main()
