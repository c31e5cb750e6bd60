"""The pipeline's guess (``pipeline_threads.Guess``): the rest of the chain run by the stereo
thread on the first labelling is the result only when the finer search adds nothing, and the
description is the same as one thread's either way."""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from cardscene import BASELINE, HFOV, H, W, card_pair, photo
from scenespeak.errors import ImageError
from scenespeak.perception.calibration import rig_from_short
from scenespeak.perception.recognition import ObjectDatabase
from scenespeak.perception.recognition.results import Labelling
from scenespeak.perception.sharing import run_shared
from scenespeak.pipeline import describe_scene
from scenespeak.pipeline_threads import Abandoned, Guess, Helper

NEAR = {"astronaut": (-0.25, 1.2, 0.2), "chelsea": (0.22, 1.0, 0.2), "coffee": (0.0, 1.8, 0.25)}


@pytest.fixture(scope="module")
def cards_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("guess") / "objects.db"
    with ObjectDatabase.create(path) as db:
        for name in ("astronaut", "chelsea", "coffee"):
            db.add_object(name, [photo(name, (240, 240))])
    return path


def _json(db_path: Path, **kw: Any) -> dict[str, Any]:
    left, right = card_pair(NEAR)
    rig = rig_from_short(BASELINE, HFOV, (W, H))
    with ObjectDatabase.open(db_path, readonly=True) as db:
        out = describe_scene(left, right, rig, db, **kw).to_dict()
    out.pop("timings_ms")
    return out


def _spy(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Record which of the guess's endings ran (the real methods still run)."""
    calls: list[str] = []
    adopt, abandon = Guess.adopt, Guess.abandon

    def adopt_spy(self: Guess, *args: Any) -> Any:
        calls.append("adopt")
        return adopt(self, *args)

    def abandon_spy(self: Guess) -> None:
        calls.append("abandon")
        abandon(self)

    monkeypatch.setattr(Guess, "adopt", adopt_spy)
    monkeypatch.setattr(Guess, "abandon", abandon_spy)
    return calls


def test_the_guess_is_the_result_when_the_finer_search_adds_nothing(
    cards_db: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    one = _json(cards_db, threads=1)
    calls = _spy(monkeypatch)
    two = _json(cards_db, threads=2)
    assert calls == ["adopt"]  # three near cards: the finer search finds nothing more
    assert two == one
    assert len(two["objects"]) == 3


def test_an_abandoned_guess_leaves_the_description_of_one_thread(
    cards_db: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    one = _json(cards_db, threads=1)
    calls = _spy(monkeypatch)
    look_closer = ObjectDatabase.look_closer

    def found_more(self: ObjectDatabase, features: Any, first: Labelling, *a: Any, **k: Any) -> Any:
        # a labelling that is not the first one (as when the finer search adds a detection)
        same = look_closer(self, features, first, *a, **k)
        return Labelling(same.labels.copy(), same.detections, same.matched.copy())

    monkeypatch.setattr(ObjectDatabase, "look_closer", found_more)
    assert _json(cards_db, threads=2) == one
    assert calls == ["abandon"]


def test_an_abandoned_guess_stops_at_its_next_stage() -> None:
    started, release = threading.Event(), threading.Event()
    stages: list[str] = []

    def run(timings: dict[str, float], say: Any) -> str:
        say("objects")
        stages.append("objects")
        started.set()
        release.wait(5)
        say("relations")
        stages.append("relations")
        return "done"

    with ThreadPoolExecutor(1) as pool:
        guess = Guess.start(pool, run)
        assert started.wait(5)
        guess.abandon()
        release.set()
        assert isinstance(guess.future.exception(5), Abandoned)
    assert stages == ["objects"]


def test_an_adopted_guess_raises_its_error() -> None:
    def run(timings: dict[str, float], say: Any) -> Any:
        raise ImageError("left.png", "no stereo matches")

    with ThreadPoolExecutor(1) as pool:
        guess = Guess.start(pool, run)
        with pytest.raises(ImageError, match="no stereo matches"):
            guess.adopt({}, lambda stage: None)


def test_a_helper_runs_the_shared_jobs_in_the_waiting_thread_and_keeps_their_order() -> None:
    here = threading.get_ident()
    ran_by: dict[int, int] = {}
    started = threading.Event()

    def job(i: int) -> int:
        ran_by[i] = threading.get_ident()
        if i == 0:
            started.set()
            # the first job waits for the helper to take the next ones (the waiting thread)
            for _ in range(500):
                if any(t == here for t in ran_by.values()):
                    break
                threading.Event().wait(0.01)
        return i * i

    helper = Helper()
    with ThreadPoolExecutor(1) as pool:
        done = pool.submit(run_shared, [lambda i=i: job(i) for i in range(8)], helper)
        assert started.wait(5)
        helper.serve(done)
        assert done.result() == [i * i for i in range(8)]
    assert here in ran_by.values()  # the waiting thread took some
    assert any(t != here for t in ran_by.values())


def test_a_helper_skips_what_its_sharer_cancelled_and_passes_errors_back() -> None:
    helper = Helper()
    skipped = helper.submit(pow, 2, 3)
    assert skipped.cancel()  # its sharer did every job itself

    def failing() -> None:
        raise ImageError("left.png", "no stereo matches")

    with ThreadPoolExecutor(1) as pool:
        done = pool.submit(lambda: helper.submit(failing).exception(5))
        helper.serve(done)
        assert isinstance(done.result(), ImageError)


def test_short_gil_slices_shorten_the_interval_inside_and_put_it_back() -> None:
    import sys

    from scenespeak.pipeline_threads import short_gil_slices

    before = sys.getswitchinterval()
    try:
        sys.setswitchinterval(0.005)
        with short_gil_slices(0.0005):
            assert sys.getswitchinterval() == pytest.approx(0.0005)
        assert sys.getswitchinterval() == pytest.approx(0.005)
        sys.setswitchinterval(0.0001)  # already shorter: left alone
        with short_gil_slices(0.0005):
            assert sys.getswitchinterval() == pytest.approx(0.0001)
        assert sys.getswitchinterval() == pytest.approx(0.0001)
    finally:
        sys.setswitchinterval(before)
