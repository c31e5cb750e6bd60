"""Jobs shared by two threads: each takes the next job not yet taken (:func:`run_shared`).

The pipeline's two threads share the finer search's boxes
(:mod:`scenespeak.perception.recognition.finer`) and the objects stage's detections
(:mod:`scenespeak.perception.scene_regions`): each job depends on its inputs only and its
result goes to its own place, so the results are the same whichever thread ran which job.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from typing import TypeVar

__all__ = ["run_shared"]

T = TypeVar("T")


def run_shared(jobs: Sequence[Callable[[], T]], executor: Executor | None = None) -> list[T]:
    """The results of ``jobs``, run in order by this thread and by one task of ``executor``.

    Both threads take the next job not yet taken until none is left, so the work is shared
    when the executor's thread is free and done here alone when it is busy (a task still
    queued when this thread has finished is cancelled). Each job's result goes to its own
    place: the list is the same whichever thread ran which job. An exception in a job is
    raised here, after the other thread has stopped (no job is started after it).

    >>> from concurrent.futures import ThreadPoolExecutor
    >>> with ThreadPoolExecutor(1) as pool:
    ...     run_shared([lambda i=i: i * i for i in range(6)], pool)
    [0, 1, 4, 9, 16, 25]
    """
    results: list[T | None] = [None] * len(jobs)
    lock = threading.Lock()
    order = iter(range(len(jobs)))
    failed = threading.Event()

    def drain() -> None:
        while not failed.is_set():
            with lock:
                i = next(order, None)
            if i is None:
                return
            try:
                results[i] = jobs[i]()
            except BaseException:
                failed.set()
                raise

    helper = executor.submit(drain) if executor is not None and len(jobs) > 1 else None
    try:
        drain()
    finally:
        if helper is not None and not helper.cancel():
            helper.result()
    return results  # type: ignore[return-value]  # every place was filled (or we raised)
