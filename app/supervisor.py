"""Restarts a robot process that died, or that stopped answering (frozen) for a grace period, safely, while the
web server goes on serving.

What "safely" means here: the death is said (an ERROR event, recorded with the session it ends, and the log); the
session that was being recorded is closed with outcome "crashed", everything it had kept; the new robot process
starts with the e-stop latched, so nothing moves until an operator releases it; and a robot that keeps dying is
left down (health 503, the diagnostics say so) instead of being restarted for ever.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Protocol

from robot.interface import EStop, Event, Level

log = logging.getLogger(__name__)

CHECK_PERIOD_S = 0.2
MAX_RESTARTS = 3  # within RESTART_WINDOW_S; one more death leaves the robot down
RESTART_WINDOW_S = 300.0
FIRST_BACKOFF_S = 0.5  # then doubled for each restart still in the window
# A robot process silent this long is killed and restarted like a dead one. Long enough for a loaded machine's
# hiccups (the page says "not answering" after 0.6 s already), short enough that nobody waits on a frozen robot.
FROZEN_GRACE_S = 5.0


class Restartable(Protocol):
    """What the supervisor needs of the robot port (`robot.process.WorkerProcess` has it)."""

    def is_alive(self) -> bool: ...

    def silent_for_s(self) -> float: ...

    def restart(self, latched: EStop) -> None: ...

    def stop(self) -> None: ...

    def announce(self, kind: str, message: str, level: Level = Level.OK, **data: object) -> Event: ...

    @property
    def exitcode(self) -> int | None: ...


def describe_exit(code: int | None) -> str:
    """'killed by SIGKILL', 'exit code 70', ..., for a person reading the alarm."""
    if code is None:
        return "it stopped answering"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


class WorkerSupervisor:
    """Watches the robot process; when it dies: say so, close the session, restart it with the e-stop latched,
    open a new session. `on_death` and `on_restart` are the server's hooks for its sessions."""

    def __init__(
        self,
        worker: Restartable,
        on_death: Callable[[str], None] = lambda why: None,
        on_restart: Callable[[], None] = lambda: None,
        max_restarts: int = MAX_RESTARTS,
        window_s: float = RESTART_WINDOW_S,
        first_backoff_s: float = FIRST_BACKOFF_S,
        frozen_grace_s: float = FROZEN_GRACE_S,
    ) -> None:
        self._worker = worker
        self._on_death = on_death
        self._on_restart = on_restart
        self.max_restarts = max_restarts
        self._window_s = window_s
        self._first_backoff_s = first_backoff_s
        self.frozen_grace_s = frozen_grace_s
        self._restarts: deque[float] = deque()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.restarts = 0  # since the server started
        self.gave_up: str | None = None  # why the robot is left down, once it is
        self.last_death: str | None = None

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="worker-supervisor", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Before the worker is stopped on purpose (else that would look like a death)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=30)

    def _run(self) -> None:
        while not self._stop.wait(CHECK_PERIOD_S):
            if self.gave_up is not None:
                continue
            if not self._worker.is_alive():
                self._recover(describe_exit(self._worker.exitcode))
            elif (silent := self._worker.silent_for_s()) > self.frozen_grace_s:
                self._recover(f"it stopped answering for {silent:.0f} s", died="stopped answering")

    def _recover(self, why: str, died: str = "died") -> None:
        """Say it, close the session, and restart it (a frozen one is killed first) unless it keeps failing."""
        self.last_death = why
        now = time.monotonic()
        while self._restarts and now - self._restarts[0] > self._window_s:
            self._restarts.popleft()
        giving_up = len(self._restarts) >= self.max_restarts
        then = (
            f"it failed {len(self._restarts) + 1} times within {self._window_s / 60:.0f} min: left down; "
            "restart the server to try again"
            if giving_up
            else "restarting it with the e-stop latched"
        )
        message = f"the robot process {died} ({why}): {then}"
        log.error(message)
        self._worker.announce("worker/died", message, Level.ERROR, cause=why, restarting=not giving_up)
        self._safely(lambda: self._on_death(why))
        if giving_up:
            self.gave_up = message
            if self._worker.is_alive():  # frozen: it must not wake up later and go on with what it was doing
                self._worker.stop()
            return
        backoff = self._first_backoff_s * 2 ** len(self._restarts)
        self._restarts.append(now)
        if self._stop.wait(backoff):
            return
        try:
            self._worker.restart(EStop(source="supervisor", reason=f"the robot process was restarted after it {died}"))
        except Exception as exc:  # it could not even start: counted, and tried again after the next backoff
            log.exception("the robot process could not be restarted")
            self._worker.announce(
                "worker/restart_failed", f"the robot process could not be restarted: {exc}", Level.ERROR
            )
            return
        self.restarts += 1
        self._safely(self._on_restart)
        self._worker.announce(
            "worker/restarted",
            f"robot process restarted after it {died} ({why}); e-stop latched: release it to go on",
            Level.WARN,
            cause=why,
            restarts_in_window=len(self._restarts),
        )

    @staticmethod
    def _safely(hook: Callable[[], None]) -> None:
        try:
            hook()
        except Exception:  # a failing session store must not keep the robot down
            log.exception("supervisor hook failed")
