"""``scenespeak watch``: a stereo stream in, one JSON line per frame out (``docs/live.md``)."""

from __future__ import annotations

import json
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._app import CalibRightOpt, QuietOpt, app
from scenespeak.cli._options import takes_options
from scenespeak.errors import InputError, ScenespeakError


@dataclass(frozen=True)
class _StreamSource:
    """The stereo source options of ``watch`` (exactly one of them is to be given)."""

    frames: Path | None
    left_video: Path | None
    right_video: Path | None
    sbs: Path | None
    cameras: tuple[int, int] | None
    rosbag: Path | None
    topics: tuple[str | None, str | None]

    def given(self) -> list[str]:
        """The options given, by their flags."""
        flags = (
            ("--frames", self.frames),
            ("--left-video/--right-video", self.left_video or self.right_video),
            ("--sbs", self.sbs),
            ("--cameras", self.cameras),
            ("--rosbag", self.rosbag),
        )
        return [n for n, v in flags if v is not None]


def _source(src: _StreamSource, fps: float, max_frames: int | None) -> Iterator[Any]:
    from scenespeak.live import sources

    given = src.given()
    if len(given) != 1:
        raise InputError(
            "watch",
            "give exactly one source: --frames DIR, --left-video L --right-video R, --sbs F, "
            f"--cameras I J or --rosbag BAG (given: {', '.join(given) or 'none'})",
        )
    if src.frames is not None:
        return sources.folder_frames(src.frames, fps=fps)
    if src.left_video is not None or src.right_video is not None:
        if src.left_video is None or src.right_video is None:
            raise InputError("watch", "--left-video and --right-video go together")
        return sources.video_frames(src.left_video, src.right_video, max_frames=max_frames)
    if src.sbs is not None:
        return sources.sbs_frames(src.sbs, max_frames=max_frames)
    if src.cameras is not None:
        return sources.camera_frames(src.cameras[0], src.cameras[1], max_frames=max_frames)
    assert src.rosbag is not None
    left, right = src.topics
    if left is None or right is None:
        raise InputError(src.rosbag, "give --left-topic and --right-topic (sensor_msgs/Image)")
    return sources.rosbag_frames(src.rosbag, left, right)


def _rig(
    calib: Path | None,
    calib_right: Path | None,
    rosbag: Path | None,
    info: tuple[str | None, str | None],
    tmp: str,
) -> Any:
    from scenespeak.cli._app import _load_rig

    if calib is not None:
        return _load_rig(calib, calib_right)
    if rosbag is not None and info[0] and info[1]:
        from scenespeak.live.sources import rosbag_rig

        return rosbag_rig(rosbag, info[0], info[1], tmp)
    raise InputError(
        "watch", "give --calib (or, with --rosbag, --left-info and --right-info CameraInfo topics)"
    )


def _warn(where: str, problem: str) -> None:
    sys.stderr.write(f"scenespeak: warning: {where}: {problem}\n")
    sys.stderr.flush()


