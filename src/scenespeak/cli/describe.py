"""``scenespeak describe`` and the printing of a scene description.

The scene's input options (images, calibration, database, and whatever input forms are added
here later) are read by :func:`describe_inputs`; ``scenespeak ask`` (``cli/ask.py``) takes the
same options by copying this command's signature (the fields of :class:`DescribeCommand`, see
:mod:`scenespeak.cli._options`) minus :data:`OUTPUT_OPTIONS`, so a new input form added to
``DescribeCommand`` and handled in :func:`describe_inputs` reaches ``ask`` as is.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._app import (
    CalibRightOpt,
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
from scenespeak.cli._options import takes_options
from scenespeak.errors import InputError

#: describe_cmd's options (fields of :class:`DescribeCommand`) that say what to print, not
#: which scene: ``ask`` leaves them out.
OUTPUT_OPTIONS = frozenset({"fmt", "figures", "summary", "viewer", "about", "quiet"})


@dataclass(frozen=True, kw_only=True)
class DescribeCommand:
    """The command line of ``scenespeak describe`` (``ask`` takes its inputs, see above)."""

    images: Annotated[
        list[Path],
        typer.Argument(
            help="LEFT RIGHT (a stereo pair, with --calib), or one COLOR image (with --depth "
            "and --intrinsics, or with --masks/--boxes alone for the image plane)."
        ),
    ]
    db: Annotated[Path | None, typer.Option("--db", help="The object database (SQLite file).")] = (
        None
    )
    calib: Annotated[
        Path | None,
        typer.Option(
            "--calib",
            help="Calibration of a stereo pair: JSON (short or full form), OpenCV FileStorage "
            "YAML, or the LEFT camera_info YAML of a ROS pair (then give --calib-right).",
        ),
    ] = None
    calib_right: CalibRightOpt = None
    depth: Annotated[
        Path | None,
        typer.Option(
            "--depth",
            help="Depth registered to COLOR: 16-bit PNG (units of --depth-scale metres), float "
            "TIFF or .npy in metres; 0, NaN, inf = no depth.",
        ),
    ] = None
    depth_scale: Annotated[
        float, typer.Option("--depth-scale", help="Metres per unit of an integer depth image.")
    ] = 0.001
    intrinsics: Annotated[
        Path | None,
        typer.Option(
            "--intrinsics",
            help='COLOR\'s camera: JSON {"fx","fy","cx","cy","width","height","up"?}, ROS '
            "camera_info YAML or OpenCV YAML.",
        ),
    ] = None
    masks: Annotated[
        Path | None,
        typer.Option(
            "--masks", help="Instance image (PNG 8/16-bit, 0 = background, k = instance k)."
        ),
    ] = None
    labels: Annotated[
        Path | None,
        typer.Option("--labels", help='Labels of the instances: JSON {"1": "mug", "2": "can"}.'),
    ] = None
    boxes: Annotated[
        Path | None,
        typer.Option(
            "--boxes", help='COCO detections: [{"bbox": [x, y, w, h], "label": ..., "score": ...}].'
        ),
    ] = None
    min_score: Annotated[
        float, typer.Option("--min-score", help="Ignore boxes with a lower score.")
    ] = 0.0
    estimate_up: Annotated[
        bool,
        typer.Option(
            "--estimate-up", help="Estimate up from the support plane even if --intrinsics give it."
        ),
    ] = False
    fmt: Annotated[TextOrJson, typer.Option("--format", help="text or json.")] = TextOrJson.text
    figures: Annotated[
        Path | None, typer.Option("--figures", help="Also write a PNG of every stage here.")
    ] = None
    dense: Annotated[
        bool,
        typer.Option(
            "--dense/--no-dense",
            help="Take each recognised object's points from dense stereo inside its outline.",
        ),
    ] = True
    unknown: Annotated[
        bool,
        typer.Option(
            "--unknown/--no-unknown", help="Cluster unlabelled points into unknown objects."
        ),
    ] = True
    summary: Annotated[
        bool, typer.Option("--summary", help="At most n + 1 sentences about the whole scene.")
    ] = False
    viewer: Annotated[
        bool,
        typer.Option("--viewer", help='Each object relative to the camera ("in front of me").'),
    ] = False
    about: Annotated[
        str | None,
        typer.Option("--about", help="Only the relations whose argument is this object."),
    ] = None
    image_size: ImageSizeOpt = None
    units: UnitsOpt = "m"
    up: UpOpt = None
    pitch: PitchOpt = None
    swap: SwapOpt = False
    quiet: QuietOpt = False


@app.command("describe")
@takes_options(DescribeCommand)
def describe_cmd(o: DescribeCommand) -> None:
    """Describe the spatial relations of the objects: a stereo pair, colour + depth, or masks."""
    if o.figures is not None and (len(o.images) != 2 or o.db is None):
        raise InputError(
            "--figures", "the stage pictures are drawn for stereo pairs with --db only"
        )
    inputs = {
        f.name: getattr(o, f.name) for f in dataclasses.fields(o) if f.name not in OUTPUT_OPTIONS
    }
    with _status("describing the scene", o.quiet):
        description = describe_inputs(**inputs)
    if o.figures is not None:
        _write_figures(description, o.figures)
    if o.summary or o.viewer or o.about is not None:
        _print_views(description, o.fmt, summary=o.summary, viewer=o.viewer, about=o.about)
    else:
        _print_description(description, o.fmt)


def describe_inputs(**inputs: Any) -> Any:
    """Describe the scene the input options of ``describe`` name (also used by ``ask``).

    Parameters
    ----------
    **inputs
        The fields of :class:`DescribeCommand` that are not in :data:`OUTPUT_OPTIONS` (``images``,
        ``db``, ``calib``, ``depth``, ``masks`` …; None where not given).

    Returns
    -------
    SceneDescription or the RGB-D / image-plane description

    Raises
    ------
    InputError
        When the inputs name no scene (``ask`` makes them all optional because of
        ``--scene``) or an impossible combination.
    """
    from scenespeak.inputs import SceneInputs
    from scenespeak.inputs import describe_inputs as describe

    images = list(inputs.get("images") or [])
    if len(images) not in (1, 2):
        raise InputError(
            "IMAGES",
            f"give LEFT RIGHT (a stereo pair) or one COLOR image, not {len(images)} "
            "(or --scene FILE for a saved description)",
        )
    stereo_db = (
        len(images) == 2
        and inputs.get("db") is not None
        and all(inputs.get(k) is None for k in ("masks", "boxes", "depth", "labels"))
    )
    if stereo_db and inputs.get("calib") is not None:
        # The stereo pipeline with the calibration options and plausibility checks of
        # docs/trust.md (--units, --up/--pitch, --image-size, --swap).
        rig = _load_rig(
            inputs["calib"],
            inputs.get("calib_right"),
            image_size=inputs.get("image_size"),
            units=inputs.get("units") or "m",
            up=inputs.get("up"),
            pitch=inputs.get("pitch"),
            swap=bool(inputs.get("swap")),
        )
        left, right = images
        if inputs.get("swap"):
            left, right = right, left
        return _describe(
            left,
            right,
            rig,
            inputs["db"],
            dense=inputs.get("dense") is not False,
            unknown=inputs.get("unknown") is not False,
        )
    scene_inputs = SceneInputs(
        color=images[0],
        right=images[1] if len(images) == 2 else None,
        calib=inputs.get("calib"),
        calib_right=inputs.get("calib_right"),
        depth=inputs.get("depth"),
        depth_scale=float(_default(inputs.get("depth_scale"), 0.001)),  # 0 is refused, not 1 mm
        intrinsics=inputs.get("intrinsics"),
        masks=inputs.get("masks"),
        labels=inputs.get("labels"),
        boxes=inputs.get("boxes"),
        min_score=float(inputs.get("min_score") or 0.0),
        db=inputs.get("db"),
        estimate_up=bool(inputs.get("estimate_up")),
    )
    dense = inputs.get("dense")
    unknown = inputs.get("unknown")
    return describe(
        scene_inputs,
        dense=True if dense is None else bool(dense),
        unknown=True if unknown is None else bool(unknown),
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


def _describe(left: Path, right: Path, rig: Any, db: Path, **options: Any) -> Any:
    """The pipeline on files, with the plausibility checks of ``docs/trust.md``."""
    import numpy as np

    from scenespeak.perception import dbfiles, plausibility
    from scenespeak.perception.features import load_image
    from scenespeak.perception.recognition import ObjectDatabase
    from scenespeak.perception.stage_options import StereoOptions
    from scenespeak.pipeline import describe_scene

    left_img = load_image(left, gray=False)
    right_img = load_image(right, gray=False)
    sources = {"left": str(left), "right": str(right), "calib": rig.source, "db": str(db)}
    dbfiles.check_file(db)
    dbfiles.validate(db)
    # the stereo stage refuses a swapped or unrelated pair first, on its own SIFT features
    # (check_order; before session 6 the check ran SIFT on both images once more here)
    stereo_options = StereoOptions(check_order=True)
    with ObjectDatabase.open(db, readonly=True) as database:
        description = describe_scene(
            left_img, right_img, rig, database, sources=sources, stereo=stereo_options, **options
        )
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


def _default(value: Any, default: float) -> Any:
    """``value`` unless it was not given (None): ``x or default`` would turn 0 into the default."""
    return default if value is None else value
