"""Dask worker plugins of the engine (:mod:`scenespeak.tools.engine`).

Kept apart so that the engine, and ``evaluate`` in one process, import Dask only when a cluster
is used (Dask is the optional ``cluster`` extra).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from distributed.diagnostics.plugin import WorkerPlugin

from scenespeak.tools.engine import _OpenPerThread, limit_threads

if TYPE_CHECKING:  # pragma: no cover
    from scenespeak.perception.database import ObjectDatabase

__all__ = ["ShippedDatabase", "ThreadLimits"]


class ShippedDatabase(WorkerPlugin):
    """The object database's bytes, written once per worker and opened there once.

    Registered once per run (:meth:`distributed.Client.register_plugin`); the scheduler keeps
    it and gives it to every worker, including workers that join or restart later. ``setup``
    also limits the worker to one OpenCV/BLAS thread (:func:`~scenespeak.tools.engine.
    limit_threads`), writes the file into the worker's local directory and ``teardown`` (at
    the end of the run) closes and deletes it.
    """

    def __init__(self, name: str, data: bytes) -> None:
        self.name = name
        self.data = data
        self._db = _OpenPerThread(None)

    def __getstate__(self) -> dict[str, Any]:
        return {"name": self.name, "data": self.data}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.name = state["name"]
        self.data = state["data"]
        self._db = _OpenPerThread(None)

    def setup(self, worker: Any) -> None:
        limit_threads()
        path = Path(worker.local_directory) / f"{self.name}.db"
        path.write_bytes(self.data)
        self.data = b""  # the file holds it now
        self._db = _OpenPerThread(path)

    def teardown(self, worker: Any) -> None:
        self._db.close()
        if self._db.path is not None:
            self._db.path.unlink(missing_ok=True)

    def get(self) -> ObjectDatabase | None:
        """The worker's open database (one connection per thread)."""
        return self._db.get()


class ThreadLimits(WorkerPlugin):
    """For runs without a database: only one OpenCV/BLAS thread per worker."""

    name = "scenespeak-thread-limits"

    def setup(self, worker: Any) -> None:
        limit_threads()
