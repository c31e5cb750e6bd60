"""A command's options as one object: a frozen dataclass whose fields declare the command line.

A command with many options (``describe``, ``watch``, ``points``, ``annotate``) declares them as
the fields of a frozen, keyword-only dataclass, each field annotated as Typer expects a
parameter to be (``Annotated[type, typer.Option(...)]`` or ``typer.Argument``) with its default
as the field's default, in the order ``--help`` lists them. :func:`takes_options` turns that
class into the click parameters of the command and hands the command one instance::

    @dataclass(frozen=True, kw_only=True)
    class PointsCommand:
        left: Annotated[Path, typer.Argument(help="Left image.")]
        out: Annotated[Path | None, typer.Option("--out", help="Write here.")] = None

    @app.command("points")
    @takes_options(PointsCommand)
    def points_cmd(o: PointsCommand) -> None: ...

Typer reads a command's parameters from its signature; the function :func:`takes_options`
returns carries the signature made of the class's fields (``__signature__``), so the flags,
defaults, help text, callbacks and ``--help`` output are exactly those of a function with one
parameter per field, and the command's own function has a single parameter.

>>> from pathlib import Path
>>> from scenespeak.cli.points import PointsCommand, points_cmd
>>> list(inspect.signature(points_cmd).parameters)[:4]
['left', 'right', 'calib', 'calib_right']
>>> PointsCommand(left=Path("l.png"), right=Path("r.png"), calib=Path("c.json")).ratio
0.6
"""

from __future__ import annotations

import dataclasses
import inspect
import typing
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["options_signature", "takes_options"]

T = TypeVar("T")


def options_signature(cls: type[Any]) -> inspect.Signature:
    """The signature of a function with one keyword parameter per field of ``cls``.

    Parameters
    ----------
    cls : dataclass type
        Fields annotated ``Annotated[type, typer.Option(...)]`` (or ``typer.Argument``); a field
        without a default is a required option or argument.

    Returns
    -------
    inspect.Signature
        Keyword-only parameters in field order, annotations evaluated (Typer reads them as is).

    Raises
    ------
    TypeError
        When ``cls`` is not a dataclass or a field's default is a factory (click needs a value).
    """
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls!r} is not a dataclass: declare the command's options as one")
    hints = typing.get_type_hints(cls, include_extras=True)
    params = []
    for f in dataclasses.fields(cls):
        if f.default_factory is not dataclasses.MISSING:
            raise TypeError(f"{cls.__name__}.{f.name}: give a plain default, not a factory")
        default = inspect.Parameter.empty if f.default is dataclasses.MISSING else f.default
        params.append(
            inspect.Parameter(
                f.name, inspect.Parameter.KEYWORD_ONLY, default=default, annotation=hints[f.name]
            )
        )
    return inspect.Signature(params)


def takes_options(cls: type[T]) -> Callable[[Callable[[T], None]], Callable[..., None]]:
    """Decorate a command taking one ``cls`` instance into the function Typer registers.

    The returned function takes the fields of ``cls`` as keywords (what click parses), builds
    the instance and calls the command with it; its name, docstring (the command's help) and
    module are the command's, its signature is :func:`options_signature` of ``cls``.

    Parameters
    ----------
    cls : dataclass type
        The command's options (module docstring).

    Returns
    -------
    callable
        The decorator.
    """
    signature = options_signature(cls)

    def decorate(command: Callable[[T], None]) -> Callable[..., None]:
        def run(**values: Any) -> None:
            command(cls(**values))

        run.__name__ = command.__name__
        run.__qualname__ = command.__qualname__
        run.__doc__ = command.__doc__
        run.__module__ = command.__module__
        run.__signature__ = signature  # type: ignore[attr-defined]
        return run

    return decorate
