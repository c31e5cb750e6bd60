"""``annotate`` on a REAL Dask cluster, over scenes rendered by the real generator (pybullet).

The tiny dataset (3 rendered scenes and the training views of the catalogue) is generated once
per session (shared between pytest-xdist workers through a lock), its database learnt once.
Quick (default run): a 2-worker local cluster gives the same lines as one process, a broken
scene is recorded with its error while the run goes on, the command's bad-input cases. Slow:
the client killed at a random point and resumed; one worker killed during a run on a scheduler
and workers started here on 127.0.0.1.
"""

from __future__ import annotations

import fcntl
import json
import os
import random
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from scenespeak.cli import main
from scenespeak.errors import InputError
from scenespeak.scene_folder import rgbd_supported
from scenespeak.tools.annotate import annotate, is_ambiguous
from scenespeak.tools.engine import EngineOptions, run_batches
from scenespeak.tools.output import log_path

FIELDS = {
    "scene", "argument", "referent", "primary", "secondary", "sentence", "degrees",
    "confidence", "ambiguous",
}  # fmt: skip
SEED = 1515
N_SCENES = 3


@pytest.fixture(scope="session")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """{"dataset", "db"}: a generated 3-scene dataset and the database learnt from its views."""
    from scenespeak.pipeline import database_from_dataset
    from scenespeak.tools.scenes import generate_dataset

    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent  # one copy per session, shared by the xdist workers
    root, db = base / "annotate-tiny", base / "annotate-tiny.db"
    with (base / "annotate-tiny.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not db.exists():
            generate_dataset(root, N_SCENES, seed=SEED)  # completes a half-made folder
            database_from_dataset(root, db.with_suffix(".partial"))
            db.with_suffix(".partial").rename(db)
    return {"dataset": root, "db": db}


def _links(tmp: Path, tiny: dict[str, Path], copies: int) -> Path:
    """A dataset of links: ``copies`` × the tiny scenes under distinct names."""
    root = tmp / "links"
    root.mkdir()
    for c in range(copies):
        for k in range(N_SCENES):
            (root / f"c{c}_scene_{k:03d}").symlink_to(tiny["dataset"] / f"scene_{k:03d}")
    return root


def _broken_scene(root: Path, tiny: dict[str, Path]) -> None:
    bad = root / "scene_broken"
    bad.mkdir()
    src = tiny["dataset"] / "scene_000"
    (bad / "left.png").write_bytes(b"not a png")
    (bad / "right.png").symlink_to(src / "right.png")
    (bad / "calib.json").symlink_to(src / "calib.json")


def _lines(path: Path) -> list[str]:
    return path.read_text(encoding="utf-8").splitlines()


def _log(out: Path) -> dict[str, dict[str, object]]:
    return {r["scene"]: r for r in map(json.loads, _lines(log_path(out)))}


@pytest.fixture(scope="session")
def reference(tiny: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    """The tiny dataset annotated in this one process (no Dask), sorted lines."""
    out = tmp_path_factory.mktemp("reference") / "relations.jsonl"
    annotate(tiny["dataset"], out, db=tiny["db"], engine=EngineOptions(workers=1))
    return sorted(_lines(out))


def _renamed(reference: list[str], copies: int) -> list[str]:
    """The reference's lines as the link dataset of ``copies`` names them."""
    out = []
    for c in range(copies):
        for line in reference:
            d = json.loads(line)
            d["scene"] = f"c{c}_{d['scene']}"
            out.append(json.dumps(d, ensure_ascii=False))
    return sorted(out)


# --------------------------------------------------------------------------------------------
# quick: the default run


def test_two_worker_cluster_equals_one_process(
    tiny: dict[str, Path], reference: list[str], tmp_path: Path
) -> None:
    root = _links(tmp_path, tiny, 1)
    _broken_scene(root, tiny)
    out = tmp_path / "relations.jsonl"
    seen: list[tuple[int, int]] = []
    summary = annotate(
        root,
        out,
        db=tiny["db"],
        engine=EngineOptions(workers=2, batch=1),
        parquet=tmp_path / "relations.parquet",
        progress=lambda done, total: seen.append((done, total)),
    )
    lines = _lines(out)
    assert sorted(lines) == _renamed(reference, 1)
    assert len(lines) == len(set(lines)) > 0
    for line in lines:
        d = json.loads(line)
        assert set(d) == FIELDS
        assert set(d["degrees"]) == {"left", "right", "front", "behind"}
        assert 0.0 <= d["confidence"] <= 1.0 and isinstance(d["ambiguous"], bool)
    # Each scene's lines are contiguous (one append per batch).
    order = [json.loads(x)["scene"] for x in lines]
    assert len([k for k in range(len(order)) if k == 0 or order[k] != order[k - 1]]) == len(
        set(order)
    )
    # The broken scene is recorded with its error (naming the file); the others are described.
    log = _log(out)
    assert set(log) == {f"c0_scene_{k:03d}" for k in range(N_SCENES)} | {"scene_broken"}
    assert "left.png" in str(log["scene_broken"]["error"])
    assert (summary.described, summary.failed, summary.pairs) == (N_SCENES, 1, len(lines))
    assert seen[0] == (0, N_SCENES + 1) and seen[-1] == (N_SCENES + 1, N_SCENES + 1)
    import pyarrow.parquet as pq

    assert pq.read_table(tmp_path / "relations.parquet").to_pylist() == [
        json.loads(x) for x in lines
    ]


def test_engine_hands_back_failed_batches_and_goes_on() -> None:
    got: list[int] = []
    failed: list[tuple[tuple[int, ...], str]] = []
    run_batches(
        _fail_on_three,
        [1, 2, 3, 4],
        EngineOptions(workers=1, batch=2),
        on_results=got.extend,
        on_failure=lambda items, err: failed.append((tuple(items), err)),
    )
    assert got == [1, 2, 4] and failed == [((3,), "ValueError: three")]
    with pytest.raises(InputError, match="tcp://HOST:PORT"):
        EngineOptions(scheduler="localhost:8786")


def _fail_on_three(items: list[int], database: object) -> list[int]:
    if 3 in items:
        raise ValueError("three")
    return list(items)


def _scene_options(items: list[int], database: Any) -> list[dict[str, int]]:
    return [database.scene_options() for _ in items]


def test_workers_describe_each_scene_in_one_thread() -> None:
    # on a cluster each worker process is one core's worth of work: its scenes run with
    # threads=1 (the pipeline's second thread would only fight the other workers); in this
    # process the pipeline keeps its own default
    here: list[dict[str, int]] = []
    run_batches(_scene_options, [1, 2], EngineOptions(workers=1), on_results=here.extend)
    assert here == [{}, {}]
    there: list[dict[str, int]] = []
    run_batches(
        _scene_options, [1, 2, 3], EngineOptions(workers=2, batch=1), on_results=there.extend
    )
    assert there == [{"threads": 1}] * 3


def test_ambiguous_flags_diagonals() -> None:
    import numpy as np

    from scenespeak.language import describe_relation

    def spike(deg: float) -> object:
        h = np.zeros(180)
        h[round(deg / 2) % 180] = 1.0
        return describe_relation(h, h, argument="a", referent="b")

    # 0° right ... 180° left; within 20° of a diagonal (45°, 135°, ...) is ambiguous.
    assert [is_ambiguous(spike(d)) for d in (0, 20, 24, 26, 44, 64, 66, 90, 180)] == [
        False, False, False, True, True, True, False, False, False,
    ]  # fmt: skip


def _cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(args)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def test_cli_annotate_and_its_bad_input(
    tiny: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    one = tmp_path / "one"
    one.mkdir()
    (one / "scene_000").symlink_to(tiny["dataset"] / "scene_000")
    out = tmp_path / "r.jsonl"
    args = ["annotate", str(one), "--out", str(out), "--db", str(tiny["db"]), "--workers", "1"]
    code, _, err = _cli([*args, "--parquet", str(tmp_path / "r.parquet")], capsys)
    assert code == 0, err
    assert "1 described, 0 failed" in err and (tmp_path / "r.parquet").is_file()
    assert all(set(json.loads(x)) == FIELDS for x in _lines(out))
    # Bad input: one line, exit 2, never a traceback.
    rgbd = tmp_path / "rgbd"
    (rgbd / "cam_000").mkdir(parents=True)
    for name in ("color.png", "depth.png", "intrinsics.json"):
        (rgbd / "cam_000" / name).write_bytes(b"")
    cases = [
        (args, "already exists; pass --resume"),
        (["annotate", str(tmp_path / "nope"), "--out", str(tmp_path / "x.jsonl")], "not a folder"),
        ([*args[:3], str(tmp_path / "z.jsonl")], "stereo scenes need an object database"),
        ([*args[:3], str(tmp_path / "w.jsonl"), "--db", str(out)], "not a scenespeak object"),
        ([*args, "--retry-failed"], "only makes sense with --resume"),
    ]
    for case, needle in cases:
        code, _, err = _cli(case, capsys)
        assert code == 2 and needle in err, (case, err)
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    # RGB-D folders: refused with one line naming the folder while this version has no RGB-D
    # path; with it, an unreadable RGB-D scene is recorded with its error like any other.
    rgbd_out = tmp_path / "y.jsonl"
    code, _, err = _cli(["annotate", str(rgbd), "--out", str(rgbd_out)], capsys)
    if rgbd_supported():
        assert code == 0 and "0 described, 1 failed" in err, err
        assert "cam_000" in str(_log(rgbd_out)["cam_000"]["error"])
    else:
        assert code == 2 and "cam_000: is an RGB-D scene" in err and len(err.splitlines()) == 1
    # The resumed run has nothing left to do and changes nothing.
    before = out.read_bytes()
    code, _, err = _cli([*args, "--resume"], capsys)
    assert code == 0 and "1 already done" in err and out.read_bytes() == before


# --------------------------------------------------------------------------------------------
# slow: faults


def _wait_for(predicate: object, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():  # type: ignore[operator]
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


def _killpg(proc: subprocess.Popen[bytes]) -> None:
    """SIGKILL what this test started: the process group of ``proc`` (its session)."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait(timeout=30)


def _env() -> dict[str, str]:
    src = str(Path(__file__).resolve().parents[2] / "src")
    return {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}


@pytest.mark.slow
def test_killed_client_resumes_with_every_pair_once(
    tiny: dict[str, Path], reference: list[str], tmp_path: Path
) -> None:
    # enough scenes that both kills land mid-run on a fast idle machine too: each kill comes
    # at most 2 scenes + 1.5 s after the previous one (3 copies, 9 scenes, let an idle
    # AVX-512 host finish before the second kill)
    copies = 8
    root = _links(tmp_path, tiny, copies)
    out = tmp_path / "relations.jsonl"
    n = copies * N_SCENES
    cmd = [sys.executable, "-m", "scenespeak", "annotate", str(root), "--out", str(out)]
    cmd += ["--db", str(tiny["db"]), "--workers", "2", "--batch", "1", "--quiet"]
    rng = random.Random(SEED)
    kills = []
    for attempt in range(2):  # killed twice, at random points, then left to finish
        proc = subprocess.Popen(
            [*cmd, *(["--resume"] if attempt else [])], env=_env(), start_new_session=True
        )
        done_before = len(_log(out)) if log_path(out).exists() else 0
        target = done_before + rng.randint(0, 2)
        _wait_for(
            lambda: log_path(out).exists() and len(_lines(log_path(out))) >= target,  # noqa: B023
            300,
            f"{target} scenes",
        )
        time.sleep(rng.uniform(0.0, 1.5))
        os.kill(proc.pid, signal.SIGKILL)  # the client, mid-run
        proc.wait(timeout=30)
        _killpg(proc)  # then its orphaned local cluster
        kills.append(len(_log(out)))
    assert kills[-1] < n, "the run finished before it could be killed"
    subprocess.run([*cmd, "--resume"], env=_env(), check=True, timeout=600)
    lines = _lines(out)
    counts = Counter(lines)
    assert max(counts.values()) == 1  # no pair written twice
    assert sorted(lines) == _renamed(reference, copies)  # and none lost
    assert len(_log(out)) == n and all(r["error"] is None for r in _log(out).values())


@pytest.fixture
def own_cluster(tmp_path: Path) -> Iterator[tuple[str, list[subprocess.Popen[bytes]]]]:
    """A scheduler and two workers (no nanny: a killed worker stays dead) on 127.0.0.1."""
    sched_file = tmp_path / "scheduler.json"
    env = {**_env(), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    procs = [
        subprocess.Popen(
            ["dask", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(sched_file)],
            env=env, start_new_session=True, stderr=subprocess.DEVNULL,
        )
    ]  # fmt: skip
    try:
        _wait_for(sched_file.exists, 60, "the scheduler")
        time.sleep(0.5)
        address = json.loads(sched_file.read_text())["address"]
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    ["dask", "worker", address, "--nthreads", "1", "--no-nanny",
                     "--no-dashboard", "--host", "127.0.0.1"],
                    env=env, start_new_session=True, stderr=subprocess.DEVNULL,
                )
            )  # fmt: skip
        yield address, procs
    finally:
        for proc in procs:
            _killpg(proc)


@pytest.mark.slow
def test_killed_worker_has_its_tasks_retried_elsewhere(
    tiny: dict[str, Path],
    reference: list[str],
    tmp_path: Path,
    own_cluster: tuple[str, list[subprocess.Popen[bytes]]],
) -> None:
    from distributed import Client

    address, procs = own_cluster
    copies = 3
    root = _links(tmp_path, tiny, copies)
    out = tmp_path / "relations.jsonl"
    killed: list[str] = []
    with Client(address, timeout="30s") as watcher:
        watcher.wait_for_workers(2, timeout=120)
        pids = watcher.run(os.getpid)  # worker address -> process id

        def kill_a_busy_worker() -> None:
            # Once a scene is done, kill a worker while it is running a task.
            deadline = time.monotonic() + 300
            while time.monotonic() < deadline and not killed:
                if log_path(out).exists() and _lines(log_path(out)):
                    for addr, keys in watcher.processing().items():
                        if keys:
                            os.kill(pids[addr], signal.SIGKILL)
                            killed.append(addr)
                            return
                time.sleep(0.05)

        thread = threading.Thread(target=kill_a_busy_worker)
        thread.start()
        summary = annotate(
            root, out, db=tiny["db"], engine=EngineOptions(scheduler=address, batch=1)
        )
        thread.join()
    assert killed, "no worker was killed"
    assert sum(p.poll() is not None for p in procs[1:]) == 1  # one worker is dead for good
    assert (summary.described, summary.failed) == (copies * N_SCENES, 0)
    lines = _lines(out)
    assert sorted(lines) == _renamed(reference, copies) and len(set(lines)) == len(lines)
