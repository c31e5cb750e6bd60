"""The pipeline's two threads: an executor that runs inline (one thread) and the guess.

:func:`scenespeak.pipeline.describe_scene` runs the right image's SIFT, the stereo stage and
geometry first's plane and segments in a second thread while this one labels. The finer
search that follows adds a detection in a minority of scenes (8 of 20 tuning scenes, 3 of 20
of the default set, 2 of the 12 bench scenes), so the second thread, once free, runs the rest
of the chain (objects, relations) on the first labelling as a :class:`Guess`: kept when the
finer search adds nothing (the same computation on the same inputs), abandoned otherwise
(``docs/architecture.md``, "One call, two threads"). The thread that labels makes the left
image's plain background for the other one (:func:`plain_promise`, :func:`fill`) and, once its
finer search is done, helps the guess with its objects' detections (:class:`Helper`).
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future
from contextlib import contextmanager
from dataclasses import dataclass, replace
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.description import SceneDescription
from scenespeak.perception import plausibility, stereo
from scenespeak.perception.features import Features
from scenespeak.perception.recognition.results import Labelling
from scenespeak.perception.scene_objects import StrategyOptions, geometry_for
from scenespeak.perception.scene_regions import SceneGeometry
from scenespeak.perception.stage_options import StereoOptions
from scenespeak.perception.stereo import StereoResult

if TYPE_CHECKING:
    from scenespeak.pipeline import PipelineOptions

__all__ = [
    "Guess",
    "Helper",
    "InlineExecutor",
    "Plain",
    "Say",
    "StereoStage",
    "fill",
    "label_and_finish",
    "plain_promise",
    "short_gil_slices",
    "stereo_stage",
    "timed",
]

#: A progress callback: called with each stage's name as it starts.
Say = Callable[[str], None]

#: The left image's plain backgrounds and textured pixels (``scene_objects.plain_for``).
Plain = tuple[NDArray[np.bool_] | None, NDArray[np.bool_] | None, NDArray[np.bool_] | None]


class InlineExecutor(Executor):
    """``ThreadPoolExecutor``'s ``submit`` run at once in the calling thread (``threads=1``).

    >>> InlineExecutor().submit(pow, 2, 10).result()
    1024
    """

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Run ``fn(*args, **kwargs)`` now; its result (or exception) in a finished future."""
        future: Future[Any] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed to whoever asks for the result, as a pool does
            future.set_exception(exc)
        return future


