"""What every page's WebSocket is sent, serialized once for all of them.

Why: each page used to turn the robot's state into JSON itself, 20 times a second, and the diagnostics once a
second. With 20 pages that was 400 state encodings a second on the server's one event loop, which then read an
e-stop message 0.3-1 s late (`humanoid bench load`). Now one task encodes each state once and every page sends
the same text.
"""

from __future__ import annotations

import asyncio
import json
import time
from typing import Any

from app.diagnostics import diagnostics_json, snapshot
from app.runtime import Runtime
from app.web.api.auth import control_json
from app.web.serialize import state_json

DIAGNOSTICS_PERIOD_S = 1.0
IDLE_STOP_S = 5.0  # with no page left for this long the encoding task ends (the next page starts it again)


class BrowserFeed:
    """The latest state, diagnostics and control texts, renewed at `hz` while pages are connected. A page waits
    for a version newer than the one it sent last (`next`)."""

    def __init__(self, rt: Runtime, hz: float) -> None:
        self._rt = rt
        self._period = 1.0 / hz
        self.version = 0
        self.state = ""
        self.diagnostics = ""
        self.diagnostics_version = 0
        self.control = ""
        self.control_version = 0
        self._control_value: Any = None
        self._diagnostics_at = 0.0
        self._pages = 0
        self._changed: asyncio.Condition | None = None
        self._task: asyncio.Task | None = None

    def join(self) -> None:
        """A page connects (from the event loop): the encoding task runs while any page is connected."""
        self._pages += 1
        if self._task is None or self._task.done():
            self._changed = asyncio.Condition()
            self._renew()
            self._task = asyncio.get_running_loop().create_task(self._run())

    def leave(self) -> None:
        self._pages -= 1

    async def next(self, seen: int) -> int:
        """Wait for a version newer than `seen`; returns it."""
        assert self._changed is not None, "join() first"
        async with self._changed:
            await self._changed.wait_for(lambda: self.version > seen)
        return self.version

    async def _run(self) -> None:
        idle_since: float | None = None
        while True:
            await asyncio.sleep(self._period)
            if self._pages <= 0:
                idle_since = idle_since or time.monotonic()
                if time.monotonic() - idle_since > IDLE_STOP_S:
                    return
                continue
            idle_since = None
            self._renew()
            assert self._changed is not None
            async with self._changed:
                self._changed.notify_all()

    def _renew(self) -> None:
        rt = self._rt
        self.state = json.dumps({"type": "state", "state": state_json(rt.worker.state())})
        now = time.monotonic()
        if not self.diagnostics or now - self._diagnostics_at >= DIAGNOSTICS_PERIOD_S:
            self._diagnostics_at = now
            self.diagnostics = json.dumps({"type": "diagnostics", "diagnostics": diagnostics_json(snapshot(rt))})
            self.diagnostics_version += 1
        control = control_json(rt)
        if control != self._control_value:
            self._control_value = control
            self.control = json.dumps({"type": "control", "control": control})
            self.control_version += 1
        self.version += 1
