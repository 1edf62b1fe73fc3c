"""The e-stop benches' set-up and presses, shared by `humanoid bench core` and the scripts that explain its
figures (`scripts/estop_wire.py`, `scripts/estop_trace.py`): the same pages and pace, so their figures compare."""

from __future__ import annotations

import random
import time
from typing import Any

from harness.browser import wait_for_scene_render
from harness.server import ServerProcess

VIEWPORT = {"width": 1400, "height": 900}


def open_watching_pages(browser: Any, url: str, count: int = 2) -> list[Any]:
    """`count` pages of the console, each with its 3D view drawn; the first is the operator's."""
    pages = []
    for _ in range(max(1, count)):
        page = browser.new_page(viewport=VIEWPORT)
        page.goto(url)
        wait_for_scene_render(page)
        pages.append(page)
    return pages


def press_and_release(page: Any, server: ServerProcess, index: int) -> None:
    """Press number `index` (from 0) of the page's E-STOP button, a real click; wait until the page has its latency,
    release it through the API, wait until the page shows it released, then pause as a person would (and not in
    step with the control ticks)."""
    page.click("#estop")
    page.wait_for_function(f"window.humanoid.estopLatencies.length > {index}", polling=5, timeout=10_000)
    response = server.post("/api/estop/reset")
    if response.status_code != 200:
        raise RuntimeError(f"release failed: {response.text}")
    page.wait_for_function("window.humanoid.state && !window.humanoid.state.estop_latched", polling=5, timeout=10_000)
    time.sleep(random.uniform(0.1, 0.4))
