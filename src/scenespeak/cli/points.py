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
        # the pair-order check (swapped or unrelated images, a calibration that does not fit)
        # runs inside, on the stage's own SIFT features
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
    """What ``scenespeak points`` computes: the pair checks and the pipeline's stereo stage,
    as ``describe`` runs it (SIFT of both images at once, then ``stereo_points`` with the
    pipeline's :class:`~scenespeak.perception.stage_options.StereoOptions`: the dense check
    cropped to the matches plus ``DENSE_MARGIN`` = 16 px).

    One path for both commands (issue 10): the points are ``describe_scene(...).points`` bit
    for bit (``tests/cli/test_points_fast.py``). OpenCV releases the GIL in SIFT, so the right
    image's extraction runs in a second thread while this one does the left's; BLAS runs
    single-threaded as in the pipeline. Each image is converted to gray once, and
    :func:`~scenespeak.perception.plausibility.check_pair_order` (swapped or unrelated images,
    a calibration that does not fit) matches the stage's features instead of running SIFT on
    both images a second time (issue 16, session 6: that was about half of the command's
    time); it runs before the stage (its refusal comes first, as when it ran first), not in
    the second thread beside it as in session 6: OpenCV runs a ``parallel_for_`` that starts
    while another one is under way serially, so the dense map's SGBM, which started while the
    check's matcher ran, took one core instead of two (``benchmarks/points_timeline.py``,
    issue 16 session 7). Since session 8 the check's matcher is NumPy's, OpenCV's brute-force
    pairs bit for bit at about a quarter of the CPU (``plausibility._ratio_matches``). The
    points are those of the command before (``benchmarks/points_golden.py``).
    """
    from concurrent.futures import ThreadPoolExecutor

    from scenespeak.perception import plausibility
    from scenespeak.perception.blas import single_threaded_blas
    from scenespeak.perception.calibration import rectify
    from scenespeak.perception.features import detect, to_gray
    from scenespeak.perception.stage_options import StereoOptions

    names = (str(sources[0]), str(sources[1]))
    stereo.check_pair(left, right, rig, left_name=names[0], right_name=names[1])
    rect = rectify(rig)
    with single_threaded_blas():
        with ThreadPoolExecutor(max_workers=1) as pool:
            gray_right = to_gray(right)
            future = pool.submit(detect, gray_right, precise_upscale=False)
            gray_left = to_gray(left)
            features_left = detect(gray_left, precise_upscale=False)
            features_right = future.result()
        # the pair-order check needs only the features; it runs before the stage, not beside
        # it: OpenCV runs a parallel_for_ that starts while another thread's is under way
        # serially (one process-wide flag), so SGBM beside the check's matcher ran on one core
        plausibility.check_pair_order(
            gray_left, gray_right, rig, names=names, rect=rect,
            features=(features_left, features_right),
        )  # fmt: skip
        result = stereo.stereo_points(
            gray_left,
            gray_right,
            rig,
            rect=rect,
            features_left=features_left,
            features_right=features_right,
            left_name=names[0],
            right_name=names[1],
            min_points=1,
            **StereoOptions(ratio=ratio).keywords(),
        )
    return result.points
