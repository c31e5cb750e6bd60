"""Helpers of the service tests and benchmark: a real uvicorn server on 127.0.0.1 in a thread,
and the malformed requests every server must answer with a 4xx."""

from __future__ import annotations

import socket
import struct
import threading
import time
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import cv2
import numpy as np


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def running_server(app: Any) -> Iterator[str]:
    """Serve ``app`` with uvicorn on 127.0.0.1 (a free port) in a thread; yield its base URL."""
    import uvicorn

    port = free_port()
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="error"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        if time.monotonic() > deadline or not thread.is_alive():
            raise RuntimeError("the server did not start")
        time.sleep(0.05)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=30)


def without_timings(d: dict[str, Any]) -> dict[str, Any]:
    """A describe JSON without its run-dependent part (``timings_ms``)."""
    return {k: v for k, v in d.items() if k != "timings_ms"}


def _png_header(w: int, h: int) -> bytes:
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (
        b"\x89PNG\r\n\x1a\n"
        + struct.pack(">I", len(ihdr))
        + chunk
        + struct.pack(">I", zlib.crc32(chunk) & 0xFFFFFFFF)
    )


def _jpeg_header(w: int, h: int) -> bytes:
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 11, 8, h, w, 1) + b"\x01\x11\x00"
    return b"\xff\xd8\xff\xe0\x00\x10JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00" + sof


def _raw(headers: dict[str, str], length: str, body: bytes) -> bytes:
    lines = ["POST /api/describe HTTP/1.1", "Host: 127.0.0.1", f"Content-Length: {length}"]
    lines += [f"{k}: {v}" for k, v in headers.items()]
    lines += ["Connection: close", "", ""]
    return "\r\n".join(lines).encode() + body


def _chunked(headers: dict[str, str], n: int, size: int) -> bytes:
    lines = ["POST /api/describe HTTP/1.1", "Host: 127.0.0.1", "Transfer-Encoding: chunked"]
    lines += [f"{k}: {v}" for k, v in headers.items()]
    lines += ["Connection: close", "", ""]
    chunk = f"{size:x}\r\n".encode() + b"y" * size + b"\r\n"
    return "\r\n".join(lines).encode() + chunk * n + b"0\r\n\r\n"


def send(client: Any, base: str, kwargs: dict[str, Any]) -> tuple[int, str]:
    """Send one case of :func:`malformed_requests`; return the status and the body text."""
    if "raw" not in kwargs:
        r = client.request("POST", "/api/describe", **kwargs)
        return r.status_code, r.text
    host, port = base.rsplit("/", 1)[-1].split(":")
    with socket.create_connection((host, int(port)), timeout=60) as s:
        s.sendall(kwargs["raw"])
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    return int(head.split()[1]), body.decode("utf-8", "replace")


