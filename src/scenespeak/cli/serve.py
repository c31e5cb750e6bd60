"""``scenespeak serve``: the scene service and its viewer page (``docs/live.md``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from scenespeak.cli._app import DbOpt, app
from scenespeak.errors import InputError


@app.command("serve")
def serve_cmd(
    db: DbOpt,
    calib: Annotated[
        Path | None,
        typer.Option("--calib", help="Calibration used when a request sends none."),
    ] = None,
    host: Annotated[
        str, typer.Option("--host", help="Address to listen on (default: this machine only).")
    ] = "127.0.0.1",
    port: Annotated[int, typer.Option("--port", min=1, max=65535, help="TCP port.")] = 8765,
    workers: Annotated[
        int, typer.Option("--workers", min=1, max=64, help="Requests described at the same time.")
    ] = 2,
    max_mb: Annotated[
        float, typer.Option("--max-mb", min=0.01, help="Largest request body, MiB.")
    ] = 32.0,
    max_side: Annotated[
        int, typer.Option("--max-side", min=16, help="Largest image width or height, pixels.")
    ] = 4096,
    intrinsics: Annotated[
        Path | None,
        typer.Option("--intrinsics", help="Colour camera used when an RGB-D request sends none."),
    ] = None,
) -> None:
    """Serve describe and ask over HTTP, with the viewer page at /."""
    from scenespeak.live.service import ServiceLimits, serve

    if not Path(db).exists():
        raise InputError(db, "no such file (an object database made with `scenespeak db add`)")
    limits = ServiceLimits(
        max_body=int(max_mb * 1024 * 1024), max_side=max_side, max_pixels=max_side * max_side
    )
    serve(
        db, calib=calib, host=host, port=port, workers=workers, limits=limits, intrinsics=intrinsics
    )
