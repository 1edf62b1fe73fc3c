"""A network between a server and an operator's computer on one machine: two network namespaces joined by an
impaired link, so that what the console does over a real network (a laptop on Wi-Fi, a site link) is measured
without loopback's zero delay and loss.

    server namespace          link namespace (the "wire")                 operator namespace
    srv0 10.36.0.1  ==veth==  tosrv  <- frame_forwarder ->  toop  ==veth==  op0 10.36.0.2
                                      delay 20 +- 5 ms each way      tbf 2 Mbit/s towards the operator
                                      1 % of frames lost, cut/restore

The kernel here has no netem qdisc, so delay, jitter, loss and cuts are made by `harness.frame_forwarder` (raw
sockets on the two veth ends in a third namespace); the rate limit is the kernel's `tbf` qdisc on the interface
towards the operator (frames beyond its queue are dropped, as at a real bottleneck). The veths' offloads are off
so that every frame is a real, checksummed, MTU-sized Ethernet frame. Names are unique per run; everything made
(namespaces, veths, the forwarder, whatever still runs in the namespaces) is removed on exit, failure included.

Needs root, `ip` and `tc` (Debian: iproute2) and `ethtool`; `unavailable_reason()` says what is missing.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Literal

Side = Literal["server", "operator"]
SERVER_ADDRESS = "10.36.0.1"
OPERATOR_ADDRESS = "10.36.0.2"
PREFIX_LENGTH = 24
TOOLS = {"ip": "iproute2", "tc": "iproute2", "ethtool": "ethtool"}
COMMAND_TIMEOUT_S = 10.0
FORWARDER_START_S = 30.0
KILL_GRACE_S = 5.0


class RigUnavailable(RuntimeError):
    """This machine cannot make the rig (not root, tools missing, no namespaces): a reason to skip, not a fault."""


@dataclass(frozen=True)
class LinkProfile:
    """How impaired the link is (the defaults are issue 36's: a poor but usable remote link)."""

    delay_ms: float = 20.0  # one way
    jitter_ms: float = 5.0
    loss: float = 0.01  # of the frames, each way
    rate_kbit: int = 2000  # server -> operator
    rate_burst_bytes: int = 8192
    rate_queue_ms: float = 100.0  # a frame that would wait longer at the bottleneck is dropped
    seed: int = 0


def unavailable_reason() -> str | None:
    """Why the rig cannot be made here (None: it can)."""
    if not sys.platform.startswith("linux"):
        return "network namespaces need Linux"
    if os.geteuid() != 0:
        return "making network namespaces needs root (CI runs as root)"
    missing = sorted({package for tool, package in TOOLS.items() if shutil.which(tool) is None})
    if missing:
        return f"missing tools: install the Debian packages {' '.join(missing)}"
    probe = f"hmn-probe-{secrets.token_hex(3)}"
    made = subprocess.run(["ip", "netns", "add", probe], capture_output=True, text=True)
    if made.returncode != 0:
        return f"cannot make a network namespace: {made.stderr.strip()}"
    subprocess.run(["ip", "netns", "del", probe], capture_output=True)
    return None


def _run(*argv: str) -> str:
    done = subprocess.run(list(argv), capture_output=True, text=True, timeout=COMMAND_TIMEOUT_S)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)}: {done.stderr.strip() or done.stdout.strip()}")
    return done.stdout


