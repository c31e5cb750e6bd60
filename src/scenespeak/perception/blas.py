"""BLAS and FAISS threads: limit them inside a block (the matrices here are small)."""

from __future__ import annotations

import contextlib
import functools
import sys
from collections.abc import Iterator
from typing import Any

__all__ = ["omp_threads", "single_threaded_blas"]


def single_threaded_blas() -> contextlib.AbstractContextManager[object]:
    """Limit BLAS to one thread for the duration of a ``with`` block (if threadpoolctl is here).

    Finding the loaded BLAS libraries takes threadpoolctl ~2 ms per call (it walks the
    process's shared objects); the controller is kept and made again only when modules were
    imported since (a new extension module may bring its own BLAS).
    """
    controller = _blas_controller(len(sys.modules))
    if controller is None:  # pragma: no cover - threadpoolctl is a declared dependency
        return contextlib.nullcontext()
    return controller.limit(limits=1, user_api="blas")


@functools.lru_cache(maxsize=1)
def _blas_controller(_n_modules: int) -> Any:
    """A ``threadpoolctl.ThreadpoolController`` (cached per number of imported modules)."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - a declared dependency
        return None
    return ThreadpoolController()


@contextlib.contextmanager
def omp_threads(threads: int | None) -> Iterator[None]:
    """FAISS's OpenMP threads for this thread's searches inside the block (None: as they are).

    OpenMP keeps the thread count per calling thread, so the pipeline's two threads each set
    their own and restore it afterwards.
    """
    if threads is None:
        yield
        return
    import faiss  # optional dependency

    before = faiss.omp_get_max_threads()
    faiss.omp_set_num_threads(max(1, int(threads)))
    try:
        yield
    finally:
        faiss.omp_set_num_threads(before)
