"""The viewer page in a real browser: Playwright driving Debian's chromium (``/usr/bin/chromium``,
installed by ``.ci/run`` when missing; ``SCENESPEAK_CHROMIUM`` points elsewhere)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from servehelp import running_server

from scenespeak.live.service import create_app

CHROMIUM = Path(os.environ.get("SCENESPEAK_CHROMIUM", "/usr/bin/chromium"))


@pytest.fixture(scope="module")
def browser():
    if not CHROMIUM.exists():
        pytest.skip(f"no chromium at {CHROMIUM} (apt-get install chromium)")
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=["--no-sandbox"])
        try:
            yield b
        finally:
            b.close()


def _has_dialogue() -> bool:
    try:
        import scenespeak.spatial.dialogue  # noqa: F401
    except ImportError:
        return False
    return True


def test_upload_a_pair_see_objects_and_sentences_then_ask(browser, live_data) -> None:
    app = create_app(live_data.db, workers=2)
    with running_server(app) as url:
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url + "/")
        assert page.title() == "scenespeak viewer"
        left, right = live_data.pair(5)
        page.set_input_files("#left", str(left))
        page.set_input_files("#right", str(right))
        page.set_input_files("#calib", str(live_data.calib))
        page.click("#describe")
        page.wait_for_selector("body[data-described='yes']", timeout=120_000)
        objects = page.locator("#objects li.object").all_inner_texts()
        sentences = page.locator("#sentences li.sentence").all_inner_texts()
        assert sorted(o.split(" ")[0] for o in objects) == ["book", "box", "tin"]
        assert len(sentences) == 6 and all(s.startswith("The ") for s in sentences)
        assert "3 objects described" in page.inner_text("#status")
        # the outlines were drawn on the image: the canvas has the image's size and colours
        size = page.evaluate(
            "[document.getElementById('image').width, document.getElementById('image').height]"
        )
        assert size == [320, 240]
        page.fill("#question", "where is the tin?")
        page.click("#ask")
        page.wait_for_function(
            "document.getElementById('answer').textContent !== 'Thinking…' && "
            "document.getElementById('answer').textContent !== ''",
            timeout=120_000,
        )
        answer = page.inner_text("#answer")
        if _has_dialogue():
            assert "tin" in answer.lower()
        else:
            assert "not available" in answer
        assert errors == []


def test_a_bad_upload_shows_the_servers_error(browser, live_data, tmp_path) -> None:
    app = create_app(live_data.db, workers=1)
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not an image")
    with running_server(app) as url:
        page = browser.new_page()
        page.goto(url + "/")
        left, _ = live_data.pair(0)
        page.set_input_files("#left", str(left))
        page.set_input_files("#right", str(bad))
        page.set_input_files("#calib", str(live_data.calib))
        page.click("#describe")
        page.wait_for_selector("#status.error", timeout=60_000)
        assert "right: not a PNG or JPEG image" in page.inner_text("#status")
