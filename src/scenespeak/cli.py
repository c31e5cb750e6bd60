"""The ``scenespeak`` command (see ``docs/cli.md``). It only calls the library.

Every error a user can cause is a :class:`~scenespeak.errors.ScenespeakError`; :func:`main`
catches it in one place and prints one line, ``scenespeak: error: <file>: <problem>``, on stderr
with exit status 2. Results go to stdout (JSON stays clean); progress goes to stderr.
"""

from __future__ import annotations

import json
import sys
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.errors import InputError, ScenespeakError

__all__ = ["app", "main"]

#: Exit status for input the program could not use (like argparse's usage errors).
EXIT_INPUT = 2

app = typer.Typer(
    name="scenespeak",
    help="Say in words where objects are, from a stereo camera pair.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
db_app = typer.Typer(help="Manage the object database (labelled SIFT descriptors).")
scenes_app = typer.Typer(help="Render stereo scenes with ground truth.")
app.add_typer(db_app, name="db", no_args_is_help=True)
app.add_typer(scenes_app, name="scenes", no_args_is_help=True)


class TextOrJson(StrEnum):
    text = "text"
    json = "json"


class PointsFormat(StrEnum):
    json = "json"
    ply = "ply"


# --------------------------------------------------------------------------------------------
# helpers


def _stderr_console() -> Any:
    from rich.console import Console

    return Console(stderr=True)


@contextmanager
def _status(message: str, quiet: bool = False) -> Iterator[None]:
    """A spinner on stderr (only when stderr is a terminal; never on stdout)."""
    if quiet or not sys.stderr.isatty():
        yield
        return
    with _stderr_console().status(message):
        yield


def _progress(total: int, description: str, quiet: bool = False) -> Any:
    """A rich progress bar on stderr, or None when stderr is not a terminal."""
    if quiet or not sys.stderr.isatty():
        return None
    from rich.progress import Progress

    return Progress(console=_stderr_console(), transient=True)


def _echo(text: str) -> None:
    sys.stdout.write(text if text.endswith("\n") else text + "\n")


def _load_rig(calib: Path, calib_right: Path | None) -> Any:
    from scenespeak import calibration

    if calib_right is not None:
        return calibration.load_ros_rig(calib, calib_right)
    return calibration.load_rig(calib)


def _write_text(path: Path, text: str) -> None:
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise InputError(path, f"cannot write ({exc.strerror})") from exc


CalibOpt = Annotated[
    Path,
    typer.Option(
        "--calib",
        help="Calibration: JSON (short or full form), OpenCV FileStorage YAML, or the LEFT "
        "camera_info YAML of a ROS pair (then give --calib-right).",
    ),
]
CalibRightOpt = Annotated[
    Path | None,
    typer.Option("--calib-right", help="The RIGHT camera_info YAML of a ROS pair."),
]
DbOpt = Annotated[Path, typer.Option("--db", help="The object database (SQLite file).")]
QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="No progress on stderr.")]


# --------------------------------------------------------------------------------------------
# db


@db_app.command("add")
def db_add(
    images: Annotated[list[Path], typer.Argument(help="Training images of the object.")],
    db: DbOpt,
    label: Annotated[str, typer.Option("--label", help="The object's name.")],
    mask: Annotated[
        list[Path] | None,
        typer.Option(
            "--mask",
            help="A mask per image (white = object), in the same order; repeat the option.",
        ),
    ] = None,
    quiet: QuietOpt = False,
) -> None:
    """Learn an object from training images (a transaction: all or nothing)."""
    from scenespeak.database import ObjectDatabase

    masks = list(mask) if mask else None
    if masks is not None and len(masks) != len(images):
        raise InputError("--mask", f"{len(masks)} masks for {len(images)} images; give one each")
    with (
        _status(f"learning {label!r} from {len(images)} image(s)", quiet),
        ObjectDatabase.open(db, create=True) as database,
    ):
        info = database.add_object(label, images, masks=masks)
    _echo(f"added {info.label!r}: {info.views} view(s), {info.descriptors} descriptors")


