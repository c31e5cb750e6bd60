"""The scene service: describe and ask over HTTP, and the viewer page (``scenespeak serve``).

``interfaces.md``, "A scene service and a viewer": ``GET /api/health``, ``POST /api/describe``
and ``POST /api/ask`` (multipart forms), ``GET /`` the viewer. Built on FastAPI; served by
uvicorn (:func:`serve`), bound to 127.0.0.1 unless told otherwise.

- **One database, loaded once per worker.** The CPU work runs in a pool of ``workers``
  threads (OpenCV and NumPy release the GIL), each with its own read-only connection to the
  database opened and indexed at start-up (SQLite connections belong to their thread); the
  event loop only parses requests, so ``/api/health`` answers while describes run.
- **Limits, checked before anything is decoded**: the request body (``max_body`` bytes, from
  ``Content-Length`` or counted while it arrives), each image's size as its PNG or JPEG header
  states it (``max_side`` pixels a side, ``max_pixels`` in all), the calibration file
  (64 KiB), the number of form parts.
- **Errors**: anything wrong with a request is a 4xx response ``{"error": "<one line>"}``
  (400 bad input, 413 too large, 415 not PNG/JPEG; 501 for questions when this version
  cannot answer them); an unexpected failure is
  a 500 with the same shape, and the server goes on.

The JSON of ``/api/describe`` is the JSON of ``scenespeak describe --format json`` for the same
files (:meth:`scenespeak.pipeline.SceneDescription.to_dict`); the field ``outlines=true`` adds
``"image": {"width", "height", "outlines": [{"label", "outline"}]}`` for the viewer.
"""

from __future__ import annotations

import asyncio
import struct
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from starlette.requests import Request

from scenespeak.errors import ScenespeakError

__all__ = ["ServiceLimits", "create_app", "image_size_from_header", "serve"]

#: The viewer page's files (package data).
STATIC = Path(__file__).with_name("static")


@dataclass(frozen=True)
class ServiceLimits:
    """What a request may hold.

    Attributes
    ----------
    max_body : int
        Bytes of the whole request body.
    max_side, max_pixels : int
        Largest width or height, and width × height, of an image (from its header).
    max_calib : int
        Bytes of a calibration file.
    max_question : int
        Characters of a question.
    """

    max_body: int = 32 * 1024 * 1024
    max_side: int = 4096
    max_pixels: int = 4096 * 3072
    max_calib: int = 64 * 1024
    max_question: int = 500


