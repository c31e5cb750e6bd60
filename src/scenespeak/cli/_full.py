"""The full ``scenespeak`` command line: the Typer application with every command.

:func:`scenespeak.cli.main` comes here for everything its quick path
(:mod:`scenespeak.cli._quick`) does not answer itself. Every error a user can cause is a
:class:`~scenespeak.errors.ScenespeakError`; :func:`main` catches it in one place and prints
one line, ``scenespeak: error: <file>: <problem>``, on stderr with exit status 2. Results go to
stdout (JSON stays clean); progress goes to stderr.

One module per command (or command group); each registers itself on :data:`app` when imported
below. A new command is a new module in ``cli/`` plus one import line here.
"""

from __future__ import annotations

import contextvars
import os
import sys
import warnings
from collections.abc import Sequence
from typing import Any

import typer

from scenespeak.cli import (  # noqa: F401  (each registers its command)
    annotate,
    ask,
    db,
    describe,
    evaluate,
    points,
    scenes,
    serve,
    watch,
)
from scenespeak.cli._app import app
from scenespeak.cli._quick import EXIT_INPUT, NESTED_TOO_DEEPLY, error_line
from scenespeak.errors import ScenespeakError

__all__ = ["app", "main"]

# Typer >= 0.2x runs on its own copy of click (``typer._click``) and never imports the real one,
# which would cost a fifth of ``--help``'s time; older Typer runs on click itself. ``typer.Exit``
# and ``typer.Abort`` are what either raises (older Typer re-exports click's).
_click: Any = getattr(typer, "_click", None)
if _click is None:  # pragma: no cover - Typer < 0.2x
    import click as _click
_CLICK_ERRORS: tuple[type[Exception], ...] = (_click.ClickException,)
_EXITS: tuple[type[Exception], ...] = (typer.Exit,)
_ABORTS: tuple[type[BaseException], ...] = (typer.Abort,)


def _usage_line(exc: Exception) -> str:
    """A click/typer usage error as one line (not the multi-line usage box)."""
    from scenespeak.cleantext import clean_text

    message = str(getattr(exc, "format_message", exc.__str__)()).strip().rstrip(".")
    ctx = getattr(exc, "ctx", None)
    where = f" (see: {ctx.command_path} --help)" if ctx is not None else ""
    return "scenespeak: error: " + clean_text(message) + where


def main(argv: Sequence[str] | None = None) -> int:
    """Run the full command line; return the exit status (0 success, 2 bad input, 1 other).

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments without the program name (default ``sys.argv[1:]``).

    Examples
    --------
    >>> main(["--help"]) == 0  # doctest: +SKIP
    True
    """
    args = list(sys.argv[1:] if argv is None else argv)
    command = typer.main.get_command(app)
    if not args:
        args = ["--help"]
    # Each run gets its own context (the --limit values) and records library warnings instead
    # of letting them print as extra lines: every error stays one line of ours.
    return contextvars.copy_context().run(_run, command, args)


def _run(command: Any, args: list[str]) -> int:
    # OpenCV reads this when it is first imported (by a command that needs it): its own log
    # lines ("[ WARN:0@...]") would be extra lines beside ours.
    os.environ.setdefault("OPENCV_LOG_LEVEL", "SILENT")
    try:
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            result = command.main(args=args, prog_name="scenespeak", standalone_mode=False)
    except ScenespeakError as exc:
        sys.stderr.write(error_line(exc) + "\n")
        return EXIT_INPUT
    except _EXITS as exc:
        return int(getattr(exc, "exit_code", 0) or 0)
    except _ABORTS:
        sys.stderr.write("scenespeak: error: interrupted\n")
        return 130
    except _CLICK_ERRORS as exc:
        sys.stderr.write(_usage_line(exc) + "\n")
        code = getattr(exc, "exit_code", EXIT_INPUT)
        return EXIT_INPUT if code in (1, 2) else int(code)
    except BrokenPipeError:  # e.g. `scenespeak describe ... | head -1`
        return 0
    except RecursionError:
        sys.stderr.write(NESTED_TOO_DEEPLY + "\n")
        return EXIT_INPUT
    except SystemExit as exc:
        code = exc.code
        if code is None:
            return 0
        if isinstance(code, int):
            return code
        sys.stderr.write(f"{code}\n")
        return 1
    return result if isinstance(result, int) else 0
