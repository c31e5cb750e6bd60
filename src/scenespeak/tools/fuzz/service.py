"""Corpus family: bad requests to ``scenespeak serve`` (the FastAPI app, through its TestClient).

Each case builds the app on the corpus database (in the case's own process), sends one bad
request and turns the answer into the corpus' terms: a 4xx with a one-line JSON ``error`` is a
refusal (:class:`~scenespeak.errors.InputError`, so it must name what was wrong: the field or
the file); a 5xx, or an answer that is not JSON, is a traceback (the server failed); a 200 for
a bad request is silently wrong. Uploads: corrupt, truncated and empty images, PNG/JPEG headers
that claim 10,000 x 10,000 or 50,000 x 50,000 pixels, a body over the limit, a truncated or
malformed multipart body, missing and unknown fields, too many files, a hostile calibration
(billion laughs, deep JSON, python tags), RGB-D uploads of the wrong size, and questions of
1 MB or with control characters.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from typing import Any

import numpy as np

from scenespeak.tools.fuzz.corpus import Base, Case, Expect, H, W, Writer, card_pair, png_bytes

__all__ = ["BUILDERS"]

_BOUNDARY = "fuzzboundary42"


def _answer(resp: Any) -> object:
    """A refusal as InputError; a server failure as RuntimeError; a success returned."""
    from scenespeak.errors import InputError

    status = int(resp.status_code)
    try:
        body = resp.json()
    except ValueError:
        body = None
    if status >= 500 or (status >= 400 and not (isinstance(body, dict) and "error" in body)):
        raise RuntimeError(f"HTTP {status}: {resp.text[:300]!r}")
    if status >= 400:
        message = str(body["error"])
        if "\n" in message:
            raise RuntimeError(f"HTTP {status}: a multi-line error {message[:200]!r}")
        raise InputError(f"HTTP {status}", message)
    if "\x1b" in resp.text:
        from scenespeak.tools.fuzz.apicases import WrongAnswer

        raise WrongAnswer("the answer carries a raw escape sequence")
    return f"HTTP {status}"


def _request(
    base: Base,
    path: str,
    kwargs: Callable[[], dict[str, Any]],
    *,
    max_body: int | None = None,
) -> Callable[[], object]:
    def run() -> object:
        from fastapi.testclient import TestClient

        from scenespeak.live.service import ServiceLimits, create_app

        limits = ServiceLimits() if max_body is None else ServiceLimits(max_body=max_body)
        app = create_app(base.db, calib=base.calib, workers=1, limits=limits)
        with TestClient(app, raise_server_exceptions=False) as client:
            return _answer(client.post(path, **kwargs()))

    return run


def _pair_files(**override: tuple[str, bytes] | None) -> dict[str, tuple[str, bytes]]:
    left, right = card_pair()
    files: dict[str, tuple[str, bytes] | None] = {
        "left": ("left.png", png_bytes(left)),
        "right": ("right.png", png_bytes(right)),
    }
    files.update(override)
    return {k: v for k, v in files.items() if v is not None}


def _multipart(parts: list[tuple[str, str | None, bytes]]) -> bytes:
    out = b""
    for name, filename, data in parts:
        disp = f'form-data; name="{name}"' + (f'; filename="{filename}"' if filename else "")
        out += f"--{_BOUNDARY}\r\nContent-Disposition: {disp}\r\n\r\n".encode() + data + b"\r\n"
    return out + f"--{_BOUNDARY}--\r\n".encode()


def _raw(body: Callable[[], bytes], ctype: str | None = None) -> Callable[[], dict[str, Any]]:
    def kwargs() -> dict[str, Any]:
        headers = {"content-type": ctype or f"multipart/form-data; boundary={_BOUNDARY}"}
        return {"content": body(), "headers": headers}

    return kwargs


def _upload(
    files: Callable[[], dict[str, tuple[str, bytes]]], data: dict[str, str] | None = None
) -> Callable[[], dict[str, Any]]:
    return lambda: {"files": files(), "data": data or {}}


def _image_uploads() -> dict[str, tuple[Callable[[], bytes], str]]:
    """Bad bytes for one image field, and what the refusal must name."""
    from scenespeak.tools.fuzz.images import png_header_only

    pair = functools.cache(card_pair)
    rng = np.random.default_rng(12)
    return {
        "empty": (lambda: b"", "right"),
        "text": (lambda: b"this is not an image\n" * 10, "right"),
        "random": (lambda: rng.bytes(5000), "right"),
        "truncated-png": (lambda: png_bytes(pair()[1])[:600], "right"),
        "corrupt-png": (lambda: png_bytes(pair()[1])[:200] + rng.bytes(3000), "right"),
        "claims-10000": (lambda: png_header_only(10_000, 10_000), "right"),
        "claims-50000": (lambda: png_header_only(50_000, 50_000), "right"),
        "claims-2G": (lambda: png_header_only(2**31 - 1, 2**31 - 1), "right"),
        "jpeg-claims-65000": (_jpeg_claims, "right"),
        "other-size": (lambda: png_bytes(np.zeros((480, 640, 3), np.uint8)), "right"),
        "one-pixel": (lambda: png_bytes(np.zeros((1, 1), np.uint8)), "right"),
        "tiff": (lambda: png_bytes(pair()[1], ".tiff"), "right"),
        "gif-magic": (lambda: b"GIF89a" + b"\x00" * 100, "right"),
    }


def _jpeg_claims() -> bytes:
    from scenespeak.tools.fuzz.images import _jpeg_huge

    return _jpeg_huge()


def _calib_uploads() -> dict[str, bytes]:
    from scenespeak.tools.fuzz.calibrations import _billion_laughs

    ok = {"baseline": 0.12, "hfov_deg": 60.0, "image_size": [W, H]}
    return {
        "billion-laughs.yml": _billion_laughs().encode(),
        "deep.json": b"[" * 50_000 + b"]" * 50_000,
        "python-tag.yml": b"baseline: !!python/object/apply:os.system ['true']\n",
        "mm.json": json.dumps({**ok, "baseline": 120}).encode(),
        "garbage.json": b"{baseline: ",
        "nan.json": json.dumps(ok).replace("0.12", "NaN").encode(),
        "huge.json": b'{"baseline": 0.12, "pad": "' + b"x" * 200_000 + b'"}',
        "xml-entities.xml": b'<?xml version="1.0"?><!DOCTYPE a [<!ENTITY x "y">]><a>&x;</a>',
    }


def serve(w: Writer, base: Base) -> None:
    """Bad requests to /api/describe and /api/ask."""
    add = w.add
    for name, (data, names) in _image_uploads().items():

        def make(data: Callable[[], bytes] = data) -> dict[str, tuple[str, bytes]]:
            return _pair_files(right=("right.png", data()))

        add(
            Case(
                f"serve/describe-right-{name}",
                "serve",
                api=_request(base, "/api/describe", _upload(make)),
                names=names,
            )
        )
    for name, calib in _calib_uploads().items():

        def with_calib(calib: bytes = calib, name: str = name) -> dict[str, tuple[str, bytes]]:
            return {**_pair_files(), "calib": (name, calib)}

        add(
            Case(
                f"serve/describe-calib-{name}",
                "serve",
                api=_request(base, "/api/describe", _upload(with_calib)),
                names="calib",
            )
        )
    _form_cases(w, base)
    _ask_cases(w, base)
    _rgbd_cases(w, base)


def _form_cases(w: Writer, base: Base) -> None:
    describe = "/api/describe"
    pair = functools.cache(_pair_files)

    def left_only() -> dict[str, tuple[str, bytes]]:
        return {"left": pair()["left"]}

    def seven_files() -> dict[str, tuple[str, bytes]]:
        files = dict(pair())
        for k in range(5):
            files[f"extra{k}"] = ("x.png", pair()["left"][1])
        return files

    def truncated() -> bytes:
        p = pair()
        return _multipart(
            [("left", "left.png", p["left"][1]), ("right", "right.png", p["right"][1])]
        )[:-5000]

    def no_end() -> bytes:
        return _multipart([("left", "left.png", pair()["left"][1])]).rsplit(
            b"--" + _BOUNDARY.encode(), 1
        )[0]

    cases: dict[str, tuple[Callable[[], dict[str, Any]], str | None, int | None, Expect]] = {
        "missing-right": (_upload(left_only), "right", None, "error"),
        "no-files": (_upload(dict, {"format": "json"}), "left", None, "error"),
        "too-many-files": (_upload(seven_files), None, None, "error"),
        "format-xml": (_upload(pair, {"format": "xml"}), "format", None, "error"),
        "format-escape": (_upload(pair, {"format": "\x1b[2J"}), "format", None, "error"),
        "outlines-junk": (_upload(pair, {"outlines": "\x00" * 10}), None, None, "either"),
        "json-body": (_raw(lambda: b'{"left": 1}', "application/json"), "multipart", None, "error"),
        "no-content-type": (lambda: {"content": b"abc"}, "multipart", None, "error"),
        "boundary-missing": (_raw(truncated, "multipart/form-data"), None, None, "error"),
        "truncated-multipart": (_raw(truncated), None, None, "error"),
        "multipart-no-end": (_raw(no_end), None, None, "error"),
        "multipart-garbage": (_raw(lambda: b"\x00\xff" * 5000), None, None, "error"),
        "header-flood": (
            _raw(lambda: (b"X-A: " + b"a" * 100 + b"\r\n") * 2000 + b"\r\n"),
            None,
            None,
            "error",
        ),
        "body-over-limit": (_upload(pair), "bytes", 64 * 1024, "error"),
        "content-length-lies": (
            lambda: {"content": b"x" * 10, "headers": {"content-length": "99999999999999"}},
            "bytes",
            None,
            "error",
        ),
        "content-length-text": (
            lambda: {"content": b"x", "headers": {"content-length": "abc"}},
            "Content-Length",
            None,
            "error",
        ),
    }
    for name, (kwargs, names, max_body, expect) in cases.items():
        w.add(
            Case(
                f"serve/describe-{name}",
                "serve",
                api=_request(base, describe, kwargs, max_body=max_body),
                names=names,
                expect=expect,
            )
        )


def _ask_cases(w: Writer, base: Base) -> None:
    pair = functools.cache(_pair_files)
    questions: dict[str, tuple[str | None, Expect, str | None]] = {
        "missing": (None, "error", "question"),
        "empty": ("", "error", "question"),
        "one-megabyte": ("where is the coffee? " * 50_000, "error", "question"),
        "control-chars": ("where is the \x1b[31mcoffee\x1b[0m?", "either", None),
        "nul": ("where\x00 is the coffee?", "either", None),
        "bidi": ("where is the \u202ecoffee?", "either", None),
    }
    for name, (q, expect, names) in questions.items():
        data = {} if q is None else {"question": q}
        w.add(
            Case(
                f"serve/ask-question-{name}",
                "serve",
                api=_request(base, "/api/ask", _upload(pair, data)),
                names=names,
                expect=expect,
            )
        )


def _rgbd_cases(w: Writer, base: Base) -> None:
    from scenespeak.tools.fuzz.streams import _intrinsics, rgbd_arrays

    arrays = functools.cache(rgbd_arrays)

    def files(**override: bytes) -> Callable[[], dict[str, tuple[str, bytes]]]:
        def make() -> dict[str, tuple[str, bytes]]:
            color, depth, masks = arrays()
            out = {
                "color": png_bytes(color),
                "depth": png_bytes(depth),
                "masks": png_bytes(masks),
                "intrinsics": json.dumps(_intrinsics()).encode(),
            }
            out.update(override)
            return {k: (f"{k}.{'json' if k == 'intrinsics' else 'png'}", v) for k, v in out.items()}

        return make

    cases: dict[str, tuple[dict[str, bytes], str]] = {
        "depth-other-size": ({"depth": png_bytes(np.full((480, 640), 1000, np.uint16))}, "depth"),
        "depth-text": ({"depth": b"not a depth image"}, "depth"),
        "masks-other-size": ({"masks": png_bytes(np.ones((100, 100), np.uint8))}, "masks"),
        "intrinsics-deep": (
            {"intrinsics": b'{"fx": ' + b"[" * 50_000 + b"]" * 50_000 + b"}"},
            "intrinsics",
        ),
        "intrinsics-fx-1e300": (
            {"intrinsics": json.dumps(_intrinsics(fx=1e300)).encode()},
            "intrinsics",
        ),
        "intrinsics-other-size": (
            {"intrinsics": json.dumps(_intrinsics(width=640, height=480)).encode()},
            "intrinsics",
        ),
    }
    for name, (override, names) in cases.items():
        w.add(
            Case(
                f"serve/rgbd-{name}",
                "serve",
                api=_request(base, "/api/describe", _upload(files(**override))),
                names=names,
            )
        )


BUILDERS = (serve,)