@db_app.command("list")
def db_list(
    db: DbOpt,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """List the objects in the database."""
    from scenespeak.database import ObjectDatabase

    with ObjectDatabase.open(db, readonly=True) as database:
        rows = [
            {"label": o.label, "views": o.views, "descriptors": o.descriptors, "added": o.added}
            for o in database.list_objects()
        ]
    if as_json:
        _echo(json.dumps({"objects": rows}))
        return
    if not rows:
        _echo("(no objects)")
    for row in rows:
        _echo(f"{row['label']}\t{row['views']} view(s)\t{row['descriptors']} descriptors")


@db_app.command("remove")
def db_remove(
    labels: Annotated[list[str], typer.Argument(help="Labels to remove.")],
    db: DbOpt,
) -> None:
    """Remove objects from the database."""
    from scenespeak.database import ObjectDatabase

    with ObjectDatabase.open(db) as database:
        for lab in labels:
            database.remove(lab)
    _echo("removed " + ", ".join(repr(lab) for lab in labels))


# --------------------------------------------------------------------------------------------
# points


@app.command("points")
def points_cmd(
    left: Annotated[Path, typer.Argument(help="Left image.")],
    right: Annotated[Path, typer.Argument(help="Right image.")],
    calib: CalibOpt,
    calib_right: CalibRightOpt = None,
    fmt: Annotated[PointsFormat, typer.Option("--format", help="json or ply.")] = (
        PointsFormat.json
    ),
    out: Annotated[Path | None, typer.Option("--out", help="Write here, not stdout.")] = None,
    ratio: Annotated[float, typer.Option(help="Lowe's ratio test threshold.")] = 0.6,
    quiet: QuietOpt = False,
) -> None:
    """Matched and triangulated keypoints of a stereo pair (before any labelling)."""
    from scenespeak import stereo
    from scenespeak.features import load_image

    rig = _load_rig(calib, calib_right)
    left_img = load_image(left)
    right_img = load_image(right)
    with _status("matching the stereo pair", quiet):
        points = _stereo_points(
            stereo, left_img, right_img, rig, ratio=ratio, sources=(left, right)
        )
    if fmt is PointsFormat.ply:
        if out is None:
            raise InputError(
                "--out", "PLY is binary-free but long: give --out FILE for --format ply"
            )
        try:
            stereo.write_ply(points, out)
        except OSError as exc:
            raise InputError(out, f"cannot write ({exc.strerror})") from exc
        return
    text = json.dumps(stereo.points_to_json(points))
    if out is None:
        _echo(text)
    else:
        _write_text(out, text + "\n")


def _stereo_points(
    stereo: Any, left: Any, right: Any, rig: Any, *, ratio: float, sources: tuple[Path, Path]
) -> Any:
    result = stereo.stereo_points(
        left, right, rig, ratio=ratio, left_name=str(sources[0]), right_name=str(sources[1])
    )
    return result.points


# --------------------------------------------------------------------------------------------
# describe


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
    from scenespeak.figures import write_figures

    return write_figures(description, out_dir)


def _print_description(description: Any, fmt: TextOrJson) -> None:
    if fmt is TextOrJson.json:
        _echo(json.dumps(description.to_dict()))
    else:
        _echo(description.to_text())


# --------------------------------------------------------------------------------------------
# scenes, demo


@scenes_app.command("generate")
def scenes_generate(
    out: Annotated[Path, typer.Argument(help="Folder to write the dataset into.")],
    n: Annotated[int, typer.Option("--n", min=1, help="Number of scenes.")] = 10,
    seed: Annotated[int, typer.Option("--seed", help="Random seed.")] = 0,
    pitched: Annotated[
        bool, typer.Option("--pitched", help="A rig pitched down instead of a level one.")
    ] = False,
    quiet: QuietOpt = False,
) -> None:
    """Render stereo scenes of textured objects with their ground truth."""
    _generate(out, n, seed=seed, pitched=pitched, quiet=quiet)
    _echo(f"wrote {n} scene(s) to {out}")


def _generate(out: Path, n: int, *, seed: int, pitched: bool, quiet: bool) -> Any:
    from scenespeak.scenes import generate_dataset

    progress = _progress(n, "rendering", quiet)
    if progress is None:
        return generate_dataset(out, n, seed=seed, pitched=pitched, progress=None)
    with progress:
        task = progress.add_task("rendering", total=None)

        def advance(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        return generate_dataset(out, n, seed=seed, pitched=pitched, progress=advance)


@app.command("demo")
def demo_cmd(
    out: Annotated[
        Path | None,
        typer.Argument(help="Folder for the scene and database (default: a temporary folder)."),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Random seed of the scene.")] = 0,
    fmt: Annotated[TextOrJson, typer.Option("--format", help="text or json.")] = TextOrJson.text,
    quiet: QuietOpt = False,
) -> None:
    """Render one scene, learn its objects, describe it and print the sentences."""
    if out is None:
        with tempfile.TemporaryDirectory(prefix="scenespeak-demo-") as tmp:
            _demo(Path(tmp), seed, fmt, quiet)
    else:
        _demo(out, seed, fmt, quiet)


def _demo(out: Path, seed: int, fmt: TextOrJson, quiet: bool) -> None:
    from scenespeak.pipeline import database_from_dataset, describe_files

    err = _stderr_console()
    _generate(out, 1, seed=seed, pitched=False, quiet=quiet)
    db_path = out / "objects.db"
    with _status("learning the objects from their training views", quiet):
        labels = database_from_dataset(out, db_path)
    scene = out / "scene_000"
    if not quiet:
        err.print(f"scene: {scene} · objects learnt: {', '.join(labels)}", highlight=False)
    with _status("describing the scene", quiet):
        description = describe_files(
            scene / "left.png", scene / "right.png", scene / "calib.json", db_path
        )
    _print_description(description, fmt)


# --------------------------------------------------------------------------------------------
# evaluate (the figures/evaluation engineer's module; wired only when it exists)


def _has_module(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None


if _has_module("scenespeak.evaluation"):

    @app.command("evaluate")
    def evaluate_cmd(
        dataset: Annotated[Path, typer.Argument(help="A generated dataset folder.")],
        as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
        workers: Annotated[int, typer.Option("--workers", min=1, help="Processes.")] = 2,
        db: Annotated[
            Path | None, typer.Option("--db", help="Object database (default: learnt).")
        ] = None,
        quiet: QuietOpt = False,
    ) -> None:
        """Describe every scene of a dataset and score it against the ground truth."""
        from scenespeak.evaluation import evaluate, format_table

        progress = _progress(0, "evaluating", quiet)
        if progress is None:
            result = evaluate(dataset, db=db, workers=workers, progress=None)
        else:
            with progress:
                task = progress.add_task("describing scenes", total=None)

                def advance(done: int, total: int) -> None:
                    progress.update(task, completed=done, total=total)

                result = evaluate(dataset, db=db, workers=workers, progress=advance)
        _echo(json.dumps(result.to_dict()) if as_json else format_table(result))


# --------------------------------------------------------------------------------------------
# entry point


def _error_line(exc: BaseException) -> str:
    return f"scenespeak: error: {exc}"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status (0 success, 2 bad input, 1 other).

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments without the program name (default ``sys.argv[1:]``).

    Examples
    --------
    >>> main(["--help"]) == 0  # doctest: +SKIP
    True
    """
    args = list(sys.argv[1:] if argv is None else argv)
    command = typer.main.get_command(app)
    try:
        # Standalone mode: click/typer print usage errors themselves and raise SystemExit.
        command.main(args=args, prog_name="scenespeak", standalone_mode=True)
    except ScenespeakError as exc:
        sys.stderr.write(_error_line(exc) + "\n")
        return EXIT_INPUT
    except BrokenPipeError:  # e.g. `scenespeak describe ... | head -1`
        return 0
    except SystemExit as exc:
        code = exc.code
        if code is None:
            return 0
        if isinstance(code, int):
            return code
        sys.stderr.write(f"{code}\n")
        return 1
    return 0
