"""Starts the real server (`humanoid serve`) in a subprocess on free ports, for benchmarks and end-to-end tests."""

from __future__ import annotations

import itertools
import os
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType

import httpx

STARTUP_TIMEOUT_S = 120.0


# Ports below the kernel's ephemeral ones (32768 and up): a port the kernel chose for a bind to port 0 may be handed
# to an outgoing connection (the server's own, the browser's) before the server binds it (a bench's replay view
# once could not listen: "address already in use").
PORTS_FROM = 20000  # pytest-xdist workers: 2000 each
PORTS_PER_WORKER = 2000
SOLO_PORTS_FROM = 10000  # anything else (benches, a test run without workers)
SOLO_PORTS = 10000
_port_turn = itertools.count(os.getpid())


def free_port() -> int:
    """A port free now. Under pytest-xdist each test process takes its ports from a range of its own, so two
    processes never pick the same port between choosing it and binding it (the kernel's own choice could)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if worker.startswith("gw"):
        first, count = PORTS_FROM + int(worker[2:]) * PORTS_PER_WORKER, PORTS_PER_WORKER
    else:
        first, count = SOLO_PORTS_FROM, SOLO_PORTS
    for _ in range(count):
        port = first + next(_port_turn) % count
        with socket.socket() as sock:
            try:
                sock.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    raise RuntimeError(f"no free port in {first}-{first + count - 1}")


class ServerProcess:
    """`with ServerProcess(workdir) as server:` gives a running app at `server.url`, stopped on exit."""

    def __init__(
        self,
        workdir: Path,
        seed: int = 0,
        extra_env: dict[str, str] | None = None,
        servo_port: str | None = None,
        tls: bool = False,
        host: str = "127.0.0.1",
        launcher: Sequence[str] = (),
        ready: Callable[[], bool] | None = None,
        startup_timeout_s: float = STARTUP_TIMEOUT_S,
        views: bool = True,
    ) -> None:
        """`servo_port`: serve the real robot (`--backend dynamixel`) on that serial device (or the emulator's);
        `tls`: HTTPS with the robot's own certificate (its CA, `self.ca`, is what clients trust); `host`: the
        address to serve on; `launcher`: a command prefix to start it with (e.g. `ip netns exec NS`); `ready`: says
        when it answers, where this process cannot reach `host` itself (default: `/api/health` answers 200);
        `startup_timeout_s`: how long it may take to answer; `views`: serve the 3D views (off, a page opened on it
        has none to render: a test that does not look at them saves the processes that serve them and the
        browser's software WebGL, about half of a browser test's CPU here)."""
        self.workdir = Path(workdir)
        self.port = free_port()
        self.viser_port = free_port()
        self.viser_light_port = free_port()
        self.replay_port = free_port()
        self.tls = tls
        self.host = host
        self.url = f"{'https' if tls else 'http'}://{host}:{self.port}"
        self._launcher = list(launcher)
        self._ready = ready or self._answers
        self._startup_timeout_s = startup_timeout_s
        self.ca = self.workdir / "tls" / "ca.pem"
        self.seed = seed
        self.servo_port = servo_port
        self.log_path = self.workdir / "server.log"
        self._env = {
            **os.environ,
            "DATABASE_URL": f"sqlite:///{self.workdir / 'server.db'}",
            "HUMANOID_AUDIO_DIR": str(self.workdir / "audio"),
            "HUMANOID_VISER_LIGHT_PORT": str(self.viser_light_port),
            "HUMANOID_REPLAY_PORT": str(self.replay_port),
            **({} if views else {"HUMANOID_ENABLE_MIRROR": "false"}),
            **(extra_env or {}),
        }
        self._process: subprocess.Popen | None = None

    def __enter__(self) -> ServerProcess:
        self.workdir.mkdir(parents=True, exist_ok=True)
        log = self.log_path.open("a")
        ports = ["--port", str(self.port)]
        if self.servo_port:
            ports = ["--backend", "dynamixel", "--port", self.servo_port, "--http-port", str(self.port)]
        command = [
            sys.executable,
            "-m",
            "app.cli",
            "serve",
            "--host",
            self.host,
            *ports,
            "--viser-port",
            str(self.viser_port),
            "--seed",
            str(self.seed),
        ]
        if self.tls:
            command.append("--tls")
        self._process = subprocess.Popen(
            [*self._launcher, *command], stdout=log, stderr=subprocess.STDOUT, env=self._env
        )
        deadline = time.monotonic() + self._startup_timeout_s
        while time.monotonic() < deadline:
            if self._process.poll() is not None:
                raise RuntimeError(f"server exited with {self._process.returncode}: {self.log_path.read_text()}")
            if self._ready():
                return self
            time.sleep(0.2)
        self.__exit__(None, None, None)
        raise RuntimeError(f"server did not start in {self._startup_timeout_s:g} s: {self.log_path.read_text()}")

    def __exit__(self, exc_type: type | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        if self._process and self._process.poll() is None:
            self._process.terminate()
            try:
                self._process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()

    def _answers(self) -> bool:
        try:
            with self.http() as client:
                return client.get("/api/health", timeout=1.0).status_code == 200
        except httpx.HTTPError:
            return False

    @property
    def pid(self) -> int:
        assert self._process is not None, "not started"
        return self._process.pid

    def send_signal(self, signum: int) -> None:
        """To the server alone, not its children (as `systemctl stop` does with KillMode=mixed)."""
        assert self._process is not None, "not started"
        self._process.send_signal(signum)

    def wait(self, timeout: float) -> int:
        """The server's exit code, once it has ended (subprocess.TimeoutExpired if not within `timeout`)."""
        assert self._process is not None, "not started"
        return self._process.wait(timeout=timeout)

    def kill(self) -> None:
        """SIGKILL, as a crash: nothing gets to close or flush."""
        if self._process and self._process.poll() is None:
            self._process.kill()
            self._process.wait()

    def http(self) -> httpx.Client:
        """A client of this server (trusting its own certificate authority when it serves HTTPS)."""
        return httpx.Client(base_url=self.url, verify=str(self.ca) if self.tls and self.ca.exists() else True)

    def get(self, path: str) -> dict:
        with self.http() as client:
            return client.get(path, timeout=5.0).json()

    def post(self, path: str, json: dict | None = None) -> httpx.Response:
        with self.http() as client:
            return client.post(path, json=json, timeout=5.0)
