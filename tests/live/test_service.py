"""The scene service over real HTTP on 127.0.0.1: health, describe as the CLI prints it, 50
malformed requests each a one-line 4xx, concurrent requests, the viewer's files."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest
from servehelp import malformed_requests, running_server, send, without_timings

from scenespeak.cli import main
from scenespeak.live.service import ServiceLimits, create_app, image_size_from_header


@pytest.fixture(scope="module")
def server(live_data):
    app = create_app(live_data.db, workers=2, limits=ServiceLimits(max_body=8 * 1024 * 1024))
    with running_server(app) as url:
        yield url


def _cli_json(live_data, k: int, capsys) -> dict:
    left, right = live_data.pair(k)
    args = ["describe", "--db", live_data.db, "--calib", live_data.calib, left, right]
    assert main([str(a) for a in args] + ["--format", "json"]) == 0
    return json.loads(capsys.readouterr().out)


def _files(live_data, k: int) -> dict:
    left, right = live_data.pair(k)
    return {
        "left": ("left.png", left.read_bytes()),
        "right": ("right.png", right.read_bytes()),
        "calib": ("calib.json", live_data.calib.read_bytes()),
    }


def test_health_and_the_page(server) -> None:
    with httpx.Client(base_url=server) as c:
        assert c.get("/api/health").json() == {"status": "ok"}
        page = c.get("/")
        assert page.status_code == 200 and "text/html" in page.headers["content-type"]
        for asset in ("/static/viewer.js", "/static/viewer.css"):
            assert c.get(asset).status_code == 200
        missing = c.get("/nothing/here")
        assert missing.status_code == 404 and set(missing.json()) == {"error"}


def test_describe_is_the_cli_json_and_requests_run_side_by_side(server, live_data, capsys) -> None:
    expected = {k: without_timings(_cli_json(live_data, k, capsys)) for k in (0, 5)}
    jobs = [0, 5] * 6

    def one(k: int) -> tuple[int, dict]:
        with httpx.Client(base_url=server, timeout=120) as c:
            r = c.post("/api/describe", files=_files(live_data, k))
            return r.status_code, r.json()

    with ThreadPoolExecutor(4) as pool:
        results = list(pool.map(one, jobs))
    for k, (status, body) in zip(jobs, results, strict=True):
        assert status == 200, body
        assert without_timings(body) == expected[k]
    assert {o["label"] for o in expected[5]["objects"]} == {"box", "book", "tin"}


def test_text_format_and_outlines(server, live_data) -> None:
    with httpx.Client(base_url=server, timeout=120) as c:
        text = c.post("/api/describe", files=_files(live_data, 5), data={"format": "text"})
        assert text.status_code == 200 and "The " in text.text
        js = c.post("/api/describe", files=_files(live_data, 5), data={"outlines": "true"}).json()
    assert js["image"]["width"] == 320 and js["image"]["height"] == 240
    assert {o["label"] for o in js["image"]["outlines"]} == {o["label"] for o in js["objects"]}


def test_fifty_malformed_requests_are_one_line_4xx(server, live_data) -> None:
    left, right = live_data.pair(5)
    cases = malformed_requests(left, right, live_data.calib)
    seen = {}
    with httpx.Client(base_url=server, timeout=120) as c:
        for name, kwargs in cases:
            status, text = send(c, server, kwargs)
            assert 400 <= status < 500, (name, status, text[:200])
            body = json.loads(text)
            assert set(body) == {"error"}, name
            assert "\n" not in body["error"] and body["error"], name
            seen[name] = (status, body["error"])
        assert c.get("/api/health").json() == {"status": "ok"}
        ok = c.post("/api/describe", files=_files(live_data, 5))
        assert ok.status_code == 200
    assert seen["left=png-10000x10000-header"][0] == 413
    assert "10000x10000" in seen["left=png-10000x10000-header"][1]
    assert seen["content-length-huge"][0] == 413
    assert seen["chunked-over-the-limit"][0] == 413
    assert seen["left=gif"][0] == 415


def test_ask_without_the_dialogue_module_says_so(server, live_data) -> None:
    pytest.importorskip("httpx")
    try:
        import scenespeak.spatial.dialogue  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("questions are available: see the viewer test")
    with httpx.Client(base_url=server, timeout=60) as c:
        r = c.post("/api/ask", files=_files(live_data, 5), data={"question": "where is the tin?"})
    assert r.status_code == 501 and "not available" in r.json()["error"]


def test_header_sizes() -> None:
    from servehelp import _jpeg_header, _png_header

    assert image_size_from_header(_png_header(10_000, 20)) == ("png", 10_000, 20)
    assert image_size_from_header(_jpeg_header(300, 200)) == ("jpeg", 300, 200)
    for bad in (b"", b"GIF89a", b"\xff\xd8\xff\xe0\x00"):
        with pytest.raises(ValueError):
            image_size_from_header(bad)


def test_a_bad_database_fails_at_start(tmp_path) -> None:
    from scenespeak.errors import ScenespeakError

    bad = tmp_path / "x.db"
    bad.write_text("no")
    with pytest.raises(ScenespeakError, match="not"):
        create_app(bad)
