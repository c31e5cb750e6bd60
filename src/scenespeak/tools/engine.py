"""The execution engine of ``annotate`` and ``evaluate``: scene batches on Dask distributed.

One engine runs every dataset-sized job (``docs/annotate.md``):

- a :class:`~distributed.LocalCluster` of ``workers`` processes on this machine by default,
  each with one thread and one OpenCV/BLAS thread (the chain's matrices are small; a second
  BLAS thread only fights the other workers), or an existing cluster by its scheduler address
  (``tcp://HOST:PORT``); ``workers=1`` without a scheduler runs in this process, no cluster;
- the object database shipped to the workers **once** per run: its bytes travel in a worker
  plugin (:class:`ShippedDatabase`), each worker writes them to its local directory, opens the
  file once and keeps it open (and its nearest-neighbour index built) for every task; a worker
  that joins later, e.g. one restarted after a crash, gets the plugin too;
- tasks of ``batch`` items each, at most ``in_flight`` tasks submitted at a time, results
  handed to the caller as they finish (:func:`distributed.as_completed`), so the client's memory
  does not grow with the number of items;
- faults: a task that raises is retried ``retries`` times (also on another worker), a worker
  that dies has its tasks rescheduled elsewhere by the scheduler; a batch that still fails is
  handed back as failed, item by item, and the run goes on.

The task function runs on the workers: ``task(items, database)`` gets a batch and a
:class:`DatabaseHandle` (``database.get()`` is the open
:class:`~scenespeak.perception.database.ObjectDatabase`, or None when the run has none) and
returns one result per item. It must be importable by the workers (a module-level function).

>>> def double(items, database):
...     return [2 * i for i in items]
>>> got = []
>>> run_batches(double, [1, 2, 3], EngineOptions(workers=1, batch=2), on_results=got.extend)
>>> got
[2, 4, 6]
"""

from __future__ import annotations

import hashlib
import logging
import os
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from scenespeak.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from distributed import Client

    from scenespeak.perception.database import ObjectDatabase

__all__ = [
    "THREAD_ENVIRONMENT",
    "DatabaseHandle",
    "EngineOptions",
    "limit_threads",
    "run_batches",
]

T = TypeVar("T")
R = TypeVar("R")

#: Environment of every worker process: one OpenMP / OpenBLAS / MKL thread. These must be set
#: before NumPy is imported, so the local cluster sets them before it spawns its workers; for
#: workers you start yourself, export them in the job script (``docs/annotate.md``).
THREAD_ENVIRONMENT: dict[str, str] = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


@dataclass(frozen=True)
class EngineOptions:
    """Where and how :func:`run_batches` runs.

    Attributes
    ----------
    workers : int
        Worker processes of the local cluster (one thread each). 1 without ``scheduler`` runs
        in this process (no cluster) unless ``in_process`` is False.
    scheduler : str or None
        Address of an existing Dask scheduler (``tcp://HOST:PORT``); ``workers`` is then
        ignored: the cluster has the workers it has.
    batch : int
        Items per task. A scene takes about a second, a task costs the scheduler about a
        millisecond: a few scenes per task keep the overhead small and the tail short.
    in_flight : int or None
        Tasks submitted and not yet collected, at most; default twice the cluster's threads
        (each worker has its next batch waiting). Bounds the client's memory.
    retries : int
        Times a task that raised is retried (Dask's ``retries``; a worker that dies is handled
        by the scheduler's own rescheduling, ``distributed.scheduler.allowed-failures``).
    in_process : bool or None
        Run in this process without Dask: None = only when ``workers == 1`` and no
        ``scheduler``; False forces a cluster even for one worker (benchmarks).
    """

    workers: int = 2
    scheduler: str | None = None
    batch: int = 2
    in_flight: int | None = None
    retries: int = 2
    in_process: bool | None = None

    def __post_init__(self) -> None:
        if self.workers < 1:
            raise InputError("--workers", f"must be at least 1, got {self.workers}")
        if self.batch < 1:
            raise InputError("--batch", f"must be at least 1, got {self.batch}")
        if self.in_flight is not None and self.in_flight < 1:
            raise InputError("in_flight", f"must be at least 1, got {self.in_flight}")
        if self.retries < 0:
            raise InputError("retries", f"must be at least 0, got {self.retries}")
        if self.scheduler is not None and "://" not in self.scheduler:
            raise InputError(
                "--scheduler", f"expected an address like tcp://HOST:PORT, got {self.scheduler!r}"
            )

    @property
    def runs_in_process(self) -> bool:
        """True when the work runs in this process, without Dask."""
        if self.in_process is not None:
            return self.in_process
        return self.workers == 1 and self.scheduler is None


def limit_threads() -> None:
    """One OpenCV thread and one BLAS thread in this process (what every worker does first)."""
    for key, value in THREAD_ENVIRONMENT.items():
        os.environ.setdefault(key, value)
    import cv2

    cv2.setNumThreads(1)
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        pass


