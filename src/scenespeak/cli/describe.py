"""``scenespeak describe`` and the printing of a scene description.

The scene's input options (images, calibration, database, and whatever input forms are added
here later) are read by :func:`describe_inputs`; ``scenespeak ask`` (``cli/ask.py``) takes the
same options by copying this command's signature minus :data:`OUTPUT_OPTIONS`, so a new input
form added to ``describe_cmd`` and handled in :func:`describe_inputs` reaches ``ask`` as is.
"""

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
from scenespeak.errors import InputError

#: describe_cmd's parameters that say what to print, not which scene: ``ask`` leaves them out.
OUTPUT_OPTIONS = frozenset({"fmt", "figures", "summary", "viewer", "about", "quiet"})


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
    summary: Annotated[
        bool, typer.Option("--summary", help="At most n + 1 sentences about the whole scene.")
    ] = False,
    viewer: Annotated[
        bool,
        typer.Option("--viewer", help='Each object relative to the camera ("in front of me").'),
    ] = False,
    about: Annotated[
        str | None,
        typer.Option("--about", help="Only the relations whose argument is this object."),
    ] = None,
    quiet: QuietOpt = False,
) -> None:
    """Describe the spatial relations of the objects in a stereo pair."""
    with _status("describing the scene", quiet):
        description = describe_inputs(
            left=left,
            right=right,
            db=db,
            calib=calib,
            calib_right=calib_right,
            dense=dense,
            unknown=unknown,
        )
    if figures is not None:
        _write_figures(description, figures)
    if summary or viewer or about is not None:
        _print_views(description, fmt, summary=summary, viewer=viewer, about=about)
    else:
        _print_description(description, fmt)


def describe_inputs(**inputs: Any) -> Any:
    """Describe the scene the input options of ``describe`` name (also used by ``ask``).

    Parameters
    ----------
    **inputs
        ``describe_cmd``'s parameters that are not in :data:`OUTPUT_OPTIONS` (``left``,
        ``right``, ``db``, ``calib``, ``calib_right``, ``dense``, ``unknown``; None where
        not given).

    Returns
    -------
    SceneDescription

    Raises
    ------
    InputError
        When a required input is missing (``ask`` makes them all optional because of
        ``--scene``).
    """
    from scenespeak.pipeline import describe_files

    missing = [
        flag
        for flag, key in (
            ("LEFT", "left"),
            ("RIGHT", "right"),
            ("--db", "db"),
            ("--calib", "calib"),
        )
        if inputs.get(key) is None
    ]
    if missing:
        raise InputError(
            "command line", f"give {', '.join(missing)} (or --scene FILE for a saved description)"
        )
    return describe_files(
        inputs["left"],
        inputs["right"],
        inputs["calib"],
        inputs["db"],
        calib_right=inputs.get("calib_right"),
        dense=bool(inputs.get("dense", True)),
        unknown=bool(inputs.get("unknown", True)),
    )


def _print_views(
    description: Any, fmt: TextOrJson, *, summary: bool, viewer: bool, about: str | None
) -> None:
    """``--summary``, ``--viewer`` and ``--about`` (``interfaces.md``, "Output for a robot")."""
    from scenespeak.spatial.dialogue import scene_from_dict, summarize, viewer_entries
    from scenespeak.spatial.dialogue.resolve import resolve

    data = description.to_dict()
    scene = scene_from_dict(data, "scene description")
    lines: list[str] = []
    if summary:
        data["summary"] = summarize(scene)
        lines.append(data["summary"])
    if viewer:
        data["viewer"] = viewer_entries(scene)
        lines += [v["sentence"] for v in data["viewer"]]
    if about is not None:
        ref = resolve(about, scene)
        if ref.status != "one":
            names = ", ".join(repr(n) for n in scene.names) or "none"
            raise InputError("--about", f"no single object called {about!r} (objects: {names})")
        name = ref.one.name
        data["relations"] = [r for r in data["relations"] if r["argument"] == name]
        data["about"] = name
        lines += [r["sentence"] for r in data["relations"]] or [
            f"Only the {name}: nothing to relate."
        ]
    _echo(json.dumps(data) if fmt is TextOrJson.json else "\n".join(lines))


def _write_figures(description: Any, out_dir: Path) -> list[Path]:
    from scenespeak.tools.figures import write_figures

    return write_figures(description, out_dir)


def _print_description(description: Any, fmt: TextOrJson) -> None:
    if fmt is TextOrJson.json:
        _echo(json.dumps(description.to_dict()))
    else:
        _echo(description.to_text())