@dataclass(frozen=True, kw_only=True)
class WatchCommand:
    """The command line of ``scenespeak watch`` (see :mod:`scenespeak.cli._options`)."""

    db: Annotated[
        Path | None,
        typer.Option("--db", help="The object database (stereo; RGB-D frames without masks)."),
    ] = None
    calib: Annotated[
        Path | None, typer.Option("--calib", help="Calibration (as for describe).")
    ] = None
    calib_right: CalibRightOpt = None
    frames: Annotated[
        Path | None,
        typer.Option(
            "--frames", help="Folder: NNNN/{left,right}.png or left_NNNN.png + right_NNNN.png."
        ),
    ] = None
    left_video: Annotated[Path | None, typer.Option("--left-video", help="Left video.")] = None
    right_video: Annotated[Path | None, typer.Option("--right-video", help="Right video.")] = None
    sbs: Annotated[Path | None, typer.Option("--sbs", help="Side-by-side stereo video.")] = None
    cameras: Annotated[
        tuple[int, int] | None, typer.Option("--cameras", help="Two OpenCV camera indices.")
    ] = None
    rosbag: Annotated[Path | None, typer.Option("--rosbag", help="A ROS 2 (or 1) bag.")] = None
    left_topic: Annotated[str | None, typer.Option("--left-topic", help="Left Image topic.")] = None
    right_topic: Annotated[str | None, typer.Option("--right-topic", help="Right Image topic.")] = (
        None
    )
    left_info: Annotated[
        str | None, typer.Option("--left-info", help="Left CameraInfo topic (instead of --calib).")
    ] = None
    right_info: Annotated[
        str | None, typer.Option("--right-info", help="Right CameraInfo topic.")
    ] = None
    keyframe_every: Annotated[
        int,
        typer.Option("--keyframe-every", min=1, help="Full recognition at least every K frames."),
    ] = 10
    fps: Annotated[
        float, typer.Option("--fps", min=0.001, help="Frame rate of a --frames folder (time_s).")
    ] = 30.0
    max_frames: Annotated[
        int | None, typer.Option("--max-frames", min=1, help="Stop after this many frames.")
    ] = None
    unknown: Annotated[
        bool, typer.Option("--unknown/--no-unknown", help="Also keep unknown point clusters.")
    ] = False
    rgbd: Annotated[
        Path | None,
        typer.Option("--rgbd", help="Folder of RGB-D frames: NNNN/{color,depth,masks}.png."),
    ] = None
    color_topic: Annotated[str | None, typer.Option(help="Colour Image topic (RGB-D bag).")] = None
    depth_topic: Annotated[str | None, typer.Option(help="Depth Image topic (RGB-D bag).")] = None
    masks_topic: Annotated[str | None, typer.Option(help="Instance-mask Image topic.")] = None
    info_topic: Annotated[str | None, typer.Option(help="Colour CameraInfo topic.")] = None
    intrinsics: Annotated[
        Path | None, typer.Option("--intrinsics", help="Colour camera of RGB-D frames.")
    ] = None
    labels: Annotated[
        Path | None, typer.Option("--labels", help="Labels JSON of the RGB-D masks.")
    ] = None
    depth_scale: Annotated[
        float, typer.Option("--depth-scale", min=1e-9, help="Metres per depth unit.")
    ] = 0.001
    quiet: QuietOpt = False


@app.command("watch")
@takes_options(WatchCommand)
def watch_cmd(o: WatchCommand) -> None:
    """Describe a stereo or RGB-D stream frame by frame with a working memory (JSON Lines)."""
    from scenespeak.cli._watch_rgbd import RGBDWatch, watch_rgbd

    w = RGBDWatch(
        o.rgbd, o.rosbag, o.color_topic, o.depth_topic, o.masks_topic, o.info_topic,
        o.intrinsics, o.labels, o.depth_scale, o.fps, o.max_frames,
    )  # fmt: skip
    if w.wanted:
        watch_rgbd(w, o.db)
        return
    if o.db is None:
        raise InputError("--db", "a stereo stream needs the object database")
    from scenespeak.live.stream import SceneStream, StreamOptions
    from scenespeak.perception.database import ObjectDatabase
    from scenespeak.perception.tracking import TrackingOptions
    from scenespeak.pipeline import PipelineOptions

    # (o.quiet: no progress, the stream itself is the output)
    with tempfile.TemporaryDirectory(prefix="scenespeak-watch-") as tmp:
        rig = _rig(o.calib, o.calib_right, o.rosbag, (o.left_info, o.right_info), tmp)
        src = _StreamSource(
            o.frames, o.left_video, o.right_video, o.sbs, o.cameras, o.rosbag,
            (o.left_topic, o.right_topic),
        )  # fmt: skip
        items = _source(src, o.fps, o.max_frames)
        options = StreamOptions(
            tracking=TrackingOptions(keyframe_every=o.keyframe_every),
            pipeline=PipelineOptions(unknown=o.unknown, summary=False),
        )
        with ObjectDatabase.open(o.db, readonly=True) as database:
            stream = SceneStream(rig, database, options)
            _run(stream, items, o.max_frames)


def _run(stream: Any, items: Iterator[Any], max_frames: int | None) -> None:
    from scenespeak.live.sources import BrokenFrame

    done = 0
    for item in items:
        if max_frames is not None and done >= max_frames:
            break
        done += 1
        if isinstance(item, BrokenFrame):
            _warn(item.source, item.problem)
            continue
        try:
            frame = stream.process(item.left, item.right, item.time_s)
        except ScenespeakError as exc:
            _warn(item.source, str(exc))
            continue
        line = frame.to_dict()
        line["frame"] = item.index
        sys.stdout.write(json.dumps(line) + "\n")
        sys.stdout.flush()
