"""The options objects of the commands (``cli/_options.py``): one instance per command line."""

from __future__ import annotations

import dataclasses
import inspect
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import pytest
import typer
from typer.testing import CliRunner

from scenespeak.cli._options import options_signature, takes_options


@dataclass(frozen=True, kw_only=True)
class _Copy:
    source: Annotated[Path, typer.Argument(help="From.")]
    target: Annotated[Path, typer.Option("--to", help="To.")]
    times: Annotated[int, typer.Option("--times", min=1, help="How often.")] = 1
    dry: Annotated[bool, typer.Option("--dry/--wet", help="Only say it.")] = False


def _app(seen: list[_Copy]) -> typer.Typer:
    app = typer.Typer(rich_markup_mode=None)

    @app.command("copy")
    @takes_options(_Copy)
    def copy_cmd(o: _Copy) -> None:
        """Copy a file."""
        seen.append(o)

    @app.command("other")
    def other() -> None:  # a second command, so that "copy" is a subcommand
        """Nothing."""

    return app


def test_the_command_gets_one_instance_with_the_parsed_values() -> None:
    seen: list[_Copy] = []
    result = CliRunner().invoke(_app(seen), ["copy", "a.txt", "--to", "b.txt", "--wet"])
    assert result.exit_code == 0, result.output
    assert seen == [_Copy(source=Path("a.txt"), target=Path("b.txt"), times=1, dry=False)]


def test_flags_defaults_help_and_checks_are_the_fields() -> None:
    app = _app([])
    help_text = CliRunner().invoke(app, ["copy", "--help"]).output
    assert "Copy a file." in help_text
    for text in (
        "--to",
        "--times",
        "How often.",
        "--dry / --wet",
        "[default: 1; x>=1]",
        "[required]",
    ):
        assert text in help_text
    missing = CliRunner().invoke(app, ["copy", "a.txt"])
    assert missing.exit_code == 2 and "--to" in missing.output
    low = CliRunner().invoke(app, ["copy", "a.txt", "--to", "b", "--times", "0"])
    assert low.exit_code == 2 and "--times" in low.output


def test_signature_is_the_fields_in_order() -> None:
    sig = options_signature(_Copy)
    assert list(sig.parameters) == [f.name for f in dataclasses.fields(_Copy)]
    assert sig.parameters["source"].default is inspect.Parameter.empty
    assert sig.parameters["times"].default == 1


def test_refuses_what_click_cannot_take() -> None:
    class Plain:
        x: int = 1

    with pytest.raises(TypeError, match="not a dataclass"):
        options_signature(Plain)

    @dataclass(frozen=True)
    class Factory:
        names: Annotated[list[str], typer.Option("--name")] = field(default_factory=list)

    with pytest.raises(TypeError, match="factory"):
        options_signature(Factory)


@pytest.mark.parametrize("command", ["describe", "watch", "points", "annotate"])
def test_the_wide_commands_take_one_options_object(command: str) -> None:
    from scenespeak.cli import _full  # noqa: F401  (registers the commands)
    from scenespeak.cli._app import app

    info = next(c for c in app.registered_commands if c.name == command)
    callback = info.callback
    assert callback is not None
    typer_params = list(inspect.signature(callback).parameters)
    module = __import__(f"scenespeak.cli.{command}", fromlist=["_"])
    cls = getattr(module, f"{command.capitalize()}Command")
    assert typer_params == [f.name for f in dataclasses.fields(cls)]
