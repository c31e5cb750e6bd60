"""The quick path of the command line: ``ask QUESTION --scene FILE`` without Typer.

A robot's dialogue loop asks one question per process about a saved scene; the answer takes a
few milliseconds, but importing Typer (with click and pydantic) takes several times the whole
budget of ``ask`` (issue 16: ``ask --scene`` <= 0.3 s as a whole process). :func:`run`
recognises exactly one shape of command line (and prints the top-level ``--help`` from a cache,
see :func:`run`),

    ask QUESTION --scene FILE [--format text|json] [--quiet | -q]

(options in any order, ``--opt=value`` or ``--opt value``, each at most once), and answers it
through the same functions as the full command (:func:`answer_saved`, :func:`echo`,
:func:`error_line`). Anything else, including ``--help``, a repeated or unknown option, a value
that looks like an option, ``--``, a missing question or a ``--format`` other than ``text`` or
``json``, returns None and the caller runs the full Typer command line, so usage errors read
exactly as they always did. This module imports only the standard library and the dialogue.

>>> parse_ask(["ask", "where is the mug?", "--scene", "scene.json", "--format=json"])
AskLine(question='where is the mug?', scene='scene.json', as_json=True)
>>> parse_ask(["ask", "where is the mug?", "--scene", "scene.json", "--db", "x.db"]) is None
True
"""

from __future__ import annotations

import contextvars
import json
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

__all__ = ["NESTED_TOO_DEEPLY", "AskLine", "answer_saved", "echo", "error_line", "parse_ask", "run"]

#: Exit status for input the program could not use (like argparse's usage errors).
EXIT_INPUT = 2
NESTED_TOO_DEEPLY = "scenespeak: error: an input is nested too deeply to process"

_FLAGS = {"--quiet": "quiet", "-q": "quiet"}
_VALUED = {"--scene": "scene", "--format": "format"}
_FORMATS = {"text": False, "json": True}


@dataclass(frozen=True)
class AskLine:
    """An ``ask`` command line the quick path answers."""

    question: str
    scene: str
    as_json: bool


def _options(tokens: list[str]) -> tuple[list[str], dict[str, str]] | None:
    """Positional arguments and options of ``tokens``, or None for anything unusual."""
    positional: list[str] = []
    seen: dict[str, str] = {}
    i = 0
    while i < len(tokens):
        token = tokens[i]
        i += 1
        if not token.startswith("-"):
            positional.append(token)
            continue
        name, eq, value = token.partition("=")
        if name in _FLAGS and not eq:
            key, value = _FLAGS[name], ""
        elif name in _VALUED:
            key = _VALUED[name]
            if not eq:
                if i == len(tokens):
                    return None
                value, i = tokens[i], i + 1
            if value.startswith("-"):
                return None
        else:  # --help, --, an option of describe's inputs, a typo: the full CLI's business
            return None
        if key in seen:
            return None
        seen[key] = value
    return positional, seen


def parse_ask(args: list[str]) -> AskLine | None:
    """The ``ask`` line in ``args`` (without the program name), or None to use the full CLI."""
    if not args or args[0] != "ask":
        return None
    parsed = _options(args[1:])
    if parsed is None:
        return None
    positional, options = parsed
    fmt = options.get("format", "text")
    if len(positional) != 1 or "scene" not in options or fmt not in _FORMATS:
        return None
    return AskLine(positional[0], options["scene"], _FORMATS[fmt])


def answer_saved(question: str, scene: Path, as_json: bool) -> str:
    """The text ``ask`` prints for ``question`` about the saved scene file ``scene``."""
    from scenespeak.spatial.dialogue import ask, load_scene

    answer = ask(question, load_scene(scene))
    return json.dumps(answer.to_dict()) if as_json else answer.answer


def echo(text: str) -> None:
    """Print a result; labels from files or the command line cannot smuggle escape sequences."""
    from scenespeak.cleantext import clean_text

    text = clean_text(text, keep_newlines=True)
    sys.stdout.write(text if text.endswith("\n") else text + "\n")


def error_line(exc: BaseException) -> str:
    """The one line the command prints on stderr for an input error."""
    from scenespeak.cleantext import clean_text

    return "scenespeak: error: " + clean_text(str(exc))


def run(args: list[str]) -> int | None:
    """Answer ``args`` if it is an ``ask --scene`` line or the top-level help; the exit status,
    or None to use the full command line."""
    if args in ([], ["--help"]):
        return _help()
    line = parse_ask(args)
    if line is None:
        return None
    return contextvars.copy_context().run(_answer, line)


# --------------------------------------------------------------------------------------------
# The top-level help, cached: building it means building every command's click parameters
# from their signatures (Typer evaluates every annotation), about 0.15 s of CPU on every
# `scenespeak --help`. The text is kept in the user's cache folder under a key of everything it
# depends on — the interpreter, Typer's installed files, the size and time of every module of
# this folder (the commands' docstrings and options) and the terminal width click wraps to — so
# that an edited command, another Typer or a narrower terminal renders it afresh. Any trouble
# with the cache (unreadable, unwritable, SCENESPEAK_NO_HELP_CACHE=1) only means rendering it.


def _help_key() -> str | None:
    import hashlib
    import importlib.util
    import os
    import shutil

    spec = importlib.util.find_spec("typer")
    if spec is None or spec.origin is None:
        return None
    parts = [sys.version, str(shutil.get_terminal_size().columns)]
    for folder in (Path(spec.origin).parent, Path(__file__).parent):
        for entry in sorted(os.scandir(folder), key=lambda e: e.name):
            if entry.name.endswith(".py"):
                st = entry.stat()
                parts.append(f"{entry.path}:{st.st_size}:{st.st_mtime_ns}")
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:32]


def _help_file() -> Path | None:
    import os

    if os.environ.get("SCENESPEAK_NO_HELP_CACHE"):
        return None
    key = _help_key()
    if key is None:
        return None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "scenespeak" / f"help-{key}.txt"


def _help() -> int | None:
    """Print the cached top-level help (or render, print and cache it); None: use the full CLI."""
    try:
        cache = _help_file()
        if cache is None:
            return None
        if cache.is_file():
            sys.stdout.write(cache.read_text(encoding="utf-8"))
            return 0
    except (OSError, UnicodeError, ValueError):
        return None
    return _render_help(cache)


def _render_help(cache: Path) -> int:
    import contextlib
    import io
    import os

    from scenespeak.cli import _full

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = _full.main(["--help"])
    text = out.getvalue()
    sys.stdout.write(text)
    if status == 0 and text:
        with contextlib.suppress(OSError):
            cache.parent.mkdir(parents=True, exist_ok=True)
            tmp = cache.with_name(f"{cache.name}.{os.getpid()}.tmp")
            tmp.write_text(text, encoding="utf-8")
            os.replace(tmp, cache)
    return status


def _answer(line: AskLine) -> int:
    from scenespeak.errors import ScenespeakError

    try:
        # As in the full CLI: library warnings are recorded, never extra lines on stderr.
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            echo(answer_saved(line.question, Path(line.scene), line.as_json))
    except ScenespeakError as exc:
        sys.stderr.write(error_line(exc) + "\n")
        return EXIT_INPUT
    except BrokenPipeError:  # e.g. `scenespeak ask ... | head -c 10`
        return 0
    except RecursionError:
        sys.stderr.write(NESTED_TOO_DEEPLY + "\n")
        return EXIT_INPUT
    return 0
