"""The viewer's screenshot for the README (``docs/img/viewer.png``), taken in a real browser.

Renders a sequence frame and a database with the generator (or reuses them in ``--cache``),
starts the service on 127.0.0.1, and drives Debian's chromium with Playwright: upload the pair,
wait for the outlines and sentences, ask a question when the service can answer it, and save
a full-page PNG.

Run::

    python -m scenespeak.tools.viewer_screenshot --out docs/img/viewer.png
"""

from __future__ import annotations

import argparse
import tempfile
import threading
import time
from pathlib import Path

__all__ = ["main"]


def _data(cache: Path) -> tuple[Path, Path, Path, Path]:
    from scenespeak.pipeline import database_from_dataset
    from scenespeak.tools.sequences import generate_sequence_set, sequence_database

    (seq,) = generate_sequence_set(cache / "seq", [100], scripts=("appear",), n_frames=24)
    db = cache / "objects.db"
    if not db.exists():
        sequence_database(cache / "train")
        database_from_dataset(cache / "train", db)
    left, right = seq.pair(len(seq.frames) - 1)
    return left, right, seq.calib, db


def main(argv: list[str] | None = None) -> int:
    """Take the screenshot; return 0."""
    import uvicorn
    from playwright.sync_api import sync_playwright

    from scenespeak.live.service import create_app

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("docs/img/viewer.png"))
    ap.add_argument(
        "--cache", type=Path, default=Path(tempfile.gettempdir()) / "scenespeak-live-bench"
    )
    ap.add_argument("--chromium", default="/usr/bin/chromium")
    ap.add_argument("--question", default="where is the can?")
    args = ap.parse_args(argv)
    left, right, calib, db = _data(args.cache)
    app = create_app(db, workers=1)
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=0, log_level="error"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.05)
    port = server.servers[0].sockets[0].getsockname()[1]
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=args.chromium, args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(f"http://127.0.0.1:{port}/")
            page.set_input_files("#left", str(left))
            page.set_input_files("#right", str(right))
            page.set_input_files("#calib", str(calib))
            page.click("#describe")
            page.wait_for_selector("body[data-described='yes']", timeout=300_000)
            page.fill("#question", args.question)
            page.click("#ask")
            page.wait_for_function(
                "!['', 'Thinking…'].includes(document.getElementById('answer').textContent)",
                timeout=300_000,
            )
            args.out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(args.out), full_page=True)
            browser.close()
    finally:
        server.should_exit = True
        thread.join(timeout=30)
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
