"""``scenespeak scenes generate`` and ``scenespeak demo``."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Annotated, Any

import typer

from scenespeak.cli._app import (
    QuietOpt,
    TextOrJson,
    _echo,
    _progress,
    _status,
    _stderr_console,
    app,
    scenes_app,
)
from scenespeak.cli.describe import _print_description
from scenespeak.errors import InputError


@scenes_app.command("generate")
def scenes_generate(
    out: Annotated[Path, typer.Argument(help="Folder to write the dataset into.")],
    n: Annotated[int, typer.Option("--n", min=1, help="Number of scenes.")] = 10,
    seed: Annotated[
        int, typer.Option("--seed", min=0, max=2**32 - 1, help="Random seed (0 to 2**32-1).")
    ] = 0,
    pitched: Annotated[
        bool, typer.Option("--pitched", help="A rig pitched down instead of a level one.")
    ] = False,
    depth_noise: Annotated[
        bool,
        typer.Option(
            "--depth-noise",
            help="Also write depth_noisy.png: the depth as a structured-light / stereo depth "
            "camera gives it (Z^2 noise, quantisation, edge holes, flying pixels).",
        ),
    ] = False,
    config: Annotated[
        str,
        typer.Option(
            "--config",
            help="default, tuning or validation (12 objects learnt without masks, repeated "
            "instances, distractors, level and pitched rigs; docs/scenes.md).",
        ),
    ] = "default",
    quiet: QuietOpt = False,
) -> None:
    """Render stereo scenes of textured objects with their ground truth (and RGB-D views)."""
    _generate(
        out, n, seed=seed, pitched=pitched, quiet=quiet, depth_noise=depth_noise, config=config
    )
    _echo(f"wrote {n} scene(s) to {out}")


def _check_out(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder; give a folder to write the dataset into")


def _generate(
    out: Path,
    n: int,
    *,
    seed: int,
    pitched: bool,
    quiet: bool,
    depth_noise: bool = False,
    config: str = "default",
) -> Any:
    from scenespeak import limits
    from scenespeak.tools.scenes import generate_dataset

    if n > limits.current().max_scenes:
        raise InputError("--n", limits.exceeded("max_scenes", f"{n} scenes", 0))
    _check_out(out)

    progress = _progress(n, "rendering", quiet)
    if progress is None:
        return generate_dataset(
            out,
            n,
            seed=seed,
            pitched=pitched,
            progress=None,
            depth_noise=depth_noise,
            config=config,
        )
    with progress:
        task = progress.add_task("rendering", total=None)

        def advance(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        return generate_dataset(
            out,
            n,
            seed=seed,
            pitched=pitched,
            progress=advance,
            depth_noise=depth_noise,
            config=config,
        )


@app.command("demo")
def demo_cmd(
    out: Annotated[
        Path | None,
        typer.Argument(help="Folder for the scene and database (default: a temporary folder)."),
    ] = None,
    seed: Annotated[
        int,
        typer.Option(
            "--seed", min=0, max=2**32 - 1, help="Random seed of the scene (0 to 2**32-1)."
        ),
    ] = 0,
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
