"""The ``scenespeak`` command (see ``docs/cli.md``). It only calls the library.

Every error a user can cause is a :class:`~scenespeak.errors.ScenespeakError`; :func:`main`
catches it in one place and prints one line, ``scenespeak: error: <file>: <problem>``, on stderr
with exit status 2. Results go to stdout (JSON stays clean); progress goes to stderr.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._quick import echo
from scenespeak.errors import InputError

__all__ = ["app"]


def new_app(**options: Any) -> typer.Typer:
    """A Typer application (or command group) with the CLI's defaults.

    Plain click help (``rich_markup_mode=None``): Typer's rich help pulls in rich, markdown-it
    and pygments, about 0.2 s on every ``--help`` and usage error. Commands import what they
    need (NumPy, OpenCV, ...) inside their functions, never at module level, so that
    ``scenespeak --help`` starts in well under 0.15 s (``tests/cli/test_cli_imports.py``).
    """
    options.setdefault("rich_markup_mode", None)
    options.setdefault("pretty_exceptions_enable", False)
    return typer.Typer(**options)


app = new_app(
    name="scenespeak",
    help="Say in words where objects are, from a stereo camera pair.",
    no_args_is_help=True,
    add_completion=False,
)
db_app = new_app(help="Manage the object database (labelled SIFT descriptors).")
scenes_app = new_app(help="Render stereo scenes with ground truth.")
app.add_typer(db_app, name="db", no_args_is_help=True)
app.add_typer(scenes_app, name="scenes", no_args_is_help=True)


@app.callback()
def _root(
    limit: Annotated[
        list[str] | None,
        typer.Option(
            "--limit",
            metavar="NAME=VALUE",
            help="Raise (or lower) one of the input limits of docs/trust.md, e.g. "
            "--limit max_image_pixels=200e6; repeat for several.",
        ),
    ] = None,
) -> None:
    """Say in words where objects are, from a stereo camera pair."""
    if limit:
        from scenespeak import limits

        # main() runs every command in a copy of the context, so this ends with the command.
        limits.install(limits.parse_assignments(limit))


class TextOrJson(StrEnum):
    text = "text"
    json = "json"


class PointsFormat(StrEnum):
    json = "json"
    ply = "ply"


# --------------------------------------------------------------------------------------------
# helpers


def _stderr_console() -> Any:
    from rich.console import Console

    return Console(stderr=True)


@contextmanager
def _status(message: str, quiet: bool = False) -> Iterator[None]:
    """A spinner on stderr (only when stderr is a terminal; never on stdout)."""
    if quiet or not sys.stderr.isatty():
        yield
        return
    with _stderr_console().status(message):
        yield


def _progress(total: int, description: str, quiet: bool = False) -> Any:
    """A rich progress bar on stderr, or None when stderr is not a terminal."""
    if quiet or not sys.stderr.isatty():
        return None
    from rich.progress import Progress

    return Progress(console=_stderr_console(), transient=True)


def _echo(text: str) -> None:
    """Print a result; labels from files or the command line cannot smuggle escape sequences."""
    echo(text)


def _load_rig(
    calib: Path,
    calib_right: Path | None,
    *,
    image_size: str | None = None,
    units: str = "m",
    up: str | None = None,
    pitch: float | None = None,
    swap: bool = False,
) -> Any:
    """Load a calibration (one file or a pair), apply --units/--up/--pitch, check plausibility."""
    from scenespeak.perception import calibfiles, plausibility

    size = _parse_size(image_size) if image_size is not None else None
    if calib_right is not None:
        rig = calibfiles.read_calibration_pair(calib, calib_right, image_size=size)
    else:
        rig = calibfiles.read_calibration(calib, image_size=size)
    rig = plausibility.with_units(rig, units)
    if swap:
        rig = plausibility.swapped(rig)
    if up is not None and pitch is not None:
        raise InputError("--up", "give --up or --pitch, not both")
    if up is not None:
        rig = rig.with_up(_parse_vector(up, "--up"))
    elif pitch is not None:
        rig = rig.with_up(plausibility.pitch_up(pitch))
    return plausibility.check_rig(rig)


def _parse_size(text: str) -> tuple[int, int]:
    parts = text.lower().replace(",", "x").split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise InputError(
            "--image-size", f"expected WIDTHxHEIGHT (e.g. 640x480), got {text!r}"
        ) from None
    side = 32768
    if not (0 < w <= side and 0 < h <= side):
        raise InputError("--image-size", f"width and height must be 1..{side} pixels, got {w}x{h}")
    return w, h


def _parse_vector(text: str, option: str) -> list[float]:
    try:
        v = [float(p) for p in text.split(",")]
    except ValueError:
        raise InputError(option, f"expected three numbers X,Y,Z, got {text!r}") from None
    if len(v) != 3 or not all(math.isfinite(x) for x in v) or not any(v):
        raise InputError(option, f"expected three finite numbers X,Y,Z not all 0, got {text!r}")
    return v


def _check_ratio(value: float) -> float:
    """--ratio: Lowe's ratio test threshold, in (0, 1)."""
    if not (math.isfinite(value) and 0.0 < value <= 1.0):
        raise typer.BadParameter(f"must be a number in (0, 1] (Lowe's ratio test), got {value}")
    if value < 0.05:
        raise typer.BadParameter(f"{value} keeps (almost) no match; use 0.05 to 1 (default 0.6)")
    return value


def _write_text(path: Path, text: str) -> None:
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise InputError(path, f"cannot write ({exc.strerror})") from exc


CalibOpt = Annotated[
    Path,
    typer.Option(
        "--calib",
        help="Calibration: JSON (short or full form), OpenCV FileStorage YAML, or the LEFT "
        "camera_info YAML of a ROS pair (then give --calib-right).",
    ),
]
CalibRightOpt = Annotated[
    Path | None,
    typer.Option(
        "--calib-right",
        help="The second file of a pair: the RIGHT camera_info YAML of a ROS pair, or "
        "extrinsics.yml beside --calib intrinsics.yml (OpenCV's stereo_calib sample).",
    ),
]
ImageSizeOpt = Annotated[
    str | None,
    typer.Option(
        "--image-size",
        metavar="WxH",
        help="Image size the calibration is for, when the file has none (OpenCV's samples).",
    ),
]
UnitsOpt = Annotated[
    str,
    typer.Option("--units", help="Units of the calibration's T / baseline: m (default), cm or mm."),
]
UpOpt = Annotated[
    str | None,
    typer.Option(
        "--up", metavar="X,Y,Z", help="World up in the left camera's frame (default 0,-1,0)."
    ),
]
PitchOpt = Annotated[
    float | None,
    typer.Option("--pitch", help="The rig's downward pitch in degrees (sets --up)."),
]
SwapOpt = Annotated[
    bool,
    typer.Option(
        "--swap",
        help="The calibration's left camera is physically on the right: exchange the "
        "cameras (calibration and images: give LEFT RIGHT as named).",
    ),
]
DbOpt = Annotated[Path, typer.Option("--db", help="The object database (SQLite file).")]
QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="No progress on stderr.")]
