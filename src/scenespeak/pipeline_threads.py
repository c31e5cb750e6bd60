"""The pipeline's two threads: an executor that runs inline (one thread) and the guess.

:func:`scenespeak.pipeline.describe_scene` runs the right image's SIFT, the stereo stage and
geometry first's plane and segments in a second thread while this one labels. The finer
search that follows adds a detection in a minority of scenes (8 of 20 tuning scenes, 3 of 20
of the default set, 2 of the 12 bench scenes), so the second thread, once free, runs the rest
of the chain (objects, relations) on the first labelling as a :class:`Guess`: kept when the
finer search adds nothing (the same computation on the same inputs), abandoned otherwise
(``docs/architecture.md``, "One call, two threads").
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scenespeak.description import SceneDescription
from scenespeak.perception import plausibility, stereo
from scenespeak.perception.features import Features
from scenespeak.perception.scene_objects import StrategyOptions, geometry_for
from scenespeak.perception.scene_regions import SceneGeometry
from scenespeak.perception.stage_options import StereoOptions
from scenespeak.perception.stereo import StereoResult

__all__ = ["Guess", "InlineExecutor", "Say", "StereoStage", "stereo_stage", "timed"]

#: A progress callback: called with each stage's name as it starts.
Say = Callable[[str], None]


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

    def adopt(self, timings: dict[str, float], say: Say) -> SceneDescription:
        """The guess's description (its errors raised here), with ``timings`` and its own."""
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
) -> StereoStage:
    """The right image's features (from ``future_r``), then the stereo stage and the scene's
    geometry (the second thread; ``timings`` gets "stereo" and "geometry")."""

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
            geometry = geometry_for((left.shape[0], left.shape[1]), result, opts[1], left)
    return StereoStage(feats_r, result, geometry)


@contextmanager
def timed(timings: dict[str, float], name: str) -> Iterator[None]:
    """Add the wall time of the ``with`` block to ``timings[name]``."""
    t0 = time.perf_counter()
    try:
        yield
    finally:
        timings[name] = timings.get(name, 0.0) + time.perf_counter() - t0
