"""``scenespeak describe`` and the printing of a scene description."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._app import (
    CalibRightOpt,
    QuietOpt,
    TextOrJson,
    _echo,
    _status,
    app,
)
from scenespeak.errors import InputError


@app.command("describe")
def describe_cmd(
    images: Annotated[
        list[Path],
        typer.Argument(
            help="LEFT RIGHT (a stereo pair, with --calib), or one COLOR image (with --depth "
            "and --intrinsics, or with --masks/--boxes alone for the image plane)."
        ),
    ],
    db: Annotated[
        Path | None, typer.Option("--db", help="The object database (SQLite file).")
    ] = None,
    calib: Annotated[
        Path | None,
        typer.Option(
            "--calib",
            help="Calibration of a stereo pair: JSON (short or full form), OpenCV FileStorage "
            "YAML, or the LEFT camera_info YAML of a ROS pair (then give --calib-right).",
        ),
    ] = None,
    calib_right: CalibRightOpt = None,
    depth: Annotated[
        Path | None,
        typer.Option(
            "--depth",
            help="Depth registered to COLOR: 16-bit PNG (units of --depth-scale metres), float "
            "TIFF or .npy in metres; 0, NaN, inf = no depth.",
        ),
    ] = None,
    depth_scale: Annotated[
        float, typer.Option("--depth-scale", help="Metres per unit of an integer depth image.")
    ] = 0.001,
    intrinsics: Annotated[
        Path | None,
        typer.Option(
            "--intrinsics",
            help='COLOR\'s camera: JSON {"fx","fy","cx","cy","width","height","up"?}, ROS '
            "camera_info YAML or OpenCV YAML.",
        ),
    ] = None,
    masks: Annotated[
        Path | None,
        typer.Option(
            "--masks", help="Instance image (PNG 8/16-bit, 0 = background, k = instance k)."
        ),
    ] = None,
    labels: Annotated[
        Path | None,
        typer.Option("--labels", help='Labels of the instances: JSON {"1": "mug", "2": "can"}.'),
    ] = None,
    boxes: Annotated[
        Path | None,
        typer.Option(
            "--boxes", help='COCO detections: [{"bbox": [x, y, w, h], "label": ..., "score": ...}].'
        ),
    ] = None,
    min_score: Annotated[
        float, typer.Option("--min-score", help="Ignore boxes with a lower score.")
    ] = 0.0,
    estimate_up: Annotated[
        bool,
        typer.Option(
            "--estimate-up", help="Estimate up from the support plane even if --intrinsics give it."
        ),
    ] = False,
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
    """Describe the spatial relations of the objects: a stereo pair, colour + depth, or masks."""
    from scenespeak.inputs import SceneInputs, describe_inputs

    if len(images) not in (1, 2):
        raise InputError(
            "IMAGES", f"give LEFT RIGHT (a stereo pair) or one COLOR image, not {len(images)}"
        )
    inputs = SceneInputs(
        color=images[0],
        right=images[1] if len(images) == 2 else None,
        calib=calib,
        calib_right=calib_right,
        depth=depth,
        depth_scale=depth_scale,
        intrinsics=intrinsics,
        masks=masks,
        labels=labels,
        boxes=boxes,
        min_score=min_score,
        db=db,
        estimate_up=estimate_up,
    )
    if figures is not None and inputs.form != "stereo":
        raise InputError(
            "--figures", "the stage pictures are drawn for stereo pairs with --db only"
        )
    with _status("describing the scene", quiet):
        description = describe_inputs(inputs, dense=dense, unknown=unknown)
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