# --------------------------------------------------------------------------------------------
# the database, once per worker


class _OpenPerThread:
    """A database file opened once per thread (SQLite connections belong to their thread)."""

    def __init__(self, path: Path | None) -> None:
        self.path = path
        self._open: dict[int, ObjectDatabase] = {}
        self._lock = threading.Lock()

    def get(self) -> ObjectDatabase | None:
        if self.path is None:
            return None
        key = threading.get_ident()
        with self._lock:
            db = self._open.get(key)
            if db is None:
                from scenespeak.perception.database import ObjectDatabase

                db = ObjectDatabase.open(self.path, readonly=True)
                self._open[key] = db
        return db

    def close(self) -> None:
        """Close this thread's connection; the others' are dropped (closed when collected:
        SQLite refuses to close a connection from another thread)."""
        with self._lock:
            mine = self._open.pop(threading.get_ident(), None)
            self._open.clear()
        if mine is not None:
            mine.close()


class DatabaseHandle:
    """What a task gets to reach the object database: ``handle.get()``.

    In this process it opens the file once (per thread); on a worker it returns the database
    the worker's :class:`ShippedDatabase` plugin opened (the handle itself carries only the
    plugin's name, so tasks stay small).

    ``scene_threads`` is how many threads one scene may use there: 1 on a cluster's worker
    (each worker process has one core's worth of work; a second thread per scene only fights
    the other workers), None in this process (the pipeline's own default:
    ``PipelineOptions.threads``). Tasks pass it on as :meth:`scene_options`.
    """

    def __init__(
        self,
        plugin: str | None = None,
        local: _OpenPerThread | None = None,
        scene_threads: int | None = None,
    ) -> None:
        self.plugin = plugin
        self._local = local
        self.scene_threads = scene_threads

    def __getstate__(self) -> dict[str, Any]:
        return {"plugin": self.plugin, "scene_threads": self.scene_threads}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.plugin = state["plugin"]
        self.scene_threads = state.get("scene_threads")
        self._local = None

    def scene_options(self) -> dict[str, Any]:
        """Pipeline options a task adds to each scene it describes (``threads`` on a worker).

        Examples
        --------
        >>> DatabaseHandle().scene_options()
        {}
        >>> DatabaseHandle("db", scene_threads=1).scene_options()
        {'threads': 1}
        """
        return {} if self.scene_threads is None else {"threads": self.scene_threads}

    def get(self) -> ObjectDatabase | None:
        """The open database (read-only), or None when the run has none."""
        if self._local is not None:
            return self._local.get()
        if self.plugin is None:
            return None
        from distributed import get_worker

        from scenespeak.tools.dask_plugins import ShippedDatabase

        plugin = get_worker().plugins.get(self.plugin)
        if not isinstance(plugin, ShippedDatabase):
            raise RuntimeError(f"the worker has no database plugin {self.plugin!r}")
        return plugin.get()


# --------------------------------------------------------------------------------------------
# running


@dataclass(frozen=True)
class _Batch(Generic[T]):
    index: int
    items: tuple[T, ...]


def _batches(items: Sequence[T], size: int) -> Iterator[_Batch[T]]:
    for k, start in enumerate(range(0, len(items), size)):
        yield _Batch(k, tuple(items[start : start + size]))


def _run_task(
    task: Callable[[Sequence[T], DatabaseHandle], list[R]],
    items: tuple[T, ...],
    handle: DatabaseHandle,
) -> list[R]:
    """What a worker runs: the task on one batch (checked: one result per item)."""
    results = list(task(items, handle))
    if len(results) != len(items):
        raise RuntimeError(f"the task returned {len(results)} results for {len(items)} items")
    return results


def _probe_scheduler(address: str) -> None:
    """Refuse at once a ``tcp://HOST:PORT`` where nothing listens (Dask would retry for 20 s).

    Other address forms (``tls://``, ``inproc://``, a scheduler file) are left to Dask.
    """
    import socket
    from urllib.parse import urlsplit

    from scenespeak.cleantext import clean_text

    try:
        parts = urlsplit(address if "://" in address else f"tcp://{address}")
        host, port = parts.hostname, parts.port
    except ValueError:
        raise InputError("--scheduler", f"{clean_text(address)!r} is not tcp://HOST:PORT") from None
    if parts.scheme != "tcp" or host is None or port is None:
        return
    try:
        socket.create_connection((host, port), timeout=5).close()
    except ConnectionRefusedError:
        raise InputError(
            "--scheduler", f"nothing listens at {clean_text(address)} (connection refused)"
        ) from None
    except OSError:
        return  # unreachable or slow: Client's own timeout says so


