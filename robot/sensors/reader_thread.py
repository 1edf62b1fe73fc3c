"""The shell every real sensor driver shares: a thread that opens its source, reads from it until it fails, says
what went wrong and reopens it every second, and keeps the newest reading for the control tick to take.

A driver says how to open, read and close its source (`_open`, `_serve`, `_close`) and hands each reading to
`_publish`; `latest()` and `problem()` are the same for every sensor, so the diagnostics read them all alike.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Generic, TypeVar

log = logging.getLogger(__name__)

REOPEN_AFTER_S = 1.0
JOIN_TIMEOUT_S = 3.0

Reading = TypeVar("Reading")
Source = TypeVar("Source")


class SourceFailed(Exception):
    """Raised by a driver's `_serve` when its source stopped working in a way it can name."""


class ReaderThread(Generic[Reading, Source]):
    """`name`: how logs and the diagnostics call the sensor; `silent_after_s`: a source that gave a reading before
    and none for this long is said to be silent (None: never said); `source_errors`: the exceptions that mean the
    source failed (reopened, not a crash)."""

    name = "sensor"
    thread_name = "sensor"
    silent_after_s: float | None = None
    source_errors: tuple[type[BaseException], ...] = (OSError, SourceFailed)

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._latest: Reading | None = None
        self._last_heard_s: float | None = None
        self._problem = "not started"
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=self.thread_name, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=JOIN_TIMEOUT_S)
            self._thread = None

    @property
    def stopping(self) -> bool:
        return self._stop.is_set()

    def latest(self) -> Reading | None:
        with self._lock:
            return self._latest

    def problem(self) -> str:
        """Why there is no fresh reading now ("" while they come)."""
        with self._lock:
            if self._problem:
                return self._problem
            if self.silent_after_s is not None and self._last_heard_s is not None:
                silent = time.monotonic() - self._last_heard_s
                if silent > self.silent_after_s:
                    return self._silence(silent)
            return ""

    def _silence(self, silent_s: float) -> str:
        return f"stalled: nothing new for {silent_s:.1f} s"

    def _say(self, problem: str) -> None:
        with self._lock:
            if problem and problem != self._problem:
                log.error("%s: %s", self.name, problem)
            self._problem = problem

    def _heard(self) -> None:
        """The source said something (a packet, a frame): it is not silent, whether or not a reading is complete."""
        with self._lock:
            self._last_heard_s = time.monotonic()
            self._problem = ""

    def _publish(self, reading: Reading) -> None:
        with self._lock:
            self._latest = reading
            self._last_heard_s = time.monotonic()
            self._problem = ""

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                source = self._open()
            except Exception as exc:  # a vendor SDK's own errors, too
                where = f" {self._source_label()}" if self._source_label() else ""
                self._say(f"cannot open{where}: {exc}")
                self._stop.wait(REOPEN_AFTER_S)
                continue
            self._say("")
            try:
                self._serve(source)
            except self.source_errors as exc:
                self._say(f"{self._source_label() or 'source'} failed: {exc}")
            finally:
                self._close(source)
            if not self._stop.is_set():
                self._stop.wait(REOPEN_AFTER_S)

    def _source_label(self) -> str:
        return ""

    def _open(self) -> Source:
        raise NotImplementedError

    def _serve(self, source: Source) -> None:
        """Read from the source until it fails (raise one of `source_errors`) or the reader is stopped."""
        raise NotImplementedError

    def _close(self, source: Source) -> None:
        raise NotImplementedError
