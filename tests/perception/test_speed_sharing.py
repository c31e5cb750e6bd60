"""The speed changes of issue 10 keep the answers: work shared between threads gives the same
results as one thread, and the region masks cut to their box are the masks made whole."""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cv2
import numpy as np
import pytest
from skimage import data

from scenespeak.perception.features import detect, to_gray
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.recognition.finer import run_shared
from scenespeak.perception.scene_regions import _outline_mask


def test_run_shared_keeps_each_result_in_its_place_and_uses_the_other_thread() -> None:
    threads: set[int] = set()

    def job(i: int) -> int:
        threads.add(threading.get_ident())
        time.sleep(0.01)  # long enough for the helper to take some jobs
        return i * i

    with ThreadPoolExecutor(1) as pool:
        got = run_shared([lambda i=i: job(i) for i in range(12)], pool)
    assert got == [i * i for i in range(12)]
    assert len(threads) == 2
    assert run_shared([lambda: 1, lambda: 2]) == [1, 2]  # no executor: all here
    assert run_shared([], None) == []


def test_run_shared_raises_a_job_error_and_stops() -> None:
    ran: list[int] = []

    def job(i: int) -> int:
        ran.append(i)
        if i == 2:
            raise ValueError("job 2 failed")
        time.sleep(0.005)
        return i

    with ThreadPoolExecutor(1) as pool, pytest.raises(ValueError, match="job 2"):
        run_shared([lambda i=i: job(i) for i in range(40)], pool)
    assert len(ran) < 40  # nothing new was started after the failure (at most one in flight)


def test_run_shared_does_not_wait_for_a_busy_executor() -> None:
    # the executor's one thread is busy: the jobs are all done here and its queued task is
    # cancelled, so the call returns before the busy task ends
    release = threading.Event()
    with ThreadPoolExecutor(1) as pool:
        busy = pool.submit(release.wait, 10)
        t0 = time.perf_counter()
        assert run_shared([lambda i=i: i for i in range(5)], pool) == [0, 1, 2, 3, 4]
        assert time.perf_counter() - t0 < 5
        release.set()
        busy.result()


def _whole_dilation(outline: np.ndarray, shape: tuple[int, int], grow: float) -> np.ndarray:
    """The outline mask as it was made before: the whole image dilated."""
    mask = np.zeros(shape, np.uint8)
    cv2.fillPoly(mask, [np.round(outline * 16).astype(np.int32).reshape(-1, 1, 2)], 1, 8, 4)
    x0, y0 = outline.min(axis=0)
    x1, y1 = outline.max(axis=0)
    r = round(grow * max(x1 - x0, y1 - y0, 1.0))
    if r > 0:
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        mask = cv2.dilate(mask, disc)
    return mask.astype(bool)


def test_outline_masks_dilated_in_their_box_are_the_whole_dilation() -> None:
    rng = np.random.default_rng(3)
    for t in range(150):
        shape = (int(rng.integers(20, 120)), int(rng.integers(20, 160)))
        centre = rng.uniform(-30, 180, 2)
        outline = centre + rng.uniform(-1, 1, (int(rng.integers(3, 8)), 2)) * rng.uniform(1, 60)
        grow = float(rng.choice([0.0, 0.1, 0.15, 0.4]))
        got = _outline_mask(outline, shape, grow)
        assert np.array_equal(got, _whole_dilation(outline, shape, grow)), t


ASTRONAUT = to_gray(data.astronaut())[30:330, 100:400]


@pytest.fixture(scope="module")
def photo_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("sharing") / "objects.db"
    with ObjectDatabase.create(path) as db:
        db.add_object("astronaut", [ASTRONAUT])
        db.add_object("coffee", [data.coffee()])
    return path


def test_finer_search_shared_with_a_thread_gives_the_same_labelling(photo_db: Path) -> None:
    # three small, far astronauts and a coffee cup: several boxes for the finer search
    scene = np.full((480, 640, 3), 120, np.uint8)
    for x, y, s in ((400, 300, 0.08), (60, 380, 0.09), (520, 60, 0.08)):
        tiny = cv2.resize(ASTRONAUT, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        scene[y : y + tiny.shape[0], x : x + tiny.shape[1]] = tiny[..., None]
    cup = cv2.resize(data.coffee(), (60, 40), interpolation=cv2.INTER_AREA)
    scene[200:240, 250:310] = cup
    feats = detect(to_gray(scene), precise_upscale=False)
    with ObjectDatabase.open(photo_db) as db, ThreadPoolExecutor(1) as pool:
        alone = db.label(feats, image=scene)
        shared = db.label(feats, image=scene, executor=pool)
    assert alone.detections, "the scene should give the finer search something to find"
    assert np.array_equal(alone.labels, shared.labels)
    assert np.array_equal(alone.matched, shared.matched)
    assert [d.label for d in alone.detections] == [d.label for d in shared.detections]
    for a, b in zip(alone.detections, shared.detections, strict=True):
        assert np.array_equal(a.inliers, b.inliers)
        assert np.array_equal(a.homography, b.homography)
        assert np.array_equal(a.outline_in_scene, b.outline_in_scene)


def test_faiss_on_one_thread_for_a_small_search_gives_the_same_answer() -> None:
    faiss = pytest.importorskip("faiss")
    from scenespeak.perception.recognition import build_index
    from scenespeak.perception.recognition.ivf import FaissIndex

    rng = np.random.default_rng(3)
    base = rng.integers(0, 256, (6000, 128), dtype=np.uint8)
    query = np.vstack([base[:200], rng.integers(0, 256, (100, 128), dtype=np.uint8)])
    index = build_index(base, "faiss", nlist=64, nprobe=4)
    assert isinstance(index, FaissIndex)
    assert 300 * (64 + 4 * 6000 / 64) < index.serial_below  # this search is a small one
    before = faiss.omp_get_max_threads()
    small = index.search(query, 16)  # one OpenMP thread
    assert faiss.omp_get_max_threads() == before  # restored afterwards
    index.threads = 2
    both = index.search(query, 16)  # FAISS's two threads
    np.testing.assert_array_equal(small[0], both[0])
    np.testing.assert_array_equal(small[1], both[1])
    assert (small[1][:200, 0] == np.arange(200)).all()


def test_faiss_counts_the_coarse_centroids_in_a_searchs_size(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A search is small by the distances it computes: each query against the ``nlist``
    centroids, then the descriptors of its ``nprobe`` cells. (Counting the cells alone put the
    1,000-object benchmark's 2,318 queries — 7.3 million distances with the centroids, 2.6
    million without — on one thread: 187 ms instead of 93.)"""
    pytest.importorskip("faiss")
    from contextlib import nullcontext

    from scenespeak.perception.recognition import build_index, ivf

    rng = np.random.default_rng(4)
    index = build_index(
        rng.integers(0, 256, (6000, 128), dtype=np.uint8), "faiss", nlist=64, nprobe=4
    )
    query = rng.integers(0, 256, (300, 128), dtype=np.uint8)
    asked: list[int | None] = []
    monkeypatch.setattr(ivf, "omp_threads", lambda t: asked.append(t) or nullcontext())
    cells = 300 * 4 * 6000 / 64  # 112,500 distances in the cells
    with_centroids = 300 * (64 + 4 * 6000 / 64)  # 131,700 with the centroids
    index.serial_below = int((cells + with_centroids) / 2)  # between the two counts
    index.search(query, 2)
    index.serial_below = int(with_centroids) + 1
    index.search(query, 2)
    assert asked == [None, 1]  # large: FAISS's own threads; then small: one thread