@contextmanager
def open_client(options: EngineOptions) -> Iterator[Client]:
    """A Dask client: to ``options.scheduler``, or to a new local cluster that it closes."""
    import dask
    from distributed import Client, LocalCluster

    if options.scheduler is not None:
        _probe_scheduler(options.scheduler)
        try:
            client = Client(options.scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise InputError(
                "--scheduler", f"cannot reach the Dask scheduler at {options.scheduler} ({exc})"
            ) from None
        with client:
            yield client
        return
    environ = {**dask.config.get("distributed.nanny.pre-spawn-environ"), **THREAD_ENVIRONMENT}
    with (
        dask.config.set({"distributed.nanny.pre-spawn-environ": environ}),
        LocalCluster(
            n_workers=options.workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port (8787 may be taken on a shared machine)
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client


def _database_plugin(path: Path) -> Any:
    import uuid

    from scenespeak.tools.dask_plugins import ShippedDatabase

    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(path, f"cannot read the object database ({exc.strerror})") from None
    # One name per run: two runs on one cluster never share (or unregister) each other's copy.
    digest = hashlib.sha1(data, usedforsecurity=False).hexdigest()[:12]
    return ShippedDatabase(f"scenespeak-db-{digest}-{uuid.uuid4().hex[:8]}", data)


def run_batches(
    task: Callable[[Sequence[T], DatabaseHandle], list[R]],
    items: Sequence[T],
    options: EngineOptions,
    *,
    on_results: Callable[[list[R]], Any],
    on_failure: Callable[[Sequence[T], str], Any] | None = None,
    database: str | PathLike[str] | None = None,
) -> None:
    """Run ``task`` over ``items`` in batches; hand each batch's results over as it finishes.

    Parameters
    ----------
    task : callable
        ``task(batch, handle) -> list`` (one result per item, same order), a module-level
        function (the workers import it). Per-item errors belong in its results; an exception
        fails the whole batch (retried ``options.retries`` times).
    items : sequence
        The work (small, picklable: e.g. folder names).
    options : EngineOptions
        Where and how to run.
    on_results : callable
        Called on this process with each finished batch's results, in completion order.
    on_failure : callable, optional
        Called with a batch's items and the error when the batch failed for good (after its
        retries, or on workers that kept dying); by default the error is raised.
    database : path, optional
        Object database file shipped once to every worker (``handle.get()`` in the task).
    """
    db_path = None if database is None else Path(database)
    if options.runs_in_process:
        _run_here(task, items, options, on_results, on_failure, db_path)
        return
    with open_client(options) as client:
        _run_on(client, task, items, options, on_results, on_failure, db_path)


def _run_here(
    task: Callable[[Sequence[T], DatabaseHandle], list[R]],
    items: Sequence[T],
    options: EngineOptions,
    on_results: Callable[[list[R]], Any],
    on_failure: Callable[[Sequence[T], str], Any] | None,
    db_path: Path | None,
) -> None:
    local = _OpenPerThread(db_path)
    handle = DatabaseHandle(None, local)
    try:
        # One item at a time: batching only saves scheduler round trips, and callers see each
        # item finish (progress per scene).
        for batch in _batches(items, 1):
            try:
                results = _run_task(task, batch.items, handle)
            except Exception as exc:
                if on_failure is None:
                    raise
                on_failure(batch.items, f"{type(exc).__name__}: {exc}")
                continue
            on_results(results)
    finally:
        local.close()


def _run_on(
    client: Client,
    task: Callable[[Sequence[T], DatabaseHandle], list[R]],
    items: Sequence[T],
    options: EngineOptions,
    on_results: Callable[[list[R]], Any],
    on_failure: Callable[[Sequence[T], str], Any] | None,
    db_path: Path | None,
) -> None:
    from distributed import as_completed

    from scenespeak.tools.dask_plugins import ThreadLimits

    plugin: Any = None
    if db_path is not None:
        plugin = _database_plugin(db_path)
        client.register_plugin(plugin, name=plugin.name)
    else:
        client.register_plugin(ThreadLimits(), name=ThreadLimits.name)
    handle = DatabaseHandle(None if plugin is None else plugin.name, scene_threads=1)
    limit = options.in_flight or max(2, 2 * sum(client.nthreads().values()))
    pending = _batches(items, options.batch)
    batch_of: dict[Any, _Batch[T]] = {}

    def submit() -> Any | None:
        batch = next(pending, None)
        if batch is None:
            return None
        future = client.submit(
            _run_task, task, batch.items, handle, retries=options.retries, pure=False
        )
        batch_of[future.key] = batch
        return future

    try:
        first = [f for f in (submit() for _ in range(limit)) if f is not None]
        running = as_completed(first)
        for future in running:
            batch = batch_of.pop(future.key)
            try:
                results = future.result()
            except Exception as exc:
                if on_failure is None:
                    raise
                on_failure(batch.items, f"{type(exc).__name__}: {exc}")
            else:
                on_results(results)
            finally:
                future.release()
            nxt = submit()
            if nxt is not None:
                running.add(nxt)
    finally:
        if plugin is not None:
            try:
                client.unregister_worker_plugin(plugin.name)
            except Exception:  # pragma: no cover - the cluster may be gone already
                pass
