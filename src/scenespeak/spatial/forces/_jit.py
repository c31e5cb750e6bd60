"""Whether the compiled kernel is available, and the decorator that compiles it (private).

Numba (the ``fast`` extra) compiles :mod:`~scenespeak.spatial.forces._sweep` to machine code
the first time it runs and keeps the result on disk (``cache=True``), so later processes load
it in milliseconds instead of compiling again. Where the cache goes, in Numba's order: the
directory in ``NUMBA_CACHE_DIR`` if set; else ``__pycache__`` next to the source if writable;
else the user's cache directory; and if none of them can be written (a read-only install with
no writable home) a private directory under the system's temporary directory. If even that
fails the kernel is compiled in memory for each process: slower to start, never an error.

Without Numba, or with the environment variable ``SCENESPEAK_NO_NUMBA=1``, :func:`available`
is False and the force histograms use the NumPy reference (the same results to 1e-9
relative; tested). Numba is imported on the first histogram, not with the package (it takes
about 0.3 s), so commands that compute none never pay for it.
"""

from __future__ import annotations

import functools
import importlib
import os
import tempfile
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

#: Set to "1" to use the NumPy reference even where Numba is installed.
DISABLE_ENV = "SCENESPEAK_NO_NUMBA"

_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy"}


@functools.cache
def _numba() -> Any:
    """The numba module, or None when it is missing or disabled (imported once, lazily)."""
    if os.environ.get(DISABLE_ENV, "") not in ("", "0"):
        return None
    try:
        return importlib.import_module("numba")
    except ImportError:  # pragma: no cover - depends on the installation
        return None


def available() -> bool:
    """Whether the compiled kernel can be used (Numba importable, not disabled)."""
    return _numba() is not None


def _fallback_cache_dir() -> str:
    """A private, writable cache directory under the temporary directory."""
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    path = os.path.join(tempfile.gettempdir(), f"scenespeak-numba-{uid}")
    os.makedirs(path, mode=0o700, exist_ok=True)
    return path


def jit(fn: F) -> F:
    """Compile ``fn`` with Numba (lazily, cached on disk); identity without Numba."""
    numba = _numba()
    if numba is None:
        return fn
    try:
        return numba.njit(cache=True, **_OPTIONS)(fn)
    except Exception:  # Numba raises RuntimeError when it has no cache directory
        pass
    try:
        numba.config.CACHE_DIR = _fallback_cache_dir()
        return numba.njit(cache=True, **_OPTIONS)(fn)
    except Exception:  # still no cache: compile in memory, in every process
        return numba.njit(cache=False, **_OPTIONS)(fn)