class Helper(Executor):
    """Tasks for a thread that waits for something else: ``submit`` queues them and that
    thread runs them in :meth:`serve` until what it waits for is done.

    The guess runs in the stereo thread while the labelling thread finishes the finer search
    and then waits for the guess; the guess's shareable jobs
    (``perception.sharing.run_shared``: the detections' regions and objects) go to this
    executor, so the waiting thread takes some of them. A task still queued when its sharer
    has done every job itself is cancelled there and skipped here.

    >>> from concurrent.futures import ThreadPoolExecutor
    >>> helper = Helper()
    >>> with ThreadPoolExecutor(1) as pool:
    ...     done = pool.submit(lambda: helper.submit(pow, 2, 10).result())
    ...     helper.serve(done)
    ...     done.result()
    1024
    """

    def __init__(self) -> None:
        self._tasks: queue.SimpleQueue[tuple[Future[Any], Callable[[], Any]] | None]
        self._tasks = queue.SimpleQueue()

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Queue ``fn(*args, **kwargs)`` for the thread in :meth:`serve`."""
        future: Future[Any] = Future()
        self._tasks.put((future, lambda: fn(*args, **kwargs)))
        return future

    def serve(self, until: Future[Any]) -> None:
        """Run the queued tasks here, in order, until ``until`` is done."""
        until.add_done_callback(lambda _done: self._tasks.put(None))
        while (task := self._tasks.get()) is not None:
            future, run = task
            if not future.set_running_or_notify_cancel():
                continue
            try:
                future.set_result(run())
            except BaseException as exc:  # the sharer raises it; nothing waits forever
                future.set_exception(exc)
                if not isinstance(exc, Exception):
                    raise


class Abandoned(Exception):
    """Stops a :class:`Guess` at the start of its next stage."""


@dataclass(frozen=True, eq=False)
class Guess:
    """The rest of the chain, run by another thread on inputs that may still change.

    Kept (:meth:`adopt`) when the inputs turned out as guessed: then it is the same
    computation on the same inputs, and its result is the result. Otherwise abandoned
    (:meth:`abandon`): it stops at the start of its next stage (its ``say`` raises) and its
    result is never read.

    >>> from concurrent.futures import ThreadPoolExecutor
    >>> with ThreadPoolExecutor(1) as pool:
    ...     guess = Guess.start(pool, lambda timings, say: say("objects") or "done")
    ...     guess.future.result()
    'done'
    """

    future: Future[Any]
    timings: dict[str, float]
    stop: threading.Event

    @classmethod
    def start(cls, pool: Executor, run: Callable[[dict[str, float], Say], Any]) -> Guess:
        """Submit ``run(timings, say)`` to ``pool`` (queued behind what it already holds)."""
        stop = threading.Event()

        def tell(stage: str) -> None:
            if stop.is_set():
                raise Abandoned(stage)

        timings: dict[str, float] = {}
        return cls(pool.submit(run, timings, tell), timings, stop)

    def adopt(
        self, timings: dict[str, float], say: Say, helper: Helper | None = None
    ) -> SceneDescription:
        """The guess's description (its errors raised here), with ``timings`` and its own;
        meanwhile this thread runs the tasks the guess hands to ``helper``."""
        if helper is not None:
            helper.serve(self.future)
        found: SceneDescription = self.future.result()
        for stage in ("objects", "relations"):
            say(stage)
        timings.update(self.timings)
        return replace(found, timings=timings)

    def abandon(self) -> None:
        """Stop the guess at its next stage; its result is never read."""
        self.stop.set()


@dataclass(frozen=True, eq=False)
class StereoStage:
    """What the stereo stage (the second thread) hands on to the rest of the chain.

    Attributes
    ----------
    features_right : Features
        SIFT features of the right image.
    result : StereoResult
        Matches, triangulated points, rectification and the dense map
        (:func:`scenespeak.perception.stereo.stereo_points`).
    geometry : SceneGeometry or None
        Geometry first's support plane and segments
        (:func:`scenespeak.perception.scene_objects.geometry_for`: they need no labels, so
        this thread makes them while the other labels); None when the strategy uses none.
    """

    features_right: Features
    result: StereoResult
    geometry: SceneGeometry | None = None


def stereo_stage(
    pair: tuple[NDArray[np.generic], NDArray[np.generic], Any],
    opts: tuple[StereoOptions, StrategyOptions],
    feats_l: Features,
    future_r: Future[Features],
    names: tuple[str, str],
    timings: dict[str, float],
    plain: Future[Plain] | None = None,
) -> StereoStage:
    """The right image's features (from ``future_r``), then the stereo stage and the scene's
    geometry (the second thread; ``timings`` gets "stereo" and "geometry"); ``plain``: the
    left image's plain parts (``scene_objects.plain_for``), made by the other thread."""

    left, right, rig = pair
    feats_r = future_r.result()
    with timed(timings, "stereo"):
        if opts[0].check_order:  # on these features: no SIFT of its own (issue 16)
            plausibility.check_pair_order(
                left, right, rig, names=names, features=(feats_l, feats_r)
            )
        result = stereo.stereo_points(
            left,
            right,
            rig,
            features_left=feats_l,
            features_right=feats_r,
            left_name=names[0],
            right_name=names[1],
            **opts[0].keywords(),
        )
    geometry = None
    if len(result.points.xyz):  # else the chain stops with _no_matches_error
        with timed(timings, "geometry"):
            shape = (left.shape[0], left.shape[1])
            made = None if plain is None else plain.result
            geometry = geometry_for(shape, result, opts[1], left, plain=made, right=right)
    return StereoStage(feats_r, result, geometry)


