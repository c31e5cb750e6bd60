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
    ImageSizeOpt,
    PitchOpt,
    QuietOpt,
    SwapOpt,
    TextOrJson,
    UnitsOpt,
    UpOpt,
    _echo,
    _load_rig,
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
    image_size: ImageSizeOpt = None,
    units: UnitsOpt = "m",
    up: UpOpt = None,
    pitch: PitchOpt = None,
    swap: SwapOpt = False,
    quiet: QuietOpt = False,
) -> None:
    """Describe the spatial relations of the objects in a stereo pair."""
    rig = _load_rig(
        calib, calib_right, image_size=image_size, units=units, up=up, pitch=pitch, swap=swap
    )
    if swap:
        left, right = right, left
    with _status("describing the scene", quiet):
        description = _describe(left, right, rig, db, dense=dense, unknown=unknown)
    if figures is not None:
        _write_figures(description, figures)
    _print_description(description, fmt)


def _describe(left: Path, right: Path, rig: Any, db: Path, **options: Any) -> Any:
    """The pipeline on files, with the plausibility checks of ``docs/trust.md``."""
    import numpy as np

    from scenespeak.perception import plausibility
    from scenespeak.perception.database import ObjectDatabase
    from scenespeak.perception.features import load_image
    from scenespeak.pipeline import describe_scene

    left_img = load_image(left, gray=False)
    right_img = load_image(right, gray=False)
    plausibility.check_pair_order(left_img, right_img, rig, names=(str(left), str(right)))
    sources = {"left": str(left), "right": str(right), "calib": rig.source, "db": str(db)}
    with ObjectDatabase.open(db, readonly=True) as database:
        description = describe_scene(left_img, right_img, rig, database, sources=sources, **options)
    z = np.array([o["centroid"][2] for o in description.to_dict()["objects"] if o.get("centroid")])
    if len(z):
        fx = float(rig.K_left[0, 0])
        with np.errstate(divide="ignore"):
            plausibility.check_depths(z, fx * rig.baseline / z, rig.source, min_points=1)
    return description


def _write_figures(description: Any, out_dir: Path) -> list[Path]:
    from scenespeak.tools.figures import write_figures

    return write_figures(description, out_dir)


def _print_description(description: Any, fmt: TextOrJson) -> None:
    if fmt is TextOrJson.json:
        _echo(json.dumps(description.to_dict()))
    else:
        _echo(description.to_text())
