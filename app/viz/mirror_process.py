"""The 3D mirrors (the full and the light viser servers) in their own process, at a lower CPU priority.

Why: in the web server's process the mirrors' threads took about two thirds of its interpreter lock with 20
viewers (viser encodes every scene message once per viewer), and the e-stop message waited behind them: p50 11 ms,
p99 77 ms from the browser to the robot (`humanoid bench load`, py-spy). Here they hold their own lock, and the
operating system serves the web server (and the robot) first.

Data flow: the robot process's state and sensor-feed messages reach this process as they came (still pickled:
the web server does not encode them again). The views' gates (`app.viz.scene_gate`) run here too, so the pages' 3D
traffic never touches the web server; a click in a 3D view goes back with who made it, for the web server to
check and turn into a command.
Wire protocol (one duplex pipe): parent -> child: a tag byte, then a pickle: `STATE` + the raw ("state", ...)
message, `FEED` + the raw ("feed", ...) message, `CONTROL` + ("revoke", login) or ("stop",); child -> parent
(pickles): ("ready", {profile: port}), ("updates", {profile: n}), ("click", SceneGrant, origin, direction),
("fatal", text).

A state is decoded only when a mirror draws it: states come at the robot's rate, a mirror draws at its own rate and
only while someone watches its view: drawing and decoding every one cost this process ~6 % of a core with no
viewer, now ~1 % (`scripts/idle_cpu.py`).
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

from app.auth.scene_tokens import SceneTokens
from app.viz.scene_gate import ClickHandler
from app.web.tls import TlsFiles
from robot.interface import RobotDescription, RobotState, SensorFeed
from robot.process import WorkerProcess, merge_feed

log = logging.getLogger(__name__)

STARTUP_TIMEOUT_S = 120.0
UPDATES_PERIOD_S = 1.0
MIRROR_NICE = 5  # below the web server and the robot: viewers wait, the e-stop does not
STATE, FEED, CONTROL = b"s", b"f", b"c"  # what follows a message's tag byte
_TAGS = {"state": STATE, "feed": FEED}


@dataclass
class RemoteMirror:
    """What the web server shows of one mirror: its port and how many updates it has pushed."""

    port: int
    updates: int = 0

    def stop(self) -> None:  # (the process is stopped as a whole)
        pass


class MirrorProcess:
    """Starts the mirrors' process, feeds it the robot's state, and hands on the clicks its 3D views take."""

    def __init__(
        self,
        worker: WorkerProcess,
        host: str,
        ports: dict[str, int],
        rate_hz: float,
        shadows: bool,
        tokens: SceneTokens,
        on_click: ClickHandler,
        tls: TlsFiles | None = None,
    ) -> None:
        self._worker = worker
        self._on_click = on_click
        self._args = (worker.describe(), host, ports, rate_hz, shadows, tokens.secret, tls)
        self.mirrors: dict[str, RemoteMirror] = {}
        self._conn: Connection | None = None
        self._process: mp.process.BaseProcess | None = None
        self._send_lock = threading.Lock()
        self._reader: threading.Thread | None = None

    def start(self) -> None:
        context = mp.get_context("spawn")
        parent_conn, child_conn = context.Pipe(duplex=True)
        self._process = context.Process(
            target=mirror_main, args=(child_conn, *self._args), name="scene-mirrors", daemon=True
        )
        self._process.start()
        child_conn.close()
        self._conn = parent_conn
        # the state it starts from (later ones come through the tap)
        parent_conn.send_bytes(STATE + pickle.dumps(("state", self._worker.state())))
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

    def revoke(self, login: str) -> None:
        """That login ended: its tokens are refused and its viewers disconnected."""
        self._send(("revoke", login))

    def stop(self) -> None:
        if self._process is None:
            return
        self._send(("stop",))
        self._process.join(timeout=10)
        if self._process.is_alive():
            self._process.kill()
            self._process.join(timeout=5)
        self._process = None

    def _send(self, message: tuple) -> None:
        self._send_tagged(CONTROL + pickle.dumps(message))

    def _forward(self, kind: str, raw: bytes) -> None:
        self._send_tagged(_TAGS[kind] + raw)

    def _send_tagged(self, tagged: bytes) -> None:
        if self._process is None:
            return
        try:
            with self._send_lock:
                self._conn.send_bytes(tagged)  # type: ignore[union-attr]
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
            elif message[0] == "click":  # with who clicked; its outcome shows on the page like any plan's
                self._on_click(*message[1:])


class PipedPort:
    """The part of `RobotPort` a mirror reads, fed from the pipe: the newest state is kept as it came, and decoded
    when a mirror asks for it (once, however many mirrors ask)."""

    def __init__(self, description: RobotDescription) -> None:
        self._description = description
        self._lock = threading.Lock()
        self._raw_state: memoryview | None = None
        self._state: RobotState | None = None
        self._feed = SensorFeed()

    def describe(self) -> RobotDescription:
        return self._description

    def state(self) -> RobotState:
        with self._lock:
            if self._raw_state is not None:
                self._state = pickle.loads(self._raw_state)[1]
                self._raw_state = None
            assert self._state is not None
            return self._state

    def sensor_feed(self) -> SensorFeed:
        return self._feed

    def take(self, tagged: bytes) -> tuple | None:
        """Take one tagged message from the pipe; returns it decoded if it is a control message."""
        tag, body = tagged[:1], memoryview(tagged)[1:]
        if tag == STATE:
            with self._lock:
                self._raw_state = body
        elif tag == FEED:
            self._feed = merge_feed(self._feed, pickle.loads(body)[1])
        elif tag == CONTROL:
            return pickle.loads(body)
        return None


def mirror_main(
    conn: Connection,
    description: RobotDescription,
    host: str,
    ports: dict[str, int],
    rate_hz: float,
    shadows: bool,
    secret: bytes,
    tls: TlsFiles | None,
) -> None:
    """Entry point of the mirrors' process."""
    send_lock = threading.Lock()

    def send(message: tuple) -> None:
        with send_lock:
            conn.send(message)

    try:
        os.nice(MIRROR_NICE)
        from app.viz.mirror import open_views

        tokens = SceneTokens(secret)
        port = PipedPort(description)
        port.take(conn.recv_bytes())
        mirrors, gates = open_views(
            port,
            host,
            ports,
            rate_hz,
            shadows,
            tokens.verify,
            on_click=lambda grant, origin, direction: send(("click", grant, origin, direction)),
            tls=tls.server_context() if tls else None,
        )
    except Exception:
        send(("fatal", traceback.format_exc()))
        return
    send(("ready", {name: gate.port for name, gate in gates.items()}))
    stop = threading.Event()

    def report() -> None:
        while not stop.wait(UPDATES_PERIOD_S):
            with contextlib.suppress(OSError):
                send(("updates", {name: m.updates for name, m in mirrors.items()}))

    threading.Thread(target=report, daemon=True).start()
    try:
        while True:
            try:
                message = port.take(conn.recv_bytes())
            except (EOFError, OSError):  # the web server is gone
                break
            if message is None:
                continue
            if message[0] == "stop":
                break
            if message[0] == "revoke":
                tokens.revoke(message[1])
                for gate in gates.values():
                    gate.revoke(message[1])
    finally:
        stop.set()
        for gate in gates.values():
            gate.stop()
        for mirror in mirrors.values():
            mirror.stop()
