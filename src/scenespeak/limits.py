"""Bounds on every input scenespeak reads, in one place (see ``docs/trust.md``).

Every reader checks the relevant bound *before* the work (an image's pixel count from its
header before decoding, a file's size from ``fstat`` before reading, a count read from the
database before allocating) and refuses with a message that names the limit and how to raise it::

    left.png: the image is 50000 x 50000 = 2500000000 pixels, over the limit of 100000000
    (max_image_pixels; raise it with --limit max_image_pixels=N)

The limits in force are a :class:`Limits` value. Library functions use :func:`current`, which is
:data:`DEFAULT` unless a caller wraps the work in :func:`using` (a context variable, so threads
and tasks each see their own); the command line's ``--limit NAME=VALUE`` option does exactly that.

>>> from scenespeak import limits
>>> limits.current().max_image_pixels
40000000
>>> with limits.using(limits.Limits(max_image_pixels=10)):
...     limits.current().max_image_pixels
10
>>> limits.parse_assignments(["max_file_bytes=1e6"]).max_file_bytes
1000000
"""

from __future__ import annotations

import contextvars
import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, fields, replace

from scenespeak.errors import InputError

__all__ = [
    "DEFAULT",
    "Limits",
    "current",
    "exceeded",
    "install",
    "parse_assignments",
    "using",
]


@dataclass(frozen=True)
class Limits:
    """The bounds on inputs. Every field is a positive number; see ``docs/trust.md``.

    Attributes
    ----------
    max_file_bytes : int
        Size of any one input file (image, calibration, truth, dataset index).
    max_text_bytes : int
        Size of a text input (calibration, truth, ``dataset.json``, labels files).
    max_image_pixels : int
        Width times height of one image, read from the header before decoding.
    max_image_side : int
        Width or height of one image.
    max_nesting : int
        Nesting depth of JSON / YAML / XML.
    max_yaml_nodes : int
        Nodes of a YAML document after expanding aliases (anchors: "billion laughs").
    max_int_digits : int
        Digits of an integer in JSON / YAML.
    max_abs_number : float
        Magnitude of any number in a calibration or truth file.
    max_db_descriptors : int
        Descriptors a database row may claim (checked before allocating).
    max_db_outline : int
        Vertices of a stored outline.
    max_db_objects : int
        Objects in one database.
    max_label_chars : int
        Characters of an object label.
    max_directions : int
        Directions of a histogram of forces.
    max_vertices : int
        Vertices of a polygon given to the spatial API.
    max_scenes : int
        Scenes of a generated or evaluated dataset.
    max_workers : int
        Worker processes of ``evaluate``.
    max_baseline_m, min_baseline_m : float
        A stereo rig's baseline in metres (larger: "looks like millimetres").
    max_scene_depth_m : float
        Median depth of a scene's points.
    min_median_disparity_px : float
        Median disparity of a scene's points.
    db_wait_s : float
        Seconds a database command waits for another process's write to finish.
    """

    max_file_bytes: int = 512 * 1024 * 1024
    max_text_bytes: int = 16 * 1024 * 1024
    max_image_pixels: int = 40_000_000
    max_image_side: int = 32_768
    max_nesting: int = 64
    max_yaml_nodes: int = 200_000
    max_int_digits: int = 30
    max_abs_number: float = 1e15
    max_db_descriptors: int = 5_000_000
    max_db_outline: int = 100_000
    max_db_objects: int = 100_000
    max_label_chars: int = 200
    max_directions: int = 100_000
    max_vertices: int = 1_000_000
    max_scenes: int = 100_000
    max_workers: int = 256
    max_baseline_m: float = 3.0
    min_baseline_m: float = 0.002
    max_scene_depth_m: float = 100.0
    min_median_disparity_px: float = 0.5
    db_wait_s: float = 30.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
                raise InputError("--limit", f"{f.name} must be a positive number, got {value!r}")


DEFAULT = Limits()
"""The limits used when nobody asked for others."""

_CURRENT: contextvars.ContextVar[Limits] = contextvars.ContextVar(
    "scenespeak_limits", default=DEFAULT
)


def current() -> Limits:
    """The limits in force here (:data:`DEFAULT` unless inside :func:`using`)."""
    return _CURRENT.get()


def install(limits: Limits) -> None:
    """Use ``limits`` for the rest of the current context (the CLI runs each command in its own
    copy of the context, see :func:`scenespeak.cli.main`); prefer :func:`using` elsewhere."""
    _CURRENT.set(limits)


@contextmanager
def using(limits: Limits) -> Iterator[Limits]:
    """Run the enclosed work under ``limits`` (restored on exit)."""
    token = _CURRENT.set(limits)
    try:
        yield limits
    finally:
        _CURRENT.reset(token)


def exceeded(name: str, what: str, value: float | str) -> str:
    """The standard wording of a limit being exceeded: what, the limit, how to raise it.

    >>> print(exceeded("max_directions", "2**40 directions", 2**40))  # doctest: +ELLIPSIS
    2**40 directions is over the limit of 100000 (max_directions; raise it with --limit ...)
    """
    limit = getattr(current(), name)
    shown = f"{limit:g}" if isinstance(limit, float) else str(limit)
    return (
        f"{what} is over the limit of {shown} "
        f"({name}; raise it with --limit {name}=N or Limits({name}=N))"
    )


def parse_assignments(items: Sequence[str], base: Limits | None = None) -> Limits:
    """Limits from ``NAME=VALUE`` strings (the CLI's ``--limit``), on top of ``base``.

    Raises
    ------
    InputError
        An unknown name, or a value that is not a positive number.
    """
    known = {f.name: f for f in fields(Limits)}
    changes: dict[str, int | float] = {}
    for item in items:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or name not in known:
            names = ", ".join(sorted(known))
            raise InputError(
                "--limit", f"expected NAME=VALUE with NAME one of {names}; got {item!r}"
            )
        try:
            number = float(text)
        except ValueError:
            raise InputError("--limit", f"{name}: {text!r} is not a number") from None
        if not math.isfinite(number) or number <= 0:
            raise InputError("--limit", f"{name}: must be a positive finite number, got {text!r}")
        if known[name].type in (int, "int") and number > 2**62:
            raise InputError("--limit", f"{name}: {text!r} is too large")
        changes[name] = int(number) if known[name].type in (int, "int") else number
    return replace(base or current(), **changes)  # type: ignore[arg-type]
