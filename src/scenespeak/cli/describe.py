"""``scenespeak describe`` and the printing of a scene description."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._app import (
    CalibOpt,
    CalibRightOpt,
    DbOpt,
    QuietOpt,
    TextOrJson,
    _echo,
    _status,
    app,
)


@app.command("describe")
def describe_cmd(
    left: Annotated[Path, typer.Argument(help="Left image.")],
    right: Annotated[Path, typer.Argument(help="Right image.")],
    db: DbOpt,
    calib: CalibOpt,
    calib_right: CalibRightOpt = None,
    fmt: Annotated[TextOrJson, typer.Option("--format", help="text or json.")] = TextOrJson.text,
    figures: Annotated[
        Path | None, typer.Option("--figures", help="Also write a PNG of every stage here.")
    ] = None,
    dense: Annotated[
        bool,
        typer.Option(
            "--dense/--no-dense",
            help="Take each recognised object's points from dense stereo inside its outline.",
        ),
    ] = True,
    unknown: Annotated[
        bool,
        typer.Option(
            "--unknown/--no-unknown", help="Cluster unlabelled points into unknown objects."
        ),
    ] = True,
    quiet: QuietOpt = False,
) -> None:
    """Describe the spatial relations of the objects in a stereo pair."""
    from scenespeak.pipeline import describe_files

    with _status("describing the scene", quiet):
        description = describe_files(
            left, right, calib, db, calib_right=calib_right, dense=dense, unknown=unknown
        )
    if figures is not None:
        _write_figures(description, figures)
    _print_description(description, fmt)


def _write_figures(description: Any, out_dir: Path) -> list[Path]:
    from scenespeak.tools.figures import write_figures

    return write_figures(description, out_dir)


def _print_description(description: Any, fmt: TextOrJson) -> None:
    if fmt is TextOrJson.json:
        _echo(json.dumps(description.to_dict()))
    else:
        _echo(description.to_text())
