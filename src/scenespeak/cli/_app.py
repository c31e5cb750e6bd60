"""The ``scenespeak`` command (see ``docs/cli.md``). It only calls the library.

Every error a user can cause is a :class:`~scenespeak.errors.ScenespeakError`; :func:`main`
catches it in one place and prints one line, ``scenespeak: error: <file>: <problem>``, on stderr
with exit status 2. Results go to stdout (JSON stays clean); progress goes to stderr.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.errors import InputError

__all__ = ["app"]

#: Exit status for input the program could not use (like argparse's usage errors).
EXIT_INPUT = 2


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
    sys.stdout.write(text if text.endswith("\n") else text + "\n")


def _load_rig(calib: Path, calib_right: Path | None) -> Any:
    from scenespeak.perception import calibration

    if calib_right is not None:
        return calibration.load_ros_rig(calib, calib_right)
    return calibration.load_rig(calib)


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
    typer.Option("--calib-right", help="The RIGHT camera_info YAML of a ROS pair."),
]
DbOpt = Annotated[Path, typer.Option("--db", help="The object database (SQLite file).")]
QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="No progress on stderr.")]
