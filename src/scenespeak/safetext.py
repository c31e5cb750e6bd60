"""Reading text files as untrusted input, with the standard library only (no NumPy, no YAML).

What :mod:`scenespeak.safeio` does for every file, kept here so that paths which must start in
milliseconds (``scenespeak ask --scene FILE``: the dialogue half imports no NumPy) read files
with the same bounds and the same messages:

* :func:`as_path`: a usable file name or one clear error (not a ``TypeError``).
* :func:`read_bytes` / :func:`read_text`: only regular files (a FIFO never blocks, a device is
  never read), under :attr:`~scenespeak.limits.Limits.max_file_bytes` /
  ``max_text_bytes``, checked before reading.
* :func:`load_json`: nesting bounded before parsing (``max_nesting``: no ``RecursionError``),
  integers of at most ``max_int_digits`` digits, numbers within ``max_abs_number``.

:mod:`scenespeak.safeio` re-exports all of them.

>>> load_json('{"a": [1, 2.5]}', "x.json")
{'a': [1, 2.5]}
>>> load_json("[" * 100 + "]" * 100, "x.json")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
scenespeak.errors.InputError: x.json: nesting is 100 levels deep, which is over the limit of 64 ...
"""

from __future__ import annotations

import errno
import json
import math
import os
import re
import stat
from collections.abc import Callable
from os import PathLike
from pathlib import Path
from typing import Any

from scenespeak import limits as _limits
from scenespeak.cleantext import clean_text
from scenespeak.errors import InputError

__all__ = ["as_path", "check_output", "load_json", "read_bytes", "read_text"]

ErrorType = type[InputError]
_BRACKETS = re.compile(r"[\[\]{}]")


def bracket_depth(text: str) -> int:
    """The deepest nesting of ``[ ]`` / ``{ }`` in ``text`` (strings already blanked), or the
    number of opening brackets when that is within ``max_nesting`` (then so is the depth).

    Pure Python, so the scan runs only on bracket-heavy text (16 MB of brackets: about a
    second, once).

    >>> bracket_depth("[" * 70 + "]" * 70 + "[]")
    70
    """
    opening = text.count("[") + text.count("{")
    if opening <= _limits.current().max_nesting:
        return opening
    depth = best = 0
    for ch in _BRACKETS.findall(text):
        depth += 1 if ch in "[{" else -1
        best = max(best, depth)
    return best


def _kind_of(mode: int) -> str | None:
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    if stat.S_ISFIFO(mode):
        return "is a FIFO (named pipe), not a regular file: it would block; copy it to a file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "is a device, not a regular file"
    if stat.S_ISSOCK(mode):
        return "is a socket, not a regular file"
    return "is not a regular file"


def as_path(path: object, *, error: ErrorType = InputError) -> Path:
    """``path`` as a :class:`~pathlib.Path`, or ``error`` if it is not a usable file name.

    Checked first by every reader, so that ``None``, a number or ``bytes`` passed by mistake
    is one clear error, not a ``TypeError`` from deep inside ``pathlib`` or OpenCV.

    >>> as_path("left.png").name
    'left.png'
    >>> as_path(123)
    Traceback (most recent call last):
    ...
    scenespeak.errors.InputError: expected a file name (str or path), got int
    """
    if not isinstance(path, str | PathLike) or isinstance(path, bytes):
        raise error(None, f"expected a file name (str or path), got {type(path).__name__}")
    text = os.fspath(path)
    if not isinstance(text, str):
        raise error(None, f"expected a file name (str or path), got {type(text).__name__}")
    if not text or "\x00" in text:
        raise error(clean_text(repr(text)), "is not a valid file name")
    return Path(text)


