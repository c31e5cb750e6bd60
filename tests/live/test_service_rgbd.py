"""The scene service's RGB-D requests over real HTTP on 127.0.0.1: colour + depth + masks (or
the database) answered with the CLI's JSON for the same files; bad RGB-D uploads each a
one-line 4xx, and the server still answers after."""

from __future__ import annotations

import io
import json

import cv2
import httpx
import numpy as np
import pytest
from servehelp import running_server, without_timings

from scenespeak.cli import main
from scenespeak.live.service import ServiceLimits, create_app


@pytest.fixture(scope="module")
def server(live_data):
    app = create_app(live_data.db, workers=2, limits=ServiceLimits(max_body=8 * 1024 * 1024))
    with running_server(app) as url:
        yield url


def _paths(live_data, k: int) -> dict:
    d = live_data.sequence / f"{k:04d}"
    return {
        "color": d / "left.png",
        "depth": d / "depth.png",
        "masks": d / "masks.png",
        "labels": d / "labels.json",
        "intrinsics": live_data.sequence / "intrinsics.json",
    }


def _cli(args: list, capsys) -> dict:
    assert main([str(a) for a in args] + ["--format", "json"]) == 0
    return json.loads(capsys.readouterr().out)


def _upload(paths: dict, keys=("color", "depth", "masks", "labels", "intrinsics")) -> dict:
    return {k: (paths[k].name, paths[k].read_bytes()) for k in keys}


def test_rgbd_describe_is_the_cli_json(server, live_data, capsys) -> None:
    p = _paths(live_data, 5)
    cli_masks = _cli(
        ["describe", p["color"], "--depth", p["depth"], "--intrinsics", p["intrinsics"],
         "--masks", p["masks"], "--labels", p["labels"]], capsys,
    )  # fmt: skip
    cli_db = _cli(
        ["describe", p["color"], "--depth", p["depth"], "--intrinsics", p["intrinsics"],
         "--db", live_data.db], capsys,
    )  # fmt: skip
    with httpx.Client(base_url=server, timeout=120) as c:
        masks = c.post("/api/describe", files=_upload(p))
        db = c.post("/api/describe", files=_upload(p, ("color", "depth", "intrinsics")))
        text = c.post("/api/describe", files=_upload(p), data={"format": "text"})
    assert masks.status_code == 200, masks.text
    assert without_timings(masks.json()) == without_timings(cli_masks)
    assert masks.json()["frame"] == "horizontal" and len(masks.json()["objects"]) == 3
    assert db.status_code == 200, db.text
    assert without_timings(db.json()) == without_timings(cli_db)
    assert text.status_code == 200 and text.text.startswith("The ")


def test_rgbd_boxes_and_estimated_up_are_the_cli_json(server, live_data, tmp_path, capsys) -> None:
    p = _paths(live_data, 5)
    inst = cv2.imread(str(p["masks"]), cv2.IMREAD_UNCHANGED)
    labels = json.loads(p["labels"].read_text())
    dets = []
    for key, label in labels.items():
        ys, xs = np.nonzero(inst == int(key))
        x0, y0 = int(xs.min()), int(ys.min())
        dets.append(
            {"bbox": [x0, y0, int(xs.max()) - x0 + 1, int(ys.max()) - y0 + 1], "label": label}
        )
    boxes = tmp_path / "boxes.json"
    boxes.write_text(json.dumps(dets))
    cli = _cli(
        ["describe", p["color"], "--depth", p["depth"], "--intrinsics", p["intrinsics"],
         "--boxes", boxes, "--estimate-up"], capsys,
    )  # fmt: skip
    files = {
        **_upload(p, ("color", "depth", "intrinsics")),
        "boxes": ("b.json", boxes.read_bytes()),
    }
    with httpx.Client(base_url=server, timeout=120) as c:
        r = c.post("/api/describe", files=files, data={"estimate_up": "true"})
    assert r.status_code == 200, r.text
    assert without_timings(r.json()) == without_timings(cli)
    assert r.json()["up_source"] == "estimated" and {o["source"] for o in r.json()["objects"]} == {
        "box"
    }


def test_rgbd_intrinsics_as_ros_camera_info_yaml(server, live_data) -> None:
    p = _paths(live_data, 5)
    cam = json.loads(p["intrinsics"].read_text())
    yaml = (
        f"image_width: {cam['width']}\nimage_height: {cam['height']}\ncamera_name: left\n"
        "camera_matrix:\n  rows: 3\n  cols: 3\n"
        f"  data: [{cam['fx']}, 0, {cam['cx']}, 0, {cam['fy']}, {cam['cy']}, 0, 0, 1]\n"
        "distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n"
        "  data: [0, 0, 0, 0, 0]\n"
    )
    with httpx.Client(base_url=server, timeout=120) as c:
        r = c.post("/api/describe", files={**_upload(p), "intrinsics": ("cam.yaml", yaml.encode())})
    assert r.status_code == 200, r.text
    # no up in camera_info: estimated from the floor, the objects as with the JSON intrinsics
    assert r.json()["up_source"] == "estimated"
    assert {o["name"] for o in r.json()["objects"]} == {"box", "book", "tin"}