class RequestProblem(Exception):
    """A client error: HTTP status and a one-line message."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = " ".join(str(message).split())


# --------------------------------------------------------------------------------------------
# image headers


def image_size_from_header(data: bytes) -> tuple[str, int, int]:
    """Format, width and height of a PNG or JPEG from its header, without decoding it.

    Raises
    ------
    ValueError
        Neither PNG nor JPEG, or a header that ends too soon.

    Examples
    --------
    >>> import cv2, numpy as np
    >>> ok, png = cv2.imencode(".png", np.zeros((30, 40), np.uint8))
    >>> image_size_from_header(png.tobytes())
    ('png', 40, 30)
    """
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        if len(data) < 24 or data[12:16] != b"IHDR":
            raise ValueError("a PNG without its IHDR header")
        w, h = struct.unpack(">II", data[16:24])
        return "png", int(w), int(h)
    if data[:2] == b"\xff\xd8":
        i = 2
        while i + 4 <= len(data):
            if data[i] != 0xFF:
                raise ValueError("a JPEG with a broken marker")
            marker = data[i + 1]
            if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
                i += 2
                continue
            (length,) = struct.unpack(">H", data[i + 2 : i + 4])
            if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
                if i + 9 > len(data):
                    break
                h, w = struct.unpack(">HH", data[i + 5 : i + 9])
                return "jpeg", int(w), int(h)
            i += 2 + length
        raise ValueError("a JPEG whose size header is missing or cut short")
    raise ValueError("not a PNG or JPEG image")


def _decode(data: bytes, name: str, limits: ServiceLimits) -> NDArray[np.uint8]:
    import cv2

    if not data:
        raise RequestProblem(400, f"{name}: the file is empty")
    try:
        _, w, h = image_size_from_header(data)
    except ValueError as exc:
        raise RequestProblem(415, f"{name}: {exc}") from None
    if w <= 0 or h <= 0:
        raise RequestProblem(400, f"{name}: the header says {w}x{h} pixels")
    if max(w, h) > limits.max_side or w * h > limits.max_pixels:
        raise RequestProblem(
            413,
            f"{name}: {w}x{h} pixels is too large (at most {limits.max_side} a side and "
            f"{limits.max_pixels} pixels)",
        )
    from scenespeak.safeio import decode_image

    try:  # OpenCV's and libpng's own warnings captured: the answer says it once
        img = decode_image(data, name, flags=cv2.IMREAD_COLOR)
    except ScenespeakError:
        raise RequestProblem(400, f"{name}: cannot be decoded (corrupt or truncated)") from None
    if img.shape[1] != w or img.shape[0] != h:
        raise RequestProblem(400, f"{name}: decodes to a size its header does not state")
    rgb = cv2.cvtColor(np.asarray(img, dtype=np.uint8), cv2.COLOR_BGR2RGB)
    return np.ascontiguousarray(rgb, dtype=np.uint8)


# --------------------------------------------------------------------------------------------
# the work (in the worker threads)


class _Workers:
    """A thread pool whose threads each hold an open, indexed database."""

    def __init__(self, db_path: Path, workers: int) -> None:
        # imported here, once: two worker threads importing the database package at the same
        # time could see it half-initialised (its compatibility alias swaps sys.modules)
        import scenespeak.perception.recognition  # noqa: F401

        self.db_path = db_path
        self.local = threading.local()
        self.pool = ThreadPoolExecutor(
            max_workers=workers, thread_name_prefix="scenespeak-serve", initializer=self._open
        )
        # open every worker's database now (a bad file fails at start-up, not per request)
        for f in [self.pool.submit(self._ready) for _ in range(workers)]:
            f.result()

    def _open(self) -> None:
        from scenespeak.perception.recognition import ObjectDatabase

        try:
            db = ObjectDatabase.open(self.db_path, readonly=True)
        except ScenespeakError as exc:
            self.local.error = exc
            return
        self.local.db = db

    def _ready(self) -> None:
        import time

        err = getattr(self.local, "error", None)
        if err is not None:
            raise err
        time.sleep(0.05)  # let the other workers take their share of the warm-up calls

    def db(self) -> Any:
        err = getattr(self.local, "error", None)
        if err is not None:
            raise err
        return self.local.db

    def close(self) -> None:
        """Close every worker's database in its own thread, then stop the pool."""
        n = self.pool._max_workers
        barrier = threading.Barrier(n, timeout=30)

        def close_mine() -> None:
            db = getattr(self.local, "db", None)
            if db is not None:
                db.close()
            try:
                barrier.wait()  # so that every thread takes one of these jobs
            except threading.BrokenBarrierError:
                pass

        for f in [self.pool.submit(close_mine) for _ in range(n)]:
            f.result()
        self.pool.shutdown(wait=True)


def _outlines(description: Any) -> dict[str, Any]:
    """Each described object's outline in the left image (for the viewer)."""
    import cv2

    h, w = description.left.shape[:2]
    carried = {d.label: np.asarray(d.outline_in_scene, float) for d in description.detections}
    K = np.asarray(description.rig.K_left, dtype=np.float64)
    out = []
    for o in description.objects:
        if o.label in carried:
            poly = carried[o.label]
        else:
            xyz = np.asarray(o.xyz, dtype=np.float64)
            uv = (xyz @ K.T)[:, :2] / np.maximum(xyz[:, 2:3], 1e-9)
            poly = cv2.convexHull(uv.astype(np.float32)).reshape(-1, 2)
        out.append(
            {
                "label": o.label,
                "outline": [[round(float(x), 1), round(float(y), 1)] for x, y in poly],
            }
        )
    return {"width": int(w), "height": int(h), "outlines": out}


def _describe_job(
    workers: _Workers,
    left: bytes,
    right: bytes,
    calib: tuple[str, bytes] | None,
    default_calib: Path | None,
    limits: ServiceLimits,
    want_outlines: bool,
) -> tuple[Any, dict[str, Any]]:
    from scenespeak.perception.calibfiles import read_calibration as load_rig
    from scenespeak.perception.plausibility import check_rig
    from scenespeak.pipeline import describe_scene

    l_img = _decode(left, "left", limits)
    r_img = _decode(right, "right", limits)
    if calib is not None:
        name, data = calib
        suffix = (
            Path(name).suffix.lower()
            if Path(name).suffix.lower() in (".json", ".yaml", ".yml", ".xml")
            else ".json"
        )
        with tempfile.TemporaryDirectory(prefix="scenespeak-serve-") as tmp:
            p = Path(tmp) / f"calib{suffix}"
            p.write_bytes(data)
            try:  # bounded parsing (no XML entities), and a rig in mm is refused
                rig = check_rig(load_rig(p))
            except ScenespeakError as exc:
                raise RequestProblem(
                    400, "calib: " + str(exc).replace(str(p), "").lstrip(": ")
                ) from None
    elif default_calib is not None:
        rig = load_rig(default_calib)
    else:
        raise RequestProblem(400, "no calibration: send a file `calib` (the server has no --calib)")
    sources = {"left": "left", "right": "right", "calib": "calib", "db": "database"}
    description = describe_scene(l_img, r_img, rig, workers.db(), sources=sources)
    result = description.to_dict()
    if want_outlines:
        result["image"] = _outlines(description)
    return description, result