class ImpairedLink:
    """`with ImpairedLink() as link:` two namespaces joined by the impaired link; `link.popen("server", argv)`
    runs a program on the server's side, `link.cut()` / `link.restore()` cut and restore the wire."""

    def __init__(self, profile: LinkProfile | None = None) -> None:
        self.profile = profile or LinkProfile()
        run_id = secrets.token_hex(3)
        self.namespaces: dict[str, str] = {role: f"hmn-{run_id}-{role}" for role in ("server", "operator", "link")}
        self.server_address = SERVER_ADDRESS
        self.operator_address = OPERATOR_ADDRESS
        self._made: list[str] = []
        self._forwarder: subprocess.Popen | None = None
        self._forwarder_log = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 (open while the rig is; closed in close)
        self._lock = threading.Lock()
        self._previous_sigterm: Any = None

    # lifecycle -------------------------------------------------------------------------------------------------

    def __enter__(self) -> ImpairedLink:
        if reason := unavailable_reason():
            raise RigUnavailable(reason)
        self._clean_up_on_sigterm()
        try:
            self._make_namespaces()
            self._make_wire()
            self._start_forwarder()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, exc_type: type | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        """Remove everything this rig made; safe to call twice, and after a partial start."""
        self._stop_forwarder()
        for namespace in reversed(self._made):
            self._end_processes_in(namespace)
            subprocess.run(["ip", "netns", "del", namespace], capture_output=True)
        self._made.clear()
        self._forwarder_log.close()
        if self._previous_sigterm is not None:
            signal.signal(signal.SIGTERM, self._previous_sigterm)
            self._previous_sigterm = None

    def _clean_up_on_sigterm(self) -> None:
        """A bench stopped with SIGTERM unwinds (and so cleans up) as on Ctrl-C."""
        if threading.current_thread() is threading.main_thread():

            def stop(signum: int, frame: object) -> None:
                raise SystemExit(128 + signum)

            self._previous_sigterm = signal.signal(signal.SIGTERM, stop)

    def _make_namespaces(self) -> None:
        for namespace in self.namespaces.values():
            try:
                _run("ip", "netns", "add", namespace)
            except RuntimeError as exc:
                raise RigUnavailable(str(exc)) from exc
            self._made.append(namespace)
            # no IPv6: its neighbour discovery and router solicitations would be the only traffic nobody asked for
            self._sysctl(namespace, "net/ipv6/conf/all/disable_ipv6", "1")
            self._sysctl(namespace, "net/ipv6/conf/default/disable_ipv6", "1")
            _run("ip", "-n", namespace, "link", "set", "lo", "up")

    def _make_wire(self) -> None:
        link = self.namespaces["link"]
        ends = (("server", "srv0", "tosrv", self.server_address), ("operator", "op0", "toop", self.operator_address))
        for role, inside, outside, address in ends:
            namespace = self.namespaces[role]
            try:
                _run(
                    "ip",
                    "link",
                    "add",
                    inside,
                    "netns",
                    namespace,
                    "type",
                    "veth",
                    "peer",
                    "name",
                    outside,
                    "netns",
                    link,
                )
            except RuntimeError as exc:
                raise RigUnavailable(f"cannot make a veth pair: {exc}") from exc
            _run("ip", "-n", namespace, "addr", "add", f"{address}/{PREFIX_LENGTH}", "dev", inside)
            _run("ip", "-n", namespace, "link", "set", inside, "up")
            _run("ip", "-n", link, "link", "set", outside, "up", "promisc", "on")
            # whole frames on the wire: no segmentation or checksums left to a NIC that a raw socket bypasses
            _run("ip", "netns", "exec", namespace, "ethtool", "-K", inside, "tx", "off", "tso", "off", "gso", "off")
            _run("ip", "netns", "exec", link, "ethtool", "-K", outside, "gro", "off")
        p = self.profile
        try:
            _run(
                "tc",
                "-n",
                link,
                "qdisc",
                "add",
                "dev",
                "toop",
                "root",
                "tbf",
                "rate",
                f"{p.rate_kbit}kbit",
                "burst",
                str(p.rate_burst_bytes),
                "latency",
                f"{p.rate_queue_ms:g}ms",
            )
        except RuntimeError as exc:
            raise RigUnavailable(f"cannot limit the rate (tbf qdisc): {exc}") from exc

    def _sysctl(self, namespace: str, key: str, value: str) -> None:
        if os.path.exists(f"/proc/sys/{key}"):
            _run("ip", "netns", "exec", namespace, "sh", "-c", f"echo {value} > /proc/sys/{key}")

    def _start_forwarder(self) -> None:
        p = self.profile
        argv = [
            sys.executable,
            "-m",
            "harness.frame_forwarder",
            "tosrv",
            "toop",
            "--delay-ms",
            str(p.delay_ms),
            "--jitter-ms",
            str(p.jitter_ms),
            "--loss",
            str(p.loss),
            "--seed",
            str(p.seed),
        ]
        self._forwarder = subprocess.Popen(
            ["ip", "netns", "exec", self.namespaces["link"], *argv],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._forwarder_log,
            text=True,
        )
        ready = self._read_answer(FORWARDER_START_S)
        if not ready.get("ready"):
            raise RuntimeError(f"the frame forwarder did not start: {ready}")

    def _stop_forwarder(self) -> None:
        forwarder, self._forwarder = self._forwarder, None
        if forwarder is None:
            return
        with contextlib.suppress(OSError, ValueError):
            forwarder.stdin.write("quit\n")  # type: ignore[union-attr]
            forwarder.stdin.flush()  # type: ignore[union-attr]
        try:
            forwarder.wait(timeout=KILL_GRACE_S)
        except subprocess.TimeoutExpired:
            forwarder.kill()
            forwarder.wait()

    def _end_processes_in(self, namespace: str) -> None:
        """Whatever still runs in a namespace of ours was started in it by us (a server a failure left behind)."""
        listed = subprocess.run(["ip", "netns", "pids", namespace], capture_output=True, text=True)
        pids = [int(p) for p in listed.stdout.split() if p.isdigit()]
        for sig in (signal.SIGTERM, signal.SIGKILL):
            for pid in pids:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, sig)
            deadline = time.monotonic() + KILL_GRACE_S
            while pids and time.monotonic() < deadline:
                pids = [pid for pid in pids if _alive(pid)]
                time.sleep(0.05)

    # use -------------------------------------------------------------------------------------------------------

    def exec_prefix(self, side: Side) -> list[str]:
        """The command prefix that runs a program on that side of the link."""
        return ["ip", "netns", "exec", self.namespaces[side]]

    def popen(self, side: Side, argv: list[str], **kwargs: Any) -> subprocess.Popen:
        return subprocess.Popen([*self.exec_prefix(side), *argv], **kwargs)

    def cut(self) -> float:
        """Cut the wire: every frame is dropped, those in flight too, until `restore`. The wall time it took effect."""
        return float(self._command("cut")["wall_time_s"])

    def restore(self) -> float:
        return float(self._command("restore")["wall_time_s"])

    def counters(self) -> dict[str, Any]:
        """Frames and bytes each way (as delivered by the wire), and what the rate limiter sent and dropped."""
        stats = self._command("stats")["directions"]
        out = {"server_to_operator": stats["tosrv->toop"], "operator_to_server": stats["toop->tosrv"]}
        out["rate_limiter"] = self._tbf_counters()
        return out

    def _tbf_counters(self) -> dict[str, int]:
        raw = _run("tc", "-n", self.namespaces["link"], "-s", "-j", "qdisc", "show", "dev", "toop")
        qdisc = next((q for q in json.loads(raw) if q.get("kind") == "tbf"), {})
        return {key: int(qdisc.get(key, 0)) for key in ("bytes", "packets", "drops", "overlimits")}

    def _command(self, command: str) -> dict[str, Any]:
        with self._lock:
            if self._forwarder is None or self._forwarder.poll() is not None:
                raise RuntimeError(f"the frame forwarder is not running: {self._log()}")
            self._forwarder.stdin.write(command + "\n")  # type: ignore[union-attr]
            self._forwarder.stdin.flush()  # type: ignore[union-attr]
            return self._read_answer(COMMAND_TIMEOUT_S)

    def _read_answer(self, timeout_s: float) -> dict[str, Any]:
        assert self._forwarder is not None and self._forwarder.stdout is not None
        readable, _, _ = select.select([self._forwarder.stdout], [], [], timeout_s)
        line = self._forwarder.stdout.readline() if readable else ""
        if not line:
            raise RuntimeError(f"the frame forwarder did not answer: {self._log()}")
        return json.loads(line)

    def _log(self) -> str:
        self._forwarder_log.seek(0)
        return self._forwarder_log.read()[-2000:] or "(nothing logged)"


def _alive(pid: int) -> bool:
    """Running (a zombie waiting for its parent to read its status is not)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rpartition(")")[2].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return False
