"""``scenespeak points``: matched and triangulated keypoints of a stereo pair."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._app import (
    CalibOpt,
    CalibRightOpt,
    ImageSizeOpt,
    PitchOpt,
    PointsFormat,
    QuietOpt,
    SwapOpt,
    UnitsOpt,
    UpOpt,
    _check_ratio,
    _echo,
    _load_rig,
    _status,
    _write_text,
    app,
)
from scenespeak.cli._options import takes_options
from scenespeak.errors import InputError


@dataclass(frozen=True, kw_only=True)
class PointsCommand:
    """The command line of ``scenespeak points`` (see :mod:`scenespeak.cli._options`)."""

    left: Annotated[Path, typer.Argument(help="Left image.")]
    right: Annotated[Path, typer.Argument(help="Right image.")]
    calib: CalibOpt
    calib_right: CalibRightOpt = None
    fmt: Annotated[PointsFormat, typer.Option("--format", help="json or ply.")] = PointsFormat.json
    out: Annotated[Path | None, typer.Option("--out", help="Write here, not stdout.")] = None
    ratio: Annotated[
        float,
        typer.Option(help="Lowe's ratio test threshold, in (0, 1].", callback=_check_ratio),
    ] = 0.6
    image_size: ImageSizeOpt = None
    units: UnitsOpt = "m"
    up: UpOpt = None
    pitch: PitchOpt = None
    swap: SwapOpt = False
    quiet: QuietOpt = False


@app.command("points")
@takes_options(PointsCommand)
def points_cmd(o: PointsCommand) -> None:
    """Matched and triangulated keypoints of a stereo pair (before any labelling)."""
    from scenespeak.perception import plausibility, stereo
    from scenespeak.perception.features import load_image

    rig = _load_rig(
        o.calib,
        o.calib_right,
        image_size=o.image_size,
        units=o.units,
        up=o.up,
        pitch=o.pitch,
        swap=o.swap,
    )
    left, right = (o.right, o.left) if o.swap else (o.left, o.right)
    # colour, as describe reads them (one path: SIFT and SGBM see the same gray conversion)
    left_img = load_image(left, gray=False)
    right_img = load_image(right, gray=False)
    with _status("matching the stereo pair", o.quiet):
        plausibility.check_pair_order(left_img, right_img, rig, names=(str(left), str(right)))
        points = _stereo_points(
            stereo, left_img, right_img, rig, ratio=o.ratio, sources=(left, right)
        )
        plausibility.check_depths(points.xyz[:, 2], points.disparity, rig.source)
    if o.fmt is PointsFormat.ply:
        if o.out is None:
            raise InputError(
                "--out", "PLY is binary-free but long: give --out FILE for --format ply"
            )
        try:
            stereo.write_ply(points, o.out)
        except OSError as exc:
            raise InputError(o.out, f"cannot write ({exc.strerror or exc})") from exc
        return
    text = json.dumps(stereo.points_to_json(points))
    if o.out is None:
        _echo(text)
    else:
        _write_text(o.out, text + "\n")


def _stereo_points(
    stereo: Any, left: Any, right: Any, rig: Any, *, ratio: float, sources: tuple[Path, Path]
) -> Any:
    """The stereo stage with SIFT of both images at once; the dense check over the whole image.

    OpenCV releases the GIL in SIFT, so the right image's extraction runs in a second thread
    while this one does the left's: the points are those of the plain
    ``stereo_points(left, right, rig)`` by construction (``tests/cli/test_points_fast.py``).
    The dense SGBM check is NOT cropped to the matches as ``describe`` crops it
    (``PipelineOptions.dense_crop``): SGBM's semi-global path costs carry influence along whole
    rows and columns, so a cropped map differs from the whole image's in thousands of pixels at
    any margin, and the matches it keeps in about one of seventy on rendered scenes, at 16 px
    as at 150 px (``benchmarks/bench_points.py`` shows the time and the points of both).
    """
    from concurrent.futures import ThreadPoolExecutor

    from scenespeak.perception.features import detect, to_gray

    names = (str(sources[0]), str(sources[1]))
    stereo.check_pair(left, right, rig, left_name=names[0], right_name=names[1])
    with ThreadPoolExecutor(max_workers=1) as pool:
        future = pool.submit(detect, to_gray(right), precise_upscale=False)
        features_left = detect(to_gray(left), precise_upscale=False)
        features_right = future.result()
    result = stereo.stereo_points(
        left,
        right,
        rig,
        ratio=ratio,
        features_left=features_left,
        features_right=features_right,
        left_name=names[0],
        right_name=names[1],
        dense_crop=False,
        min_points=1,
    )
    return result.points
