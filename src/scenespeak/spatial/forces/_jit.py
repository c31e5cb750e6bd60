"""Whether the compiled kernel is used, and the decorator that compiles it (private).

Numba (the ``fast`` extra) compiles :mod:`~scenespeak.spatial.forces._sweep` to machine code
the first time it runs and keeps the result on disk (``cache=True``), so later processes load
it instead of compiling again. Where the cache goes, in Numba's order: the directory in
``NUMBA_CACHE_DIR`` if set; else ``__pycache__`` next to the source if writable; else the
user's cache directory; and if none of them can be written (a read-only install with no
writable home) a private directory under the system's temporary directory. If even that fails
the kernel is compiled in memory for each process: slower to start, never an error.

Loading is not free: importing Numba and loading the cached kernel cost a process about a
second of CPU (``benchmarks/bench_startup.py``: 1.45 s against 0.21 s for the reference's
first histogram, at load 10), while the NumPy reference computes a small
pair in well under a millisecond. So by default (``SCENESPEAK_NUMBA=auto``) a sweep runs
compiled when that one call is estimated to cost the reference at least :data:`LOAD_SECONDS`
(:func:`reference_seconds`, measured): such a call pays for loading Numba on its own. The
choice depends on the call only, never on what the process did before, so the same input gives
the same floats in a short command, a long-running service or a stream (the two kernels agree to
1e-9 relative, ``tests/spatial/test_forces_kernel.py``, but not bit for bit; a choice that
remembered earlier calls made ``serve`` and ``describe`` differ in the last digits). The few
histograms of a short command or of one stream frame cost what the reference costs; a scene of a
hundred objects runs compiled.

A cached function has its callees compiled into it, but Numba checks only the function's own
source file before loading it: after an edit of ``_table.py`` the cached ``_sweep.sweep``
would still be loaded, built against the old code (a stale cache can crash the process). So
the kernel's functions are cached under a stamp of every source file of this package
(:func:`_install_locator`): any edit here recompiles all of them once.

``SCENESPEAK_NUMBA=always`` loads Numba on the first histogram (benchmarks of the kernel);
``SCENESPEAK_NO_NUMBA=1`` (or ``SCENESPEAK_NUMBA=never``) never imports it.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import os
import tempfile
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

#: Set to "1" to use the NumPy reference even where Numba is installed.
DISABLE_ENV = "SCENESPEAK_NO_NUMBA"
#: ``auto`` (default), ``always`` or ``never``.
POLICY_ENV = "SCENESPEAK_NUMBA"

#: CPU seconds that importing Numba and loading the cached kernel cost a process (measured
#: with ``benchmarks/bench_startup.py``: first histogram 1.45 s with Numba, 0.21 s without, at
#: load 10; issue 16's first session: 1.37 s against 0.23 s at load 30). A call estimated to cost
#: the reference this much pays for loading Numba on its own.
LOAD_SECONDS = 1.0

_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy"}


def policy() -> str:
    """``"auto"``, ``"always"`` or ``"never"``, from the environment (read at every call)."""
    if os.environ.get(DISABLE_ENV, "") not in ("", "0"):
        return "never"
    value = os.environ.get(POLICY_ENV, "auto").strip().lower()
    if value in ("1", "always", "on", "yes"):
        return "always"
    if value in ("0", "never", "off", "no"):
        return "never"
    return "auto"


@functools.cache
def _numba() -> Any:
    """The numba module, or None when it is missing (imported once, lazily)."""
    try:
        return importlib.import_module("numba")
    except ImportError:  # pragma: no cover - depends on the installation
        return None


@functools.cache
def _installed() -> bool:
    return importlib.util.find_spec("numba") is not None


def available() -> bool:
    """Whether the compiled kernel can be used (Numba installed, not disabled); no import."""
    return policy() != "never" and _installed()


def loaded() -> bool:
    """Whether Numba has been loaded for the kernel in this process (and is not disabled)."""
    return policy() != "never" and _numba.cache_info().currsize > 0 and _numba() is not None


def reference_seconds(pairs: int, work: int) -> float:
    """Estimated CPU seconds of the NumPy reference for ``pairs`` pairs and ``work`` units.

    ``work`` is the sum over pairs of both objects' edge counts times the directions. Fitted
    on ``benchmarks/bench_forces.py``'s cases (idle core): 0.25 ms per pair of fixed cost and
    0.06-0.27 µs per unit (convex 30 + 30: 0.64 ms; stars 200 + 200: 19 ms; 512² masks: 13 ms).
    """
    return 2.5e-4 * pairs + 1.0e-7 * work


def wanted(pairs: int, work: int) -> bool:
    """Whether this sweep should run compiled (loading Numba now if this call pays for it; the
    choice depends on the call alone, see above)."""
    mode = policy()
    if mode == "never" or not _installed():
        return False
    if mode == "always" or reference_seconds(pairs, work) >= LOAD_SECONDS:
        return _numba() is not None
    return False


def _fallback_cache_dir() -> str:
    """A private, writable cache directory under the temporary directory."""
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    path = os.path.join(tempfile.gettempdir(), f"scenespeak-numba-{uid}")
    os.makedirs(path, mode=0o700, exist_ok=True)
    return path


@functools.cache
def _package_stamp() -> bytes:
    """SHA-256 of every source file of this package (``spatial/forces/*.py``)."""
    here = os.path.dirname(os.path.abspath(__file__))
    digest = hashlib.sha256()
    for name in sorted(os.listdir(here)):
        if name.endswith(".py"):
            with open(os.path.join(here, name), "rb") as f:
                digest.update(name.encode() + b"\0" + f.read())
    return digest.digest()


@functools.cache
def _install_locator() -> None:
    """Put a cache locator first in Numba's list that, for this package's files only, adds
    :func:`_package_stamp` to Numba's own stamp of the function's file (same cache place)."""
    from numba.core import caching

    # CacheImpl was _CacheImpl before Numba 0.61.
    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # type: ignore[attr-defined]
    here = os.path.dirname(os.path.abspath(__file__))

    class KernelLocator(caching._CacheLocator):
        def __init__(self, inner: Any) -> None:
            self._inner = inner
            self._py_file = inner._py_file

        def ensure_cache_path(self) -> None:
            self._inner.ensure_cache_path()

        def get_cache_path(self) -> Any:
            return self._inner.get_cache_path()

        def get_source_stamp(self) -> Any:
            return (self._inner.get_source_stamp(), _package_stamp())

        def get_disambiguator(self) -> Any:
            return self._inner.get_disambiguator()

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if os.path.dirname(os.path.abspath(py_file)) != here:
                return None
            for other in impl._locator_classes:
                if other is not cls:
                    inner = other.from_function(py_func, py_file)
                    if inner is not None:
                        return cls(inner)
            return None

    impl._locator_classes.insert(0, KernelLocator)


def jit(fn: F) -> F:
    """Compile ``fn`` with Numba (lazily, cached on disk); identity without Numba."""
    return _compiled(fn, _OPTIONS)


def jit_inline(fn: F) -> F:
    """:func:`jit`, and the function's body is inlined into every compiled caller (Numba's
    ``inline="always"``): for small helpers of an inner loop, which Numba otherwise calls
    through a pointer with the result returned in memory."""
    return _compiled(fn, {**_OPTIONS, "inline": "always"})


def jit_reassoc(fn: F) -> F:
    """:func:`jit`, and the function's floating-point additions and multiplications may be
    reassociated (Numba's ``fastmath={"reassoc"}``): for a sum over a loop, which the compiler
    can then vectorise (the order of the terms changes, so the last bits of the sum do)."""
    return _compiled(fn, {**_OPTIONS, "fastmath": {"reassoc"}})


def bitcasts() -> tuple[Callable[[int], float], Callable[[float], int]]:
    """``(as_float, as_int)``: the double with the bits of an int64 and back, in registers.

    With Numba, two LLVM ``bitcast`` intrinsics, which the compiler vectorises (reading a
    float's bits through an int64 view of its array needs a pass through memory); without it,
    the same through :mod:`struct`.

    With Numba they are usable in compiled code only (``tests/spatial/test_forces_kernel.py``
    checks them there against NumPy's views).

    Examples
    --------
    >>> as_float, as_int = bitcasts()
    >>> callable(as_float) and callable(as_int)
    True
    """
    numba = _numba() if available() else None
    if numba is None:
        import struct

        def as_float(b: int) -> float:
            return float(struct.unpack("<d", struct.pack("<q", b))[0])

        def as_int(x: float) -> int:
            return int(struct.unpack("<q", struct.pack("<d", x))[0])

        return as_float, as_int
    from llvmlite import ir
    from numba.extending import intrinsic

    @intrinsic
    def as_float_(typingctx: Any, b: Any) -> Any:
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.bitcast(args[0], ir.DoubleType())

        return numba.types.float64(numba.types.int64), codegen

    @intrinsic
    def as_int_(typingctx: Any, x: Any) -> Any:
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.bitcast(args[0], ir.IntType(64))

        return numba.types.int64(numba.types.float64), codegen

    to_float: Callable[[int], float] = as_float_  # type: ignore[assignment]
    to_int: Callable[[float], int] = as_int_  # type: ignore[assignment]
    return to_float, to_int


def _compiled(fn: F, options: dict[str, Any]) -> F:
    numba = _numba() if available() else None
    if numba is None:
        return fn
    try:
        _install_locator()
    except Exception:  # a Numba without this internal API: its own stamps only
        pass
    try:
        return numba.njit(cache=True, **options)(fn)
    except Exception:  # Numba raises RuntimeError when it has no cache directory
        pass
    try:
        numba.config.CACHE_DIR = _fallback_cache_dir()
        return numba.njit(cache=True, **options)(fn)
    except Exception:  # still no cache: compile in memory, in every process
        return numba.njit(cache=False, **options)(fn)
