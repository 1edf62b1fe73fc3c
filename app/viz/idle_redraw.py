"""How often a 3D view redraws a scene that has not changed.

viser's client redraws on demand: each update from its server asks for frames, and besides that a timer redraws
every second (`RENDER_HEARTBEAT_MS` in its App.tsx, "a low-rate safety net for imperative changes that never request
a frame"). Where WebGL runs in software (no GPU: the robot's own computer, headless browsers) one frame of the light
view costs ~100 ms of CPU on two threads, so two idle views took a quarter of a core in bursts, and the e-stop's
press waited behind them on a 2-core robot (docs/design/faults-and-load.md). The gate in front of each view adds
a small script to viser's page that stretches that one timer; every update still draws at once.

The script recognises the timer by its shape (a 1 s interval whose callback is `() => f()`): no other interval of
viser's client has it. If a viser release changes it, nothing breaks: the view redraws every second again, and
`window.__humanoidIdleRedraw.stretched` stays 0 (a browser test checks it is 1).
"""

from __future__ import annotations

IDLE_REDRAW_S = 10.0
PAGE_PATHS = ("/", "/index.html")

_SCRIPT = """<script>(() => {
  const state = { stretched: 0, everyMs: %d };
  window.__humanoidIdleRedraw = state;
  const setIntervalOfPage = window.setInterval;
  window.setInterval = function (callback, delay, ...rest) {
    if (delay === 1000 && typeof callback === "function" && /^\\(\\)\\s*=>\\s*[\\w$]+\\(\\)$/.test(String(callback))) {
      state.stretched += 1;
      delay = state.everyMs;
    }
    return setIntervalOfPage.call(window, callback, delay, ...rest);
  };
})();</script>"""


def idle_redraw_script(every_s: float = IDLE_REDRAW_S) -> bytes:
    """The script that makes viser's client redraw an unchanged scene every `every_s` seconds."""
    if not every_s >= 1.0:
        raise ValueError(f"an idle redraw every {every_s} s: at least 1 s")
    return (_SCRIPT % round(every_s * 1000)).encode()


def is_page(target: str) -> bool:
    """True for the address of viser's page (its client), which the script goes into."""
    return target.partition("?")[0] in PAGE_PATHS


def add_script(html: bytes, script: bytes) -> bytes:
    """`html` with `script` first in its head, so that it runs before the client's own code."""
    at = html.find(b"<head>")
    if at < 0:
        return script + html
    at += len(b"<head>")
    return html[:at] + script + html[at:]


def with_body(head: bytes, body: bytes) -> bytes:
    """An HTTP response head (ending in a blank line) with its Content-Length set to `body`'s."""
    lines = head.decode("latin-1").split("\r\n")
    kept = [line for line in lines[:-2] if not line.lower().startswith("content-length:")]
    kept.append(f"Content-Length: {len(body)}")
    return ("\r\n".join(kept) + "\r\n\r\n").encode("latin-1")


def content_length(head: bytes) -> int | None:
    """The Content-Length of a response head, or None when it has none (or an unreadable one)."""
    for line in head.decode("latin-1").split("\r\n")[1:]:
        name, _, value = line.partition(":")
        if name.strip().lower() == "content-length":
            try:
                return int(value.strip())
            except ValueError:
                return None
    return None


def is_plain_ok(head: bytes) -> bool:
    """A 200 whose body is sent as is (not compressed): the only kind of page the script can go into."""
    lines = head.decode("latin-1").split("\r\n")
    if len(lines[0].split(" ")) < 2 or lines[0].split(" ")[1] != "200":
        return False
    for line in lines[1:]:
        name, _, value = line.partition(":")
        if name.strip().lower() == "content-encoding" and value.strip().lower() not in ("", "identity"):
            return False
    return True
