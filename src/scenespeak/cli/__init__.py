"""The ``scenespeak`` command (see ``docs/cli.md``). It only calls the library.

:func:`main` is the console entry point. The commonest call of a robot's dialogue loop,
``scenespeak ask QUESTION --scene FILE``, is answered by a small standard-library parser
(:mod:`scenespeak.cli._quick`) without importing Typer, click or pydantic, which would cost
more than the answer itself; every other command line, and any ``ask`` line the quick parser
does not recognise in full, goes to the Typer application in :mod:`scenespeak.cli._full`
(where the commands are registered: one module per command plus one import line there). Both
give the same output, the same one-line errors and the same exit status
(``tests/cli/test_cli_quick.py``).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

__all__ = ["app", "main"]

if TYPE_CHECKING:  # pragma: no cover
    from scenespeak.cli._full import app


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
    from scenespeak.cli import _quick

    status = _quick.run(args)
    if status is not None:
        return status
    from scenespeak.cli import _full

    return _full.main(args)


def __getattr__(name: str) -> Any:
    # The Typer application, imported only when someone asks for it (tests, the fuzzer).
    if name == "app":
        from scenespeak.cli._full import app

        return app
    raise AttributeError(f"module 'scenespeak.cli' has no attribute {name!r}")
