"""The 3D mirrors (the full and the light viser servers) in their own process, at a lower CPU priority.

Why: in the web server's process the mirrors' threads took about two thirds of its interpreter lock with 20
viewers (viser encodes every scene message once per viewer), and the e-stop message waited behind them: p50 11 ms,
p99 77 ms from the browser to the robot (`humanoid bench load`, py-spy). Here they hold their own lock, and the
operating system serves the web server (and the robot) first.

Data flow: the robot process's state and sensor-feed messages reach this process as they came (still pickled:
the web server does not encode them again); a click in a 3D view comes back as a command the web server submits.
Wire protocol (one duplex pipe, pickles): parent -> child: raw ("state", ...) / ("feed", ...) messages, ("stop",);
child -> parent: ("ready", {profile: port}), ("updates", {profile: n}), ("cmd", Command), ("fatal", text).
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing as mp
import os
import pickle
import threading
import traceback
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

from robot.interface import Command, CommandReply, Level, RobotDescription, RobotState, SensorFeed
from robot.process import WorkerProcess, merge_feed

log = logging.getLogger(__name__)

STARTUP_TIMEOUT_S = 120.0
UPDATES_PERIOD_S = 1.0
MIRROR_NICE = 5  # below the web server and the robot: viewers wait, the e-stop does not


@dataclass
class RemoteMirror:
    """What the web server shows of one mirror: its port and how many updates it has pushed."""

    port: int
    updates: int = 0

    def stop(self) -> None:  # (the process is stopped as a whole)
        pass


class MirrorProcess:
    """Starts the mirrors' process, feeds it the robot's state, and submits the commands its 3D views send."""

    def __init__(self, worker: WorkerProcess, host: str, ports: dict[str, int], rate_hz: float,
                 shadows: bool) -> None:  # fmt: skip
        self._worker = worker
        self._args = (worker.describe(), host, ports, rate_hz, shadows)
        self.mirrors: dict[str, RemoteMirror] = {}
        self._conn: Connection | None = None
        self._process: mp.process.BaseProcess | None = None
        self._send_lock = threading.Lock()
        self._reader: threading.Thread | None = None

    def start(self) -> None:
        context = mp.get_context("spawn")
        parent_conn, child_conn = context.Pipe(duplex=True)
        self._process = context.Process(target=mirror_main, args=(child_conn, *self._args), name="scene-mirrors",
                                        daemon=True)  # fmt: skip
        self._process.start()
        child_conn.close()
        self._conn = parent_conn
        # the state it starts from (later ones come through the tap)
        parent_conn.send_bytes(pickle.dumps(("state", self._worker.state())))
        if not parent_conn.poll(STARTUP_TIMEOUT_S):
            self._process.kill()
            raise RuntimeError(f"the 3D mirrors did not start within {STARTUP_TIMEOUT_S:.0f} s")
        message = parent_conn.recv()
        if message[0] != "ready":
            self._process.join(timeout=5)
            raise RuntimeError(f"the 3D mirrors failed to start:\n{message[1]}")
        self.mirrors = {name: RemoteMirror(port) for name, port in message[1].items()}
        self._worker.add_tap(self._forward)
        self._reader = threading.Thread(target=self._read, name="scene-mirrors-reader", daemon=True)
        self._reader.start()

    def stop(self) -> None:
        if self._process is None:
            return
        with contextlib.suppress(OSError), self._send_lock:
            self._conn.send_bytes(pickle.dumps(("stop",)))  # type: ignore[union-attr]
        self._process.join(timeout=10)
        if self._process.is_alive():
            self._process.kill()
            self._process.join(timeout=5)
        self._process = None

    def _forward(self, raw: bytes) -> None:
        if self._process is None:
            return
        try:
            with self._send_lock:
                self._conn.send_bytes(raw)  # type: ignore[union-attr]
        except OSError:  # the mirrors' process is gone: the robot and the web server go on without it
            pass

    def _read(self) -> None:
        while True:
            try:
                message = self._conn.recv()  # type: ignore[union-attr]
            except (EOFError, OSError):
                if self._process is not None:
                    log.error("the 3D mirrors' process has exited (code %s)", self._process.exitcode)
                return
            if message[0] == "updates":
                for name, count in message[1].items():
                    if name in self.mirrors:
                        self.mirrors[name].updates = count
            elif message[0] == "cmd":  # a click in a 3D view; its outcome shows on the page like any plan's
                threading.Thread(target=self._submit_click, args=(message[1],), daemon=True).start()

    def _submit_click(self, command: Command) -> None:
        """A refused click makes no plan to show, so the refusal is said in the events (the page lists them)."""
        reply = self._worker.submit(command)
        if not reply.accepted:
            self._worker.announce("mirror/click_refused", f"3D view click refused: {reply.message}", Level.WARN,
                                  refusal=reply.refusal.value if reply.refusal else None)  # fmt: skip


class PipedPort:
    """The part of `RobotPort` a mirror reads, fed from the pipe; `submit` sends the command to the web server."""

    def __init__(self, description: RobotDescription, send: Any) -> None:
        self._description = description
        self._send = send
        self._state: RobotState | None = None
        self._feed = SensorFeed()

    def describe(self) -> RobotDescription:
        return self._description

    def state(self) -> RobotState:
        assert self._state is not None
        return self._state

    def sensor_feed(self) -> SensorFeed:
        return self._feed

    def submit(self, command: Command) -> CommandReply:
        self._send(("cmd", command))
        return CommandReply(True, "sent to the robot")

    def take(self, message: tuple) -> None:
        if message[0] == "state":
            self._state = message[1]
        elif message[0] == "feed":
            self._feed = merge_feed(self._feed, message[1])


def mirror_main(conn: Connection, description: RobotDescription, host: str, ports: dict[str, int], rate_hz: float,
                shadows: bool) -> None:  # fmt: skip
    """Entry point of the mirrors' process."""
    send_lock = threading.Lock()

    def send(message: tuple) -> None:
        with send_lock:
            conn.send(message)

    try:
        os.nice(MIRROR_NICE)
        from app.mirror import PROFILES, SceneMirror

        port = PipedPort(description, send)
        port.take(pickle.loads(conn.recv_bytes()))
        mirrors = {name: SceneMirror(port, host, viser_port, rate_hz, profile=PROFILES[name], shadows=shadows)
                   for name, viser_port in ports.items()}  # fmt: skip
        for mirror in mirrors.values():
            mirror.start()
    except Exception:
        send(("fatal", traceback.format_exc()))
        return
    send(("ready", {name: m.port for name, m in mirrors.items()}))
    stop = threading.Event()

    def report() -> None:
        while not stop.wait(UPDATES_PERIOD_S):
            with contextlib.suppress(OSError):
                send(("updates", {name: m.updates for name, m in mirrors.items()}))

    threading.Thread(target=report, daemon=True).start()
    try:
        while True:
            try:
                message = pickle.loads(conn.recv_bytes())
            except (EOFError, OSError):  # the web server is gone
                break
            if message[0] == "stop":
                break
            port.take(message)
    finally:
        stop.set()
        for mirror in mirrors.values():
            mirror.stop()
