"""Headless Debian Chromium through Playwright (never `playwright install`), and helpers to watch the page."""

from __future__ import annotations

import shutil
import time
from typing import Any

import cv2
import numpy as np

CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-unsafe-swiftshader",  # software WebGL for the 3D view
]


def chromium_path() -> str:
    path = shutil.which("chromium") or "/usr/bin/chromium"
    return path


def launch_chromium(playwright: Any, microphone_wav: str | None = None) -> Any:
    """Debian's Chromium, headless; with `microphone_wav`, a fake microphone that plays that file (in a loop)."""
    args = list(CHROMIUM_ARGS)
    if microphone_wav is not None:
        args += [
            "--use-fake-ui-for-media-stream",
            "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-audio-capture={microphone_wav}",
        ]
    return playwright.chromium.launch(executable_path=chromium_path(), args=args, headless=True)


def wait_for_scene_render(page: Any, timeout_s: float = 90.0) -> float:
    """Wait until the 3D mirror's canvas shows a picture (not a blank colour); returns the pixel std."""
    canvas = page.frame_locator("#scene").locator("canvas").first
    canvas.wait_for(state="visible", timeout=timeout_s * 1000)
    deadline = time.monotonic() + timeout_s
    spread = 0.0
    while time.monotonic() < deadline:
        image = cv2.imdecode(np.frombuffer(canvas.screenshot(), np.uint8), cv2.IMREAD_GRAYSCALE)
        spread = float(image.std())
        if spread > 8.0:
            return spread
        time.sleep(1.0)
    raise TimeoutError(f"the 3D canvas stayed blank (pixel std {spread:.1f})")