# --------------------------------------------------------------------------------------------
# the app


def _truthy(v: Any) -> bool:
    return str(v).strip().lower() in ("1", "true", "yes", "on")


def create_app(  # noqa: C901 (complexity 41 > 15: to be split into route modules)
    db_path: str | Path,
    *,
    calib: str | Path | None = None,
    workers: int = 2,
    limits: ServiceLimits | None = None,
    intrinsics: str | Path | None = None,
) -> Any:
    """The FastAPI application (the database is opened by every worker thread now).

    ``intrinsics`` is used by RGB-D requests (``color`` + ``depth``) that send none.

    Raises
    ------
    DatabaseError
        If ``db_path`` is not a usable object database.
    """
    from contextlib import asynccontextmanager

    from fastapi import FastAPI
    from fastapi.responses import FileResponse, JSONResponse, PlainTextResponse
    from fastapi.staticfiles import StaticFiles
    from starlette.datastructures import UploadFile

    lim = limits or ServiceLimits()
    import logging

    for noisy in ("python_multipart", "multipart"):  # its parse warnings: our answer says it
        logging.getLogger(noisy).setLevel(logging.ERROR)
    default_calib = Path(calib) if calib is not None else None
    if default_calib is not None:
        from scenespeak.perception.calibration import load_rig

        load_rig(default_calib)  # fail at start-up, not per request
    default_intrinsics = Path(intrinsics) if intrinsics is not None else None
    if default_intrinsics is not None:
        from scenespeak.perception.intrinsics import load_intrinsics

        load_intrinsics(default_intrinsics)  # fail at start-up, not per request
    pool = _Workers(Path(db_path), max(1, int(workers)))

    @asynccontextmanager
    async def lifespan(_app: Any) -> Any:
        yield
        pool.close()

    app = FastAPI(title="scenespeak", lifespan=lifespan, docs_url=None, redoc_url=None)
    app.state.workers = pool

    def error(status: int, message: str) -> Any:
        return JSONResponse({"error": " ".join(message.split())}, status_code=status)

    @app.middleware("http")
    async def body_limit(request: Request, call_next: Any) -> Any:
        length = request.headers.get("content-length")
        if length is not None:
            try:
                n = int(length)
            except ValueError:
                return error(400, "Content-Length is not a number")
            if n > lim.max_body:
                return error(413, f"the request body is {n} bytes; at most {lim.max_body}")
        try:
            return await call_next(request)
        except Exception as exc:  # the server must not die on a request
            return error(500, f"internal error ({type(exc).__name__})")

    async def read_form(request: Request) -> tuple[dict[str, tuple[str, bytes]], dict[str, str]]:
        ctype = request.headers.get("content-type", "")
        if not ctype.startswith("multipart/form-data"):
            raise RequestProblem(400, "send a multipart/form-data form (files left, right, ...)")
        received = 0
        chunks: list[bytes] = []
        async for chunk in request.stream():
            received += len(chunk)
            if received > lim.max_body:
                # Read (and drop) up to as much again, so that the client, still sending, reads
                # the answer instead of a reset connection; then answer.
                if received > 2 * lim.max_body:
                    break
                chunks = []
                continue
            chunks.append(chunk)
        if received > lim.max_body:
            raise RequestProblem(413, f"the request body is over {lim.max_body} bytes")
        body = b"".join(chunks)

        async def replay() -> dict[str, Any]:
            return {"type": "http.request", "body": body, "more_body": False}

        clone = Request(request.scope, replay)
        try:
            form = await clone.form(max_files=6, max_fields=12, max_part_size=lim.max_calib)
        except Exception as exc:  # python-multipart raises several types
            text = str(exc)
            if "maximum size" in text:  # which field is not said: name the ones it can be
                text += "; a field (question, format, outlines) or calib is too large"
            raise RequestProblem(400, f"the multipart form cannot be parsed ({text})") from None
        files: dict[str, tuple[str, bytes]] = {}
        fields: dict[str, str] = {}
        for key, value in form.multi_items():
            if isinstance(value, UploadFile):
                files[key] = (value.filename or key, await value.read())
            else:
                fields[key] = str(value)
        return files, fields

    async def describe_from(request: Request) -> tuple[Any, dict[str, Any], dict[str, str]]:
        files, fields = await read_form(request)
        if "color" in files or "depth" in files:
            from scenespeak.live.service_rgbd import rgbd_job

            fmt = fields.get("format", "json")
            if fmt not in ("json", "text"):
                raise RequestProblem(400, f"format must be json or text, not {fmt[:20]!r}")

            loop = asyncio.get_running_loop()
            description, result = await loop.run_in_executor(
                pool.pool, rgbd_job, files, fields, pool.db_path, default_intrinsics, lim
            )
            return description, result, fields
        for need in ("left", "right"):
            if need not in files:
                raise RequestProblem(400, f"missing the file field `{need}` (send left and right)")
        fmt = fields.get("format", "json")
        if fmt not in ("json", "text"):
            raise RequestProblem(400, f"format must be json or text, not {fmt[:20]!r}")
        calib_file = files.get("calib")
        if calib_file is not None and len(calib_file[1]) > lim.max_calib:
            raise RequestProblem(413, f"calib: over {lim.max_calib} bytes")
        loop = asyncio.get_running_loop()
        description, result = await loop.run_in_executor(
            pool.pool,
            _describe_job,
            pool,
            files["left"][1],
            files["right"][1],
            calib_file,
            default_calib,
            lim,
            _truthy(fields.get("outlines", "")),
        )
        return description, result, fields

    async def guarded(job: Any) -> Any:
        try:
            return await job
        except RequestProblem as exc:
            return error(exc.status, exc.message)
        except ScenespeakError as exc:
            return error(400, str(exc))
        except (ValueError, MemoryError) as exc:
            return error(400, f"the input cannot be used ({type(exc).__name__}: {exc})")

    @app.get("/api/health")
    async def health() -> Any:
        return {"status": "ok"}

    @app.post("/api/describe")
    async def describe(request: Request) -> Any:
        async def job() -> Any:
            description, result, fields = await describe_from(request)
            if fields.get("format", "json") == "text":
                return PlainTextResponse(description.to_text() + "\n")
            return JSONResponse(result)

        return await guarded(job())

    @app.post("/api/ask")
    async def ask(request: Request) -> Any:
        async def job() -> Any:
            try:
                from scenespeak.spatial.dialogue import ask as ask_scene  # type: ignore[import-not-found,unused-ignore]
            except ImportError:
                raise RequestProblem(501, "questions are not available in this version") from None
            description, _, fields = await describe_from(request)
            question = fields.get("question", "").strip()
            if not question:
                raise RequestProblem(400, "missing the field `question`")
            if len(question) > lim.max_question:
                raise RequestProblem(413, f"the question is over {lim.max_question} characters")
            answer = ask_scene(question, description)
            return JSONResponse(answer.to_dict())

        return await guarded(job())

    @app.get("/")
    async def index() -> Any:
        return FileResponse(STATIC / "index.html", media_type="text/html")

    app.mount("/static", StaticFiles(directory=STATIC), name="static")

    from fastapi.exceptions import RequestValidationError
    from starlette.exceptions import HTTPException as StarletteHTTPException

    @app.exception_handler(StarletteHTTPException)
    async def http_error(_request: Request, exc: StarletteHTTPException) -> Any:
        return error(exc.status_code, str(exc.detail))

    @app.exception_handler(RequestValidationError)
    async def validation_error(_request: Request, exc: RequestValidationError) -> Any:
        return error(400, "the request does not have the expected fields")

    return app


def serve(
    db_path: str | Path,
    *,
    calib: str | Path | None = None,
    host: str = "127.0.0.1",
    port: int = 8765,
    workers: int = 2,
    limits: ServiceLimits | None = None,
    intrinsics: str | Path | None = None,
) -> None:  # pragma: no cover - runs until stopped
    """Run the service with uvicorn until interrupted."""
    import uvicorn

    app = create_app(db_path, calib=calib, workers=workers, limits=limits, intrinsics=intrinsics)
    uvicorn.run(app, host=host, port=port, log_level="warning")
