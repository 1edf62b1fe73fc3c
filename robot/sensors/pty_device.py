"""A serial device emulated on a pseudo-terminal, for tests and the rig: the driver opens `port_name` as it would
a USB adapter's tty, and a thread on the other end plays the device (`_run`). `unplug()` pulls the cable: the
driver's port fails as a real one does.
"""

from __future__ import annotations

import contextlib
import os
import threading
import tty
from typing import Self

JOIN_TIMEOUT_S = 2.0


class PtyDevice:
    """The pseudo-terminal and the device's thread; a subclass plays the device in `_run` on `self._master`
    until `self._stop` is set. Use it as a context manager."""

    thread_name = "pty-device"

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port_name = os.ttyname(self._slave)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=self.thread_name, daemon=True)

    def __enter__(self) -> Self:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._halt()
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    def unplug(self) -> None:
        """The cable pulled: the host's port fails (its pseudo-terminal's other end is gone)."""
        self._halt()
        with contextlib.suppress(OSError):
            os.close(self._master)

    def _halt(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=JOIN_TIMEOUT_S)

    def _run(self) -> None:
        raise NotImplementedError
