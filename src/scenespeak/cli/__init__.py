"""The ``scenespeak`` command (see ``docs/cli.md``). It only calls the library.

Every error a user can cause is a :class:`~scenespeak.errors.ScenespeakError`; :func:`main`
catches it in one place and prints one line, ``scenespeak: error: <file>: <problem>``, on stderr
with exit status 2. Results go to stdout (JSON stays clean); progress goes to stderr.

One module per command (or command group); each registers itself on :data:`app` when imported
below. A new command is a new module here plus one import line.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

import typer

from scenespeak.cli import annotate, db, describe, evaluate, points, scenes  # noqa: F401
from scenespeak.cli._app import EXIT_INPUT, app
from scenespeak.errors import ScenespeakError

__all__ = ["app", "main"]


def _error_line(exc: BaseException) -> str:
    return f"scenespeak: error: {exc}"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status (0 success, 2 bad input, 1 other).

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
    try:
        # Standalone mode: click/typer print usage errors themselves and raise SystemExit.
        command.main(args=args, prog_name="scenespeak", standalone_mode=True)
    except ScenespeakError as exc:
        sys.stderr.write(_error_line(exc) + "\n")
        return EXIT_INPUT
    except BrokenPipeError:  # e.g. `scenespeak describe ... | head -1`
        return 0
    except SystemExit as exc:
        code = exc.code
        if code is None:
            return 0
        if isinstance(code, int):
            return code
        sys.stderr.write(f"{code}\n")
        return 1
    return 0