def test_rgbd_npy_depth_in_metres(server, live_data) -> None:
    p = _paths(live_data, 5)
    mm = cv2.imread(str(p["depth"]), cv2.IMREAD_UNCHANGED)
    metres = np.where(mm > 0, mm.astype(np.float32) * np.float32(0.001), np.nan).astype(np.float32)
    with httpx.Client(base_url=server, timeout=120) as c:
        png = c.post("/api/describe", files=_upload(p)).json()
        npy = c.post("/api/describe", files={**_upload(p), "depth": ("d.npy", _npy(metres))})
    assert npy.status_code == 200, npy.text
    a, b = png["objects"], npy.json()["objects"]
    assert [(o["name"], o["kept_pixels"]) for o in a] == [(o["name"], o["kept_pixels"]) for o in b]
    assert np.allclose([o["centroid"] for o in a], [o["centroid"] for o in b], atol=1e-6)


def test_rgbd_ask_is_the_cli_answer(server, live_data, capsys) -> None:
    p = _paths(live_data, 5)
    question = "where is the tin?"
    cli = _cli(
        ["ask", question, p["color"], "--depth", p["depth"], "--intrinsics", p["intrinsics"],
         "--masks", p["masks"], "--labels", p["labels"]], capsys,
    )  # fmt: skip
    with httpx.Client(base_url=server, timeout=120) as c:
        r = c.post("/api/ask", files=_upload(p), data={"question": question})
    assert r.status_code == 200, r.text
    assert r.json() == cli and r.json()["answer"].startswith("The tin is")


def _png(a: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", a)
    assert ok
    return buf.tobytes()


def _npy(a: np.ndarray) -> bytes:
    f = io.BytesIO()
    np.save(f, a)
    return f.getvalue()


def test_bad_rgbd_uploads_are_one_line_4xx(server, live_data) -> None:
    p = _paths(live_data, 5)
    good = _upload(p)
    cases = {
        "no depth": {k: v for k, v in good.items() if k != "depth"},
        "no color": {k: v for k, v in good.items() if k != "color"},
        "no intrinsics": {k: v for k, v in good.items() if k != "intrinsics"},
        "depth of another size": {**good, "depth": ("d.png", _png(np.ones((10, 12), np.uint16)))},
        "8-bit depth": {**good, "depth": ("d.png", _png(np.ones((240, 320), np.uint8)))},
        "colour image as depth": {**good, "depth": ("d.png", good["color"][1])},
        "corrupt depth": {**good, "depth": ("d.png", good["depth"][1][:200])},
        "depth not an image": {**good, "depth": ("d.txt", b"hello")},
        "npy depth of 3 dims": {**good, "depth": ("d.npy", _npy(np.ones((4, 4, 3))))},
        "npy header 10000x10000": {
            **good,
            "depth": (
                "d.npy",
                _npy(np.ones((2, 2), np.float32))[:128].replace(b"(2, 2)", b"(10000, 10000)"),
            ),
        },
        "masks of another size": {**good, "masks": ("m.png", _png(np.ones((10, 12), np.uint8)))},
        "empty masks": {**good, "masks": ("m.png", _png(np.zeros((240, 320), np.uint8)))},
        "labels naming absent instances": {**good, "labels": ("l.json", b'{"9": "mug"}')},
        "labels not JSON": {**good, "labels": ("l.json", b"{nope")},
        "intrinsics of another size": {
            **good,
            "intrinsics": (
                "i.json",
                b'{"fx": 300, "fy": 300, "cx": 10, "cy": 10, "width": 20, "height": 20}',
            ),
        },
        "intrinsics garbage": {**good, "intrinsics": ("i.json", b"\x00\x01")},
        "masks and boxes": {**good, "boxes": ("b.json", b'[{"bbox": [1, 1, 5, 5], "label": "x"}]')},
        "boxes outside": {
            **{k: v for k, v in good.items() if k not in ("masks", "labels")},
            "boxes": ("b.json", b'[{"bbox": [900, 900, 5, 5], "label": "x"}]'),
        },
        "color with left": {**good, "left": good["color"]},
        "empty color": {**good, "color": ("c.png", b"")},
    }
    with httpx.Client(base_url=server, timeout=120) as c:
        for name, files in cases.items():
            r = c.post("/api/describe", files=files)
            assert 400 <= r.status_code < 500, (name, r.status_code, r.text[:300])
            body = r.json()
            assert set(body) == {"error"} and body["error"] and "\n" not in body["error"], name
            assert "/tmp/" not in body["error"] and "scenespeak-serve" not in body["error"], (
                name,
                body["error"],
            )
        huge = c.post("/api/describe", files=cases["npy header 10000x10000"])
        assert huge.status_code == 413 and "10000x10000" in huge.json()["error"], huge.text
        bad = c.post("/api/describe", files=cases["depth of another size"]).json()["error"]
        assert bad.startswith("depth") and "10" in bad, bad
        r = c.post("/api/describe", files=good, data={"depth_scale": "abc"})
        assert r.status_code == 400 and "depth_scale" in r.json()["error"]
        assert c.get("/api/health").json() == {"status": "ok"}
        assert c.post("/api/describe", files=good).status_code == 200
