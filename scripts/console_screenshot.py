"""Take the console's screenshot for the README and the docs (docs/img/console.png) from a running server.

Start the server first (`make run`), then:

    .venv/bin/python scripts/console_screenshot.py [--url http://127.0.0.1:8000] [--output docs/img/console.png]

It opens the page in Debian's Chromium (headless, 1400 x 900), sends a command, waits until the plan runs and the
3D view has drawn the robot walking, and saves the page. The 3D view renders in software here (the light view).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

CHROMIUM = "/usr/bin/chromium"
COMMAND = "bring the red mug to the living-room table"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    parser.add_argument("--url", default="http://127.0.0.1:8000")
    parser.add_argument("--output", default="docs/img/console.png")
    parser.add_argument("--width", type=int, default=1400)
    parser.add_argument("--height", type=int, default=900)
    parser.add_argument("--walk-s", type=float, default=12.0, help="seconds of walking before the picture")
    args = parser.parse_args(argv)
    output = Path(args.output)
    output.parent.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=["--use-gl=swiftshader"])
        page = browser.new_page(viewport={"width": args.width, "height": args.height})
        page.goto(args.url)
        page.wait_for_selector("#conn.badge-ok", timeout=60_000)
        page.frame_locator("#scene").locator("canvas").first.wait_for(timeout=60_000)
        page.wait_for_function("document.querySelector('#camera-fps').textContent.includes('fps')", timeout=60_000)
        page.fill("#command-text", COMMAND)
        page.click("#send")
        page.wait_for_function(
            "document.querySelectorAll('#plan-steps li').length > 0 && "
            "document.querySelector('#plan-state').textContent.includes('running')",
            timeout=60_000,
        )
        time.sleep(args.walk_s)  # the robot on its way, the map growing: a picture, not a test
        page.screenshot(path=str(output))
        browser.close()
    print(f"wrote {output} ({output.stat().st_size // 1024} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
