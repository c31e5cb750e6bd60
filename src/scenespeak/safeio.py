"""Readers that treat every file as untrusted (see ``docs/trust.md``).

* :func:`read_bytes` / :func:`read_text`: refuse a missing path, a folder, a FIFO, a device, a
  socket, an over-long name and a file over :attr:`~scenespeak.limits.Limits.max_file_bytes`
  *before* reading (the file is opened non-blocking and checked with ``fstat``, so a FIFO never
  blocks and ``/dev/zero`` is never read).
* :func:`load_json`: nesting depth bounded before parsing (no ``RecursionError``), integers of at
  most ``max_int_digits`` digits, numbers within ``max_abs_number``.
* :func:`load_yaml`: a safe loader (no ``!!python/...`` tags: nothing from a file ever runs), the
  node graph bounded after alias expansion (a "billion laughs" file is refused in microseconds),
  nesting and numbers bounded as for JSON.
* :func:`check_xml`: refuses a DOCTYPE or entity declaration (no entity expansion, no external
  entities) and over-deep nesting before OpenCV's FileStorage parses it.
* :func:`image_size_from_header`: width and height from a PNG, JPEG, TIFF, BMP, PNM or WebP
  header, so :func:`decode_image` refuses a 50,000 x 50,000 image before decoding it.
* :func:`decode_image`: OpenCV's and libpng's own warnings are captured instead of printed
  (a corrupt file gives our one line, not three).
* :func:`clean_text`: terminal escape sequences, control characters and unpaired surrogates
  shown as visible escapes, for every label or message we print.

>>> clean_text("mug\\x1b[31m red")
'mug\\\\x1b[31m red'
>>> load_json('{"a": [1, 2.5]}', "x.json")
{'a': [1, 2.5]}
>>> load_json("[" * 100 + "]" * 100, "x.json")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
scenespeak.errors.InputError: x.json: nesting is 100 levels deep, which is over the limit of 64 ...
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import struct
import tempfile
import threading
from collections.abc import Iterator
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from scenespeak import limits as _limits
from scenespeak.cleantext import check_label, clean_text
from scenespeak.errors import ImageError, InputError
from scenespeak.safetext import (
    _check_depth,
    _strip_strings,
    as_path,
    load_json,
    read_bytes,
    read_text,
)

if TYPE_CHECKING:  # PyYAML is imported when YAML is read (~20 ms of every command's start-up)
    import yaml

__all__ = [
    "as_path",
    "captured_stderr",
    "check_label",
    "check_xml",
    "clean_text",
    "decode_image",
    "image_size_from_header",
    "load_json",
    "load_yaml",
    "quiet_opencv",
    "read_bytes",
    "read_text",
    "within",
]

ErrorType = type[InputError]

# --------------------------------------------------------------------------------------------
# printing

# --------------------------------------------------------------------------------------------
# files


def within(root: str | PathLike[str], entry: str, source: str | PathLike[str]) -> Path:
    """``root / entry`` resolved, refused unless it stays inside ``root``.

    For paths read from a file (e.g. a dataset's scene folders): absolute paths, ``..`` that
    climbs out, and symbolic links that lead out are refused.

    >>> within("/data/set", "scene_000", "dataset.json").as_posix()
    '/data/set/scene_000'
    """
    base = Path(root).resolve()
    if not isinstance(entry, str) or not entry or "\x00" in entry:
        raise InputError(source, f"entry {clean_text(repr(entry))} is not a folder name")
    if Path(entry).is_absolute():
        raise InputError(
            source,
            f"entry {clean_text(repr(entry))} is an absolute path, outside the dataset folder; "
            "entries are folder names inside it",
        )
    target = (base / entry).resolve()
    if not target.is_relative_to(base):
        raise InputError(
            source, f"entry {clean_text(repr(entry))} leads outside the dataset folder {base}"
        )
    return target


# --------------------------------------------------------------------------------------------
# JSON and YAML


def _bracket_depth(text: str, opening: str = "[{", closing: str = "]}") -> int:
    data = np.frombuffer(text.encode("utf-8", "replace"), np.uint8)
    if data.size == 0:
        return 0
    step = np.zeros(data.size, np.int32)
    for ch in opening:
        step[data == ord(ch)] = 1
    for ch in closing:
        step[data == ord(ch)] = -1
    return int(np.cumsum(step).max(initial=0))


_ALLOWED_TAG_PREFIXES = ("tag:yaml.org,2002:",)
_REFUSED_TAG_PREFIXES = ("tag:yaml.org,2002:python/",)


def _check_tag(n: yaml.Node, source: str | PathLike[str], error: ErrorType) -> None:
    """Refuse a node whose tag is python's or not one of YAML's own."""
    tag = n.tag or ""
    if tag.startswith(_REFUSED_TAG_PREFIXES) or not tag.startswith(_ALLOWED_TAG_PREFIXES):
        raise error(source, f"uses the YAML tag {clean_text(tag)!r}, which is not allowed")


def _yaml_children(n: yaml.Node) -> list[yaml.Node]:
    """A node's children: a sequence's items, a mapping's keys and values."""
    import yaml

    if isinstance(n, yaml.SequenceNode):
        return list(n.value)
    if isinstance(n, yaml.MappingNode):
        return [x for kv in n.value for x in kv]
    return []


def _record_size(
    n: yaml.Node,
    children: list[yaml.Node],
    sizes: dict[int, int],
    source: str | PathLike[str],
    error: ErrorType,
) -> None:
    """Memoise ``n``'s expanded size (its children's are known) and refuse it over the limit."""
    total = 1 + sum(sizes[id(c)] for c in children)
    sizes[id(n)] = total
    if total > _limits.current().max_yaml_nodes:
        raise error(
            source,
            _limits.exceeded(
                "max_yaml_nodes",
                f"the YAML expands to more than {total} nodes (aliases), which",
                0,
            ),
        )


def _yaml_walk(node: yaml.Node, source: str | PathLike[str], error: ErrorType) -> None:
    """Refuse unknown tags, deep nesting, and alias expansion over ``max_yaml_nodes``."""
    lim = _limits.current()
    sizes: dict[int, int] = {}
    # iterative post-order with memoised expanded sizes: aliases are shared node objects
    stack: list[tuple[yaml.Node, int, bool]] = [(node, 1, False)]
    while stack:
        n, depth, done = stack.pop()
        if id(n) in sizes and not done:
            continue
        if depth > lim.max_nesting:
            _check_depth(depth, source, error)
        _check_tag(n, source, error)
        children = _yaml_children(n)
        if done:
            _record_size(n, children, sizes, source, error)
            continue
        stack.append((n, depth, True))
        for c in children:
            if id(c) not in sizes:
                stack.append((c, depth + 1, False))


def load_yaml(
    text: str,
    source: str | PathLike[str],
    *,
    loader: type[yaml.SafeLoader] | None = None,
    error: ErrorType = InputError,
) -> Any:
    """Parse YAML safely: no python tags, aliases bounded, nesting and numbers bounded.

    ``loader`` must derive from :class:`yaml.SafeLoader` (e.g. one that adds OpenCV's
    ``!!opencv-matrix``; those tags are under ``tag:yaml.org,2002:`` and allowed); None:
    :class:`yaml.SafeLoader`.
    """
    import yaml

    if loader is None:
        loader = yaml.SafeLoader
    lines = text.splitlines()
    if lines and lines[0].startswith("%YAML"):
        lines = lines[1:]  # OpenCV writes "%YAML:1.0", which PyYAML rejects
    body = "\n".join(lines)
    _check_depth(_bracket_depth(_strip_strings(body)), source, error)
    indents = [len(ln) - len(ln.lstrip(" -")) for ln in lines if ln.strip()]
    if indents and max(indents) > 4 * _limits.current().max_nesting:
        _check_depth(max(indents) // 2, source, error)
    ld = loader(body)
    try:
        node = ld.get_single_node()
        if node is None:
            return None
        _yaml_walk(node, source, error)
        data = ld.construct_document(node)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise error(source, f"is not valid YAML{where}") from None
    except RecursionError:
        raise error(source, "nesting is too deep") from None
    except InputError:
        raise
    except (ValueError, OverflowError, TypeError) as exc:
        raise error(source, f"is not valid YAML ({clean_text(str(exc))[:120]})") from None
    finally:
        ld.dispose()
    _check_numbers(data, source, error)
    return data


def _check_numbers(data: Any, source: str | PathLike[str], error: ErrorType) -> None:
    lim = _limits.current()
    stack = [data]
    while stack:
        x = stack.pop()
        if isinstance(x, dict):
            stack.extend(x.keys())
            stack.extend(x.values())
        elif isinstance(x, list | tuple):
            stack.extend(x)
        elif isinstance(x, bool):
            continue
        elif isinstance(x, int):
            if abs(x) > lim.max_abs_number:
                digits = len(str(abs(x))) if abs(x) < 10**4000 else 4000
                raise error(
                    source, _limits.exceeded("max_abs_number", f"an integer of {digits} digits", 0)
                )
        elif isinstance(x, float) and math.isfinite(x) and abs(x) > lim.max_abs_number:
            raise error(source, _limits.exceeded("max_abs_number", f"the number {x:g}", 0))


def check_xml(data: bytes, source: str | PathLike[str], *, error: ErrorType = InputError) -> None:
    """Refuse XML that declares a DOCTYPE or entities, or nests too deep (before parsing)."""
    head = data.lstrip()
    if not head.startswith(b"<"):
        raise error(source, "is not XML (it does not start with '<')")
    low = data.lower()
    if b"<!doctype" in low or b"<!entity" in low:
        raise error(
            source, "declares a DOCTYPE or entities, which are not accepted (no entity expansion)"
        )
    text = data.decode("utf-8", "replace")
    text = re.sub(r"<\?.*?\?>|<!--.*?-->|<!\[CDATA\[.*?\]\]>", "", text, flags=re.S)
    opens = len(re.findall(r"<[A-Za-z_]", text))
    if opens:
        depth = _xml_depth(text)
        _check_depth(depth, source, error)


def _xml_depth(text: str) -> int:
    depth = best = 0
    for m in re.finditer(r"<(/?)[A-Za-z_][^>]*?(/?)>", text):
        if m.group(1):
            depth -= 1
        elif not m.group(2):
            depth += 1
            best = max(best, depth)
    return best


# --------------------------------------------------------------------------------------------
# images


def _png_size(b: bytes) -> tuple[int, int] | None:
    if b[:8] == b"\x89PNG\r\n\x1a\n" and len(b) >= 24 and b[12:16] == b"IHDR":
        w, h = struct.unpack(">II", b[16:24])
        return int(w), int(h)
    return None


def _jpeg_size(b: bytes) -> tuple[int, int] | None:
    if b[:2] != b"\xff\xd8":
        return None
    i = 2
    n = len(b)
    while i + 4 <= n:
        if b[i] != 0xFF:
            i += 1
            continue
        marker = b[i + 1]
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7 or marker == 0xFF:
            i += 1 if marker == 0xFF else 2
            continue
        length = struct.unpack(">H", b[i + 2 : i + 4])[0]
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC) and i + 9 <= n:
            h, w = struct.unpack(">HH", b[i + 5 : i + 9])
            return int(w), int(h)
        i += 2 + length
    return None


def _tiff_size(b: bytes) -> tuple[int, int] | None:
    if b[:4] not in (b"II*\x00", b"MM\x00*") or len(b) < 8:
        return None
    end = "<" if b[:2] == b"II" else ">"
    off = struct.unpack(end + "I", b[4:8])[0]
    if off + 2 > len(b):
        return None
    count = struct.unpack(end + "H", b[off : off + 2])[0]
    w = h = None
    for k in range(min(count, 4096)):
        e = off + 2 + 12 * k
        if e + 12 > len(b):
            break
        tag, typ = struct.unpack(end + "HH", b[e : e + 4])
        if typ == 3:
            val = struct.unpack(end + "H", b[e + 8 : e + 10])[0]
        else:
            val = struct.unpack(end + "I", b[e + 8 : e + 12])[0]
        if tag == 256:
            w = val
        elif tag == 257:
            h = val
    return (int(w), int(h)) if w is not None and h is not None else None


def _bmp_size(b: bytes) -> tuple[int, int] | None:
    if b[:2] == b"BM" and len(b) >= 26:
        w, h = struct.unpack("<ii", b[18:26])
        return abs(int(w)), abs(int(h))
    return None


def _pnm_size(b: bytes) -> tuple[int, int] | None:
    m = re.match(rb"P[1-7]\s+(?:#[^\n]*\n\s*)*(\d+)\s+(?:#[^\n]*\n\s*)*(\d+)", b[:512])
    if m is None:
        return None
    return int(m.group(1)[:12]), int(m.group(2)[:12])


def _webp_size(b: bytes) -> tuple[int, int] | None:
    if b[:4] != b"RIFF" or b[8:12] != b"WEBP" or len(b) < 30:
        return None
    kind = b[12:16]
    if kind == b"VP8X":
        w = 1 + int.from_bytes(b[24:27], "little")
        h = 1 + int.from_bytes(b[27:30], "little")
        return w, h
    if kind == b"VP8 ":
        w, h = struct.unpack("<HH", b[26:30])
        return w & 0x3FFF, h & 0x3FFF
    if kind == b"VP8L" and len(b) >= 25:
        bits = int.from_bytes(b[21:25], "little")
        return 1 + (bits & 0x3FFF), 1 + ((bits >> 14) & 0x3FFF)
    return None


def image_size_from_header(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` from an image file's header, or None when the format is unknown.

    >>> import cv2, numpy as np
    >>> image_size_from_header(cv2.imencode(".png", np.zeros((3, 5), np.uint8))[1].tobytes())
    (5, 3)
    """
    for reader in (_png_size, _jpeg_size, _tiff_size, _bmp_size, _pnm_size, _webp_size):
        try:
            size = reader(data)
        except (struct.error, ValueError, IndexError):
            size = None
        if size is not None:
            return size
    return None


def check_image_header(data: bytes, source: str | PathLike[str]) -> tuple[int, int] | None:
    """Refuse an image whose header declares too many pixels (before any decoding)."""
    size = image_size_from_header(data)
    if size is None:
        return None
    w, h = size
    lim = _limits.current()
    if w == 0 or h == 0:
        raise ImageError(source, f"the image header declares a size of {w} x {h} pixels")
    if max(w, h) > lim.max_image_side:
        raise ImageError(
            source, _limits.exceeded("max_image_side", f"the image is {w} x {h} pixels: a side", 0)
        )
    if w * h > lim.max_image_pixels:
        raise ImageError(
            source,
            _limits.exceeded(
                "max_image_pixels", f"the image is {w} x {h} = {w * h} pixels, which", 0
            ),
        )
    return size


_FD_LOCK = threading.Lock()


def quiet_opencv() -> None:
    """Silence OpenCV's own log lines (``[ WARN:0@…] …``); scenespeak says what matters once."""
    import cv2

    os.environ.setdefault("OPENCV_LOG_LEVEL", "SILENT")
    try:
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    except AttributeError:  # pragma: no cover - very old OpenCV
        getattr(cv2, "setLogLevel", lambda level: None)(0)


@contextlib.contextmanager
def captured_stderr() -> Iterator[list[str]]:
    """Capture what C libraries (FFmpeg, libpng, OpenCV) write to the process's stderr.

    Yields a list that holds the captured text (at most 4 KiB) when the block ends, so the
    caller can say it once, in its own words, instead of the libraries' lines before its own.

    >>> with captured_stderr() as noise:
    ...     _ = os.write(2, b"[mov @ 0x1] moov atom not found")
    >>> noise
    ['[mov @ 0x1] moov atom not found']
    """
    noise: list[str] = []
    with _FD_LOCK, tempfile.TemporaryFile() as capture:
        saved = os.dup(2)
        try:
            os.dup2(capture.fileno(), 2)
            yield noise
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            capture.seek(0)
            noise.append(capture.read(4096).decode("utf-8", "replace"))


def decode_image(
    data: bytes, source: str | PathLike[str], *, flags: int | None = None
) -> NDArray[np.generic]:
    """Decode image bytes with OpenCV, checking the header first and capturing library noise.

    Anything OpenCV or libpng writes to the process's stderr while decoding (truncated data,
    CRC errors) is captured, and the image is then refused with one message of ours.

    Raises
    ------
    ImageError
        Too many pixels (from the header), undecodable, or decoded with library warnings.
    """
    import cv2

    quiet_opencv()
    check_image_header(data, source)
    buf = np.frombuffer(data, np.uint8)
    mode = cv2.IMREAD_UNCHANGED if flags is None else flags
    with _FD_LOCK, tempfile.TemporaryFile() as capture:
        saved = os.dup(2)
        try:
            os.dup2(capture.fileno(), 2)
            try:
                image = cv2.imdecode(buf, mode)
            except cv2.error:
                image = None
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        capture.seek(0)
        noise = capture.read(4096).decode("utf-8", "replace")
    if image is None or image.size == 0:
        hint = _noise_hint(noise)
        raise ImageError(source, f"cannot be read as an image ({hint})")
    if noise.strip():
        raise ImageError(source, f"the image is damaged ({_noise_hint(noise)})")
    return image


def _noise_hint(noise: str) -> str:
    low = noise.lower()
    if "incomplete" in low or "truncat" in low or "premature" in low:
        return "the file is truncated"
    if "crc" in low or "incorrect data check" in low or "corrupt" in low:
        return "the data is corrupt (checksum error)"
    return "corrupt or unsupported format"
