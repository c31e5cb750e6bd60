"""``scenespeak ask QUESTION``: answer a question about a scene (``interfaces.md``, Questions).

The scene is a saved ``describe --format json`` output (``--scene FILE``: no image work, no
NumPy for most questions) or any input form of ``describe``: the command's options are
``describe``'s own input options (the fields of ``DescribeCommand`` minus ``OUTPUT_OPTIONS``),
all made optional because ``--scene`` can stand for them, and the scene is described by
:func:`scenespeak.cli.describe.describe_inputs`.
"""

from __future__ import annotations

import inspect
import json
from pathlib import Path
from typing import Annotated, Any, get_args, get_origin

import typer

from scenespeak.cli._app import TextOrJson, _echo, _status, app
from scenespeak.cli._options import options_signature
from scenespeak.cli._quick import answer_saved
from scenespeak.cli.describe import OUTPUT_OPTIONS, DescribeCommand, describe_inputs

__all__ = ["ask_cmd"]


def _optional(param: inspect.Parameter) -> inspect.Parameter:
    """The same option or argument, with default None when it had none."""
    if param.default is not inspect.Parameter.empty:
        return param
    annotation = param.annotation
    if get_origin(annotation) is Annotated:
        base, *meta = get_args(annotation)
        annotation = Annotated[(base | None, *meta)]
    return param.replace(default=None, annotation=annotation)


def _ask(**kwargs: Any) -> None:
    question: str = kwargs.pop("question")
    scene_file: Path | None = kwargs.pop("scene")
    fmt: TextOrJson = kwargs.pop("fmt")
    quiet: bool = kwargs.pop("quiet")
    if scene_file is not None:  # what the quick path (cli/_quick.py) answers without Typer
        _echo(answer_saved(question, scene_file, fmt is TextOrJson.json))
        return
    from scenespeak.spatial.dialogue import ask

    with _status("describing the scene", quiet):
        scene = describe_inputs(**kwargs)
    answer = ask(question, scene)
    _echo(json.dumps(answer.to_dict()) if fmt is TextOrJson.json else answer.answer)


def _signature() -> inspect.Signature:
    own = [
        inspect.Parameter(
            "question",
            inspect.Parameter.POSITIONAL_OR_KEYWORD,
            annotation=Annotated[
                str, typer.Argument(help='The question, e.g. "where is the mug?".')
            ],
        ),
        inspect.Parameter(
            "scene",
            inspect.Parameter.KEYWORD_ONLY,
            default=None,
            annotation=Annotated[
                Path | None,
                typer.Option(
                    "--scene", help="A saved `describe --format json` output instead of images."
                ),
            ],
        ),
        inspect.Parameter(
            "fmt",
            inspect.Parameter.KEYWORD_ONLY,
            default=TextOrJson.text,
            annotation=Annotated[TextOrJson, typer.Option("--format", help="text or json.")],
        ),
    ]
    described = options_signature(DescribeCommand).parameters
    inputs = [
        _optional(p).replace(kind=inspect.Parameter.KEYWORD_ONLY)
        for p in described.values()
        if p.name not in OUTPUT_OPTIONS
    ]
    quiet = described["quiet"]
    return inspect.Signature([*own, *inputs, quiet.replace(kind=inspect.Parameter.KEYWORD_ONLY)])


def ask_cmd(**kwargs: Any) -> None:
    """Answer a question about a scene: a saved description (--scene) or images."""
    _ask(**kwargs)


ask_cmd.__signature__ = _signature()  # type: ignore[attr-defined]
app.command("ask")(ask_cmd)