def label_and_finish(
    db: Any,
    scene: tuple[Features, NDArray[np.generic]],
    opts: PipelineOptions,
    pool: Executor,
    rest: Callable[[Labelling, Executor | None, dict[str, float], Say], SceneDescription],
    stereo_done: Future[StereoStage],
    timings: dict[str, float],
    say: Say,
) -> SceneDescription:
    """:func:`scenespeak.pipeline.describe_scene`'s stage 2 and the rest: the first
    labelling, the guess at the rest of the chain (two threads), the finer search; then the
    guess kept (this thread helping it, :class:`Helper`) or ``rest`` run here on what the
    finer search found (the other thread helping: ``pool``)."""
    feats_l, left = scene
    helper = Helper() if opts.threads > 1 else None
    with timed(timings, "label"):
        first: Labelling = db.label(feats_l, opts.labels)
        guess = Guess.start(pool, partial(rest, first, helper)) if helper is not None else None
        try:
            # the finer search looks again where matches explain nothing; its boxes are
            # shared with the stereo thread once that is free (same result)
            labelling = db.look_closer(feats_l, first, left, opts.labels, executor=pool)
        except BaseException:
            if guess is not None:
                guess.abandon()
            raise
        if guess is not None and labelling is not first:
            guess.abandon()  # the finer search found more: the rest runs here
    say("stereo")
    with timed(timings, "wait"):
        if guess is not None and labelling is first:
            return guess.adopt(timings, say, helper)
        stereo_done.result()
    return rest(labelling, pool if helper is not None else None, timings, say)


def plain_promise(threads: int, strategy: StrategyOptions) -> Future[Plain] | None:
    """A future for the left image's plain parts (``scene_objects.plain_for``), which the
    thread that labels makes while the stereo thread matches (:func:`fill`), when geometry
    first may read them; None with one thread (the stereo stage makes them in its turn)."""
    return Future() if threads > 1 and strategy.geometry and strategy.dense else None


def fill(future: Future[Any], fn: Callable[..., Any], *args: Any) -> None:
    """Set ``future``'s result to ``fn(*args)``; an exception it raises is set too (the thread
    waiting for the result raises it: nothing waits forever) and raised here."""
    try:
        future.set_result(fn(*args))
    except BaseException as exc:
        future.set_exception(exc)
        raise


#: The interpreter's thread switch interval inside :func:`short_gil_slices` (seconds; Python's
#: default is 5 ms). Each NumPy or OpenCV call of one thread lets the GIL go; taking it back
#: waits until the other thread, running Python code, hands it over at the end of its slice.
#: The objects stage of 6 bench scenes took 216 ms alone, 386 ms beside a thread doing BLAS
#: (no GIL, the CPU shared at load 6) and 749 ms beside a thread running Python; 509 ms with
#: 0.5 ms slices.
GIL_SLICE = 0.0005


@contextmanager
def short_gil_slices(seconds: float = GIL_SLICE) -> Iterator[None]:
    """The thread switch interval at most ``seconds`` inside the block, then as it was.

    Only a longer interval is shortened, and it is put back only if it is still the one set
    here (a block running at the same time in another thread may have put it back already:
    then this one runs with the longer slices, slower but the same).
    """
    before = sys.getswitchinterval()
    if before <= seconds:
        yield
        return
    sys.setswitchinterval(seconds)
    ours = sys.getswitchinterval()
    try:
        yield
    finally:
        if sys.getswitchinterval() == ours:
            sys.setswitchinterval(before)


@contextmanager
def timed(timings: dict[str, float], name: str) -> Iterator[None]:
    """Add the wall time of the ``with`` block to ``timings[name]``."""
    t0 = time.perf_counter()
    try:
        yield
    finally:
        timings[name] = timings.get(name, 0.0) + time.perf_counter() - t0