def read_bytes(
    path: str | PathLike[str],
    *,
    error: ErrorType = InputError,
    max_bytes: int | None = None,
    what: str = "file",
) -> bytes:
    """Read a whole regular file, refusing what is not one or is too large.

    Parameters
    ----------
    path : str or path-like
    error : InputError subclass
        Raised with the path and the problem.
    max_bytes : int, optional
        Default :attr:`~scenespeak.limits.Limits.max_file_bytes`.
    what : str
        What the file is, for messages ("calibration file", "image", …).
    """
    p = as_path(path, error=error)
    limit = _limits.current().max_file_bytes if max_bytes is None else max_bytes
    name = "max_file_bytes" if max_bytes is None else "max_text_bytes"
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise error(p, "no such file") from None
    except IsADirectoryError:
        raise error(p, f"is a folder, not a {what}") from None
    except OSError as exc:
        raise error(p, _os_problem(exc)) from None
    try:
        st = os.fstat(fd)
        problem = _kind_of(st.st_mode)
        if problem is not None:
            raise error(p, problem.replace("a file", f"a {what}"))
        if st.st_size > limit:
            raise error(p, _limits.exceeded(name, f"the file is {st.st_size} bytes, which", limit))
        if st.st_size == 0:
            raise error(p, "the file is empty (0 bytes)")
        os.set_blocking(fd, True)
        chunks: list[bytes] = []
        total = 0
        while True:  # a file growing while read is still bounded
            chunk = os.read(fd, min(1 << 20, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:
                raise error(p, _limits.exceeded(name, "the file (growing while read)", limit))
        return b"".join(chunks)
    except OSError as exc:
        raise error(p, _os_problem(exc)) from None
    finally:
        os.close(fd)


def _os_problem(exc: OSError) -> str:
    if exc.errno == errno.ENAMETOOLONG:
        return "the file name is too long for this system"
    if exc.errno == errno.EACCES:
        return "permission denied"
    if exc.errno == errno.ENOTDIR:
        return "a part of the path is not a folder"
    if exc.errno == errno.ELOOP:
        return "too many levels of symbolic links"
    return f"cannot be read ({exc.strerror or exc})"


def read_text(
    path: str | PathLike[str], *, error: ErrorType = InputError, what: str = "text file"
) -> str:
    """Read a UTF-8 text file under :attr:`~scenespeak.limits.Limits.max_text_bytes`."""
    data = read_bytes(path, error=error, max_bytes=_limits.current().max_text_bytes, what=what)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(
            Path(path), f"is not UTF-8 text (byte {exc.start}); expected a {what}"
        ) from None
    if not text.strip():
        raise error(Path(path), "the file is empty (only white space)")
    return text


def _strip_strings(text: str) -> str:
    return re.sub(r'"(?:[^"\\\n]|\\.)*"', '""', text)


def _check_depth(depth: int, source: str | PathLike[str], error: ErrorType) -> None:
    if depth > _limits.current().max_nesting:
        raise error(
            source, _limits.exceeded("max_nesting", f"nesting is {depth} levels deep, which", 0)
        )


def _number_checks(
    source: str | PathLike[str], error: ErrorType
) -> tuple[Callable[[str], int], Callable[[str], float]]:
    lim = _limits.current()

    def parse_int(s: str) -> int:
        digits = len(s.lstrip("+-"))
        if digits > lim.max_int_digits:
            raise error(
                source,
                _limits.exceeded("max_int_digits", f"an integer of {digits} digits", 0),
            )
        value = int(s)
        if abs(value) > lim.max_abs_number:
            raise error(source, _limits.exceeded("max_abs_number", f"the number {s}", 0))
        return value

    def parse_float(s: str) -> float:
        value = float(s)
        if math.isfinite(value) and abs(value) > lim.max_abs_number:
            raise error(source, _limits.exceeded("max_abs_number", f"the number {s[:40]}", 0))
        if not math.isfinite(value):
            raise error(source, f"the number {s[:40]} is out of range (not a finite float)")
        return value

    return parse_int, parse_float


def load_json(text: str, source: str | PathLike[str], *, error: ErrorType = InputError) -> Any:
    """Parse JSON with bounded nesting and numbers (see the module docstring)."""
    depth = bracket_depth(_strip_strings(text))
    if depth > _limits.current().max_nesting:
        _check_depth(depth, source, error)
    parse_int, parse_float = _number_checks(source, error)
    try:
        return json.loads(text, parse_int=parse_int, parse_float=parse_float)
    except json.JSONDecodeError as exc:
        raise error(
            source, f"is not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    except RecursionError:
        raise error(source, "nesting is too deep") from None
    except InputError:
        raise
    except ValueError as exc:  # Python's own int-digits limit, surrogates, …
        raise error(source, f"is not valid JSON ({clean_text(str(exc))[:120]})") from None


def check_output(path: object, *, error: ErrorType = InputError, what: str = "file") -> Path:
    """``path`` as a place a new file may be written (by a temporary file and a rename).

    Refused: a missing folder, and a name that exists as anything but a regular file or a
    symbolic link — a folder, a FIFO, a socket or a device. A rename over ``/dev/full`` would
    replace the device itself (as root): never. A symbolic link is replaced, not written
    through.

    >>> check_output("/dev/null")
    Traceback (most recent call last):
    ...
    scenespeak.errors.InputError: /dev/null: is a device, not a regular file; give a file name
    """
    p = as_path(path, error=error)
    try:
        st = os.lstat(p)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise error(p, _os_problem(exc)) from None
    if st is not None and not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
        problem = _kind_of(st.st_mode) or "is not a regular file"
        raise error(p, problem.split(":")[0] + f"; give a {what} name")
    if not p.parent.is_dir():
        raise error(p, f"the folder {str(p.parent)!r} does not exist")
    return p