def malformed_requests(left: Path, right: Path, calib: Path) -> list[tuple[str, dict[str, Any]]]:
    """Fifty bad requests as keyword arguments of ``httpx.Client.request`` (name, kwargs), for a
    server started without ``--calib`` (one case sends no calibration)."""
    L, R, C = left.read_bytes(), right.read_bytes(), calib.read_bytes()
    h0, w0 = cv2.imread(str(left)).shape[:2]
    wrong_size = (
        f'{{"baseline": 0.12, "hfov_deg": 60, "image_size": [{2 * w0}, {2 * h0}]}}'.encode()
    )
    small = cv2.imencode(".png", np.full((40, 60, 3), 128, np.uint8))[1].tobytes()
    flat = cv2.imencode(".png", np.full((240, 320, 3), 128, np.uint8))[1].tobytes()
    jpeg_l = cv2.imencode(".jpg", cv2.imread(str(left)))[1].tobytes()
    corrupt = L[:64] + bytes(np.random.default_rng(0).integers(0, 255, 4000, dtype=np.uint8))
    images = {
        "text": b"hello, I am not an image",
        "empty": b"",
        "corrupt-png": corrupt,
        "truncated-png": L[: len(L) // 3],
        "png-10000x10000-header": _png_header(10_000, 10_000),
        "jpeg-10000x10000-header": _jpeg_header(10_000, 10_000),
        "png-0x0-header": _png_header(0, 0),
        "gif": b"GIF89a" + b"\x00" * 40,
        "truncated-jpeg": jpeg_l[:200],
        "png-header-only": _png_header(320, 240),
    }
    cases: list[tuple[str, dict[str, Any]]] = []
    for name, data in images.items():
        for side in ("left", "right"):
            files = {"left": ("l.png", L), "right": ("r.png", R), "calib": ("c.json", C)}
            files[side] = (f"{side}.png", data)
            cases.append((f"{side}={name}", {"files": files}))
    ok = {"left": ("l.png", L), "right": ("r.png", R)}
    calibs = {
        "calib-garbage": b"{not json",
        "calib-nan": b'{"baseline": NaN, "hfov_deg": 60, "image_size": [320, 240]}',
        "calib-negative-baseline": b'{"baseline": -1, "hfov_deg": 60, "image_size": [320, 240]}',
        "calib-wrong-size": wrong_size,
        "calib-fov-180": b'{"baseline": 0.12, "hfov_deg": 180, "image_size": [320, 240]}',
        "calib-empty": b"",
        "calib-list": b"[1, 2, 3]",
        "calib-huge": b'{"pad": "' + b"x" * 200_000 + b'"}',
    }
    for name, data in calibs.items():
        cases.append((name, {"files": {**ok, "calib": ("c.json", data)}}))
    boundary = "XyZ0123"
    good_body = (
        f'--{boundary}\r\nContent-Disposition: form-data; name="left"; filename="l.png"\r\n'
        f"Content-Type: image/png\r\n\r\n"
    ).encode() + L
    mp = {"Content-Type": f"multipart/form-data; boundary={boundary}"}
    cases += [
        ("no-body", {}),
        ("json-body", {"json": {"left": "x", "right": "y"}}),
        ("urlencoded", {"data": {"left": "x", "right": "y"}}),
        ("missing-left", {"files": {"right": ("r.png", R), "calib": ("c.json", C)}}),
        ("missing-right", {"files": {"left": ("l.png", L), "calib": ("c.json", C)}}),
        ("missing-both", {"files": {"calib": ("c.json", C)}}),
        ("wrong-field-names", {"files": {"image1": ("l.png", L), "image2": ("r.png", R)}}),
        ("left-as-text-field", {"data": {"left": "x"}, "files": {"right": ("r.png", R)}}),
        ("no-calibration", {"files": ok}),
        ("format-xml", {"files": {**ok, "calib": ("c.json", C)}, "data": {"format": "xml"}}),
        ("sizes-differ", {"files": {"left": ("l.png", L), "right": ("r.png", small),
                                    "calib": ("c.json", C)}}),
        ("textureless", {"files": {"left": ("l.png", flat), "right": ("r.png", flat),
                                   "calib": ("c.json", C)}}),
        ("truncated-multipart", {"content": good_body[: len(good_body) // 2], "headers": mp}),
        ("multipart-no-closing", {"content": good_body, "headers": mp}),
        ("multipart-wrong-boundary", {"content": good_body.replace(boundary.encode(), b"Other"),
                                      "headers": mp}),
        ("multipart-no-boundary", {"content": good_body, "headers": {"Content-Type":
                                                                     "multipart/form-data"}}),
        ("content-length-huge", {"raw": _raw(mp, "999999999999", b"x" * 10)}),
        ("chunked-over-the-limit", {"raw": _chunked(mp, 9, 1024 * 1024)}),
        ("too-many-files", {"files": [("f", (f"{i}.png", small)) for i in range(9)]}),
        ("color-depth", {"files": {"color": ("c.png", L), "depth": ("d.png", R)}}),
        ("ten-thousand-fields", {"files": ok, "data": {f"k{i}": "v" for i in range(13)}}),
        ("format-empty", {"files": {**ok, "calib": ("c.json", C)}, "data": {"format": ""}}),
    ]  # fmt: skip
    assert len(cases) == 50, len(cases)
    return cases
