"""`humanoid bench network`: the console used over a poor network, not loopback (issue 36).

The real server (`humanoid serve`, access control on, bound to its namespace's address) runs on one side of
`app.bench.impaired_link` (20 +- 5 ms each way, 1 % of frames lost, 2 Mbit/s towards the operator) and the
operator's and viewers' clients (`app.bench.network_client`, programs of their own) on the other. Measured:

- the link's round trip (a ping on the e-stop's idle socket, and on `/ws` behind the state stream, as the page's
  badge sees it);
- e-stop latency, from the client's press (its `client_time_s`) to the control loop applying the stop (the
  robot's `estop/latched` event), over many presses: sent as the page sends it (on `/ws` and `/ws/stop`), and on
  `/ws` alone for comparison (a segment lost on one TCP connection waits for its resend);
- while driving by teleop at 10 Hz, the time from cutting the link to the robot beginning to stop (the wall time
  of the deadman's event, seen on the server's side, minus the moment the wire was cut), over several cuts;
- per viewer at default settings (`/ws`, `/ws/camera` and the light 3D view, as a page opens them): the bytes/s
  the server sends it and the state rate it receives, over the link, and what the same viewer is sent with no
  link in between (what the server wants to send, which the 2 Mbit/s limit would otherwise hide).

Needs root (network namespaces); without it the result says why it was skipped.
"""

from __future__ import annotations

import json
import os
import platform
import queue
import select
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from app.bench.core import _percentiles
from app.bench.impaired_link import ImpairedLink, LinkProfile, Side, unavailable_reason
from app.bench.network_client import TOKEN_ENV
from app.bench.server import ServerProcess
from app.settings import Settings
from robot.perception.service import SENSOR_HZ

TARGETS = {
    "estop_p99_ms": 60.0,
    "cut_to_stopping_max_ms": 400.0,  # teleop's 300 ms deadman + 100 ms
    "viewer_mbit_s": 2.0,
    "viewer_state_rate_of_no_link": 0.95,  # the state rate holds over the link (as a share of the unlinked viewer's)
}
STATE_HZ = Settings.model_fields["ws_state_hz"].default  # what a page is sent at default settings
CLIENT = [sys.executable, "-m", "app.bench.network_client"]
STOP_KINDS = frozenset({"teleop/deadman", "teleop/stop"})
# what would spoil a run, said in it: the robot process died or restarted, the robot fell or stopped itself
INCIDENTS = frozenset({"worker/died", "worker/restarted", "robot/fell", "diagnostics/safe_stop"})
WATCHED = ("estop/latched", "teleop/started", "teleop/ended", *sorted(STOP_KINDS), *sorted(INCIDENTS))
DRIVE_BEFORE_CUT_S = 1.5
CUT_HOLD_S = 1.0  # the link stays cut at least this long (well past the deadman), and until the walk has ended
EVENT_TIMEOUT_S = 20.0
CLIENT_TIMEOUT_S = 600.0
# full Ethernet frames for full TCP segments (MSS 1448 with timestamps); what a viewer's page reads, on the wire
# (from the wire's own count instead, a client that reads late moves bytes between windows)
WIRE_OVERHEAD = 1514 / 1448
VIEWER_SETTLE_S = 8.0  # a viewer's first scene and camera frames, before its steady rate is measured
SERVER_START_S = 300.0  # (a loaded machine: the robot's first start derives its model)


class FarEnd:
    """Runs `network_client` scenarios on one side of the link, logged in with a token."""

    def __init__(self, link: ImpairedLink, side: Side, base: str, token: str, logs: Path) -> None:
        self._link = link
        self._side = side
        self._base = base
        self._env = {**os.environ, TOKEN_ENV: token}
        self._logs = logs

    def start(self, scenario: str, *args: str) -> subprocess.Popen:
        with (self._logs / f"{self._side}-{scenario}.log").open("a") as log:
            return self._link.popen(
                self._side,
                [*CLIENT, scenario, "--base", self._base, *args],
                env=self._env,
                stdout=subprocess.PIPE,
                stderr=log,
                text=True,
            )

    def run(self, scenario: str, *args: str) -> dict[str, Any]:
        process = self.start(scenario, *args)
        out, _ = process.communicate(timeout=CLIENT_TIMEOUT_S)
        return self._result(scenario, process, out)

    def log(self, scenario: str) -> str:
        """The end of what a scenario wrote to stderr."""
        path = self._logs / f"{self._side}-{scenario}.log"
        return (path.read_text()[-3000:] if path.exists() else "") or "(empty)"

    def _result(self, scenario: str, process: subprocess.Popen, out: str) -> dict[str, Any]:
        lines = out.strip().splitlines()
        if process.returncode != 0 or not lines:
            raise RuntimeError(
                f"{scenario} on the {self._side}'s side failed ({process.returncode}): {self.log(scenario)}"
            )
        return json.loads(lines[-1])

    def stop(self, scenario: str, process: subprocess.Popen) -> dict[str, Any]:
        """End a scenario that runs until told (SIGTERM) and read its summary."""
        process.terminate()
        out, _ = process.communicate(timeout=30)
        return self._result(scenario, process, out)


class EventWatch:
    """The robot's events as the server's own side sees them (a cut link does not delay them)."""

    def __init__(self, process: subprocess.Popen) -> None:
        self.process = process
        self.incidents: list[str] = []  # the robot process died or restarted, the robot fell
        self._events: queue.Queue[dict[str, Any]] = queue.Queue()
        first = process.stdout.readline()  # type: ignore[union-attr]
        if not first or not json.loads(first).get("ready"):
            raise RuntimeError(f"the event watch did not start: {first!r}")
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stdout:  # type: ignore[union-attr]
            message = json.loads(line)
            if "event" in message:
                self._events.put(message["event"])
                if message["event"]["kind"] in INCIDENTS:
                    self.incidents.append(f"{message['event']['kind']}: {message['event']['message']}")

    def close(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()

    def next(self, kinds: set[str] | frozenset[str], after_s: float, timeout_s: float) -> dict[str, Any] | None:
        """The first event of `kinds` at or after wall time `after_s` (older ones are passed over)."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            try:
                event = self._events.get(timeout=left)
            except queue.Empty:
                return None
            if event["kind"] in kinds and event["wall_time_s"] >= after_s:
                return event
        return None


def add_bench_users(database_url: str) -> tuple[str, str]:
    """An operator and a viewer with API tokens, as `humanoid users add/token` makes them."""
    from app.auth.roles import Role
    from app.auth.store import UserStore
    from app.sessions.db import make_engine, make_session_factory, upgrade_to_head

    upgrade_to_head(database_url)
    store = UserStore(make_session_factory(make_engine(database_url)))
    store.add("bench-operator", Role.OPERATOR)
    store.add("bench-viewer", Role.VIEWER)
    return store.issue_token("bench-operator", "bench"), store.issue_token("bench-viewer", "bench")


@dataclass
class Ends:
    """The server across the link, and who uses it: an operator's and a viewer's clients on the far side, clients on
    the server's own side (unimpaired), and the robot's events as the server's side sees them."""

    server: ServerProcess
    operator: FarEnd
    viewer: FarEnd
    on_server: FarEnd  # a viewer
    local_operator: FarEnd
    watch: EventWatch


@contextmanager
def served_across(link: ImpairedLink, work: Path) -> Iterator[Ends]:
    """`humanoid serve` on the server's side of `link` (bound to its address, access control on, an operator and
    a viewer with API tokens), stopped on exit."""
    operator_token, viewer_token = add_bench_users(f"sqlite:///{work / 'server.db'}")
    server = ServerProcess(
        work,
        host=link.server_address,
        launcher=link.exec_prefix("server"),
        extra_env={"HUMANOID_AUTH": "on"},
        ready=lambda: probe.poll() == 0,
        startup_timeout_s=SERVER_START_S,
    )
    # (this process cannot reach the server's namespace: it is asked from there whether it answers)
    probe = link.popen(
        "server", [*CLIENT, "ready", "--base", server.url, "--timeout", str(SERVER_START_S)], stdout=subprocess.DEVNULL
    )
    try:
        with server:
            on_server = FarEnd(link, "server", server.url, viewer_token, work)
            watch = EventWatch(on_server.start("watch", "--kinds", ",".join(WATCHED)))
            try:
                yield Ends(
                    server=server,
                    operator=FarEnd(link, "operator", server.url, operator_token, work),
                    viewer=FarEnd(link, "operator", server.url, viewer_token, work),
                    on_server=on_server,
                    local_operator=FarEnd(link, "server", server.url, operator_token, work),
                    watch=watch,
                )
            finally:
                watch.close()
    finally:
        probe.kill()
        probe.wait()


def round_trips(far: FarEnd, path: str, count: int) -> dict[str, float]:
    """Round trips (ms) of `count` pings on the WebSocket at `path`."""
    rtts = far.run("rtt", "--path", path, "--count", str(count), "--period", "0.05")["rtt_ms"]
    return {**_percentiles(rtts), "min": round(min(rtts), 3)}


def estop_presses(far: FarEnd, presses: int, ws_only: bool, seed: int) -> dict[str, Any]:
    """`presses` e-stops as the page sends them (or on `/ws` only), each released once acknowledged."""
    args = ["--presses", str(presses), "--seed", str(seed)] + (["--ws-only"] if ws_only else [])
    result = far.run("estop", *args)
    latched = [p for p in result["presses"] if p["latency_ms"] is not None]
    latencies = [p["latency_ms"] for p in latched]
    in_server = [p["server_latency_ms"] for p in latched]
    slowest = sorted(latched, key=lambda p: -p["latency_ms"])[:5]
    return {
        "paths": result["paths"],
        "latency_ms": _percentiles(latencies),
        "missed": len(result["presses"]) - len(latched),  # no latch within 10 s
        "first_path": dict(Counter(p["source"] for p in latched)),
        "over_100_ms": sum(1 for v in latencies if v > 100.0),
        # where the time went: the press to the web server taking it (the client sending it, the link, the server
        # reading it), and from there to the control loop applying it (the server's relay and the robot process)
        "parts_ms": {
            "press_to_sent": _percentiles([p["sent_ms"] for p in latched]),
            "press_to_server": _percentiles([a - b for a, b in zip(latencies, in_server, strict=True)]),
            "server_to_applied": _percentiles(in_server),
        },
        "slowest": [
            {
                "ms": round(p["latency_ms"], 1),
                "sent_ms": round(p["sent_ms"], 1),
                "in_server_ms": round(p["server_latency_ms"], 1),
                "first": p["source"],
            }
            for p in slowest
        ],
    }


def _driving(watch: EventWatch, since_s: float) -> float:
    """Wait until teleop has started after `since_s` and driven `DRIVE_BEFORE_CUT_S` without a stop; when."""
    while True:
        started = watch.next({"teleop/started"}, since_s, EVENT_TIMEOUT_S)
        if started is None:
            raise RuntimeError("teleop did not start (is the driver refused?)")
        stopped = watch.next(STOP_KINDS, started["wall_time_s"], DRIVE_BEFORE_CUT_S)
        if stopped is None:
            return started["wall_time_s"]
        since_s = stopped["wall_time_s"]


def cut_while_driving(link: ImpairedLink, operator: FarEnd, watch: EventWatch, cuts: int) -> dict[str, Any]:
    """Drive by teleop; `cuts` times, once the robot drives, cut the link and time the robot's stop."""
    driver = operator.start("drive")
    delays, kinds, held = [], [], []
    failure = None
    try:
        since = time.time()
        for _ in range(cuts):
            _driving(watch, since)
            cut_s = link.cut()
            stopping = watch.next(STOP_KINDS, cut_s, EVENT_TIMEOUT_S)
            delays.append(None if stopping is None else round((stopping["wall_time_s"] - cut_s) * 1e3, 1))
            kinds.append(None if stopping is None else stopping["kind"])
            # (teleop that comes back before the walk has ended resumes it without a "teleop/started")
            watch.next({"teleop/ended"}, cut_s, EVENT_TIMEOUT_S)
            time.sleep(max(0.0, cut_s + CUT_HOLD_S - time.time()))
            since = link.restore()
            held.append(round(since - cut_s, 2))
    except RuntimeError as exc:
        failure = exc
    finally:
        drive = operator.stop("drive", driver)
    if failure is not None:
        raise RuntimeError(
            f"{failure}; the driver: {drive}; its log: {operator.log('drive')}; incidents: {watch.incidents}"
        ) from failure
    measured = [d for d in delays if d is not None]
    return {
        "cut_to_stopping_ms": delays,
        "max_ms": max(measured) if measured else None,
        "median_ms": statistics.median(measured) if measured else None,
        "event_kinds": dict(Counter(kinds)),
        "cut_held_s": held,
        "driver": drive,
    }


def _read_line(process: subprocess.Popen, timeout_s: float) -> dict[str, Any]:
    readable, _, _ = select.select([process.stdout], [], [], timeout_s)
    line = process.stdout.readline() if readable else ""  # type: ignore[union-attr]
    if not line:
        raise RuntimeError("a viewer said nothing")
    return json.loads(line)


def viewers_side_by_side(ends: Ends, link: ImpairedLink, settle_s: float, seconds: float) -> dict[str, Any]:
    """A viewer across the link and one on the server's side (the same page with nothing in between: what the
    server sends when no link limits it), watched together while an operator on the server's side drives (a robot
    that moves is what makes the 3D view and the camera send the most). Over the link, the wire's own count of the
    bytes to the viewer too."""
    driver = ends.local_operator.start(
        "drive", "--vx", "0", "--yaw-rate", "0.4"
    )  # (on the spot: it walks into nothing)
    args = ("--settle", str(settle_s), "--seconds", str(seconds))
    remote, local = ends.viewer.start("view", *args), ends.on_server.start("view", *args)
    try:
        _read_line(remote, settle_s + 120)  # {"measuring": true}
        before, started = link.counters(), time.monotonic()
        over = _read_line(remote, seconds + 60)
        after, window = link.counters(), time.monotonic() - started
        _read_line(local, settle_s + 120)
        demand = _read_line(local, seconds + 60)
    finally:
        for process in (remote, local):
            process.wait(timeout=30)
        drive = ends.local_operator.stop("drive", driver)
    for result in (over, demand):
        result["mbit_s"] = round(result["bytes_per_s"] * 8 / 1e6, 3)
    down = after["server_to_operator"]["bytes"] - before["server_to_operator"]["bytes"]
    dropped = after["rate_limiter"]["drops"] - before["rate_limiter"]["drops"]
    over["wire"] = {"mbit_s": round(down * 8 / window / 1e6, 3), "frames_dropped_at_the_limit": dropped}
    return {
        "over_the_link": over,
        "no_link": demand,
        "at_nominal_rates": at_nominal_rates(demand),
        "while": f"driven from the server's side: {drive}",
    }


def at_nominal_rates(viewer: dict[str, Any]) -> dict[str, float]:
    """What `viewer` would be sent if the state and the camera ran at their nominal rates (a loaded machine sends
    fewer of both, which would flatter the figure), on the wire (TCP/IP and Ethernet headers included)."""
    streams = viewer["streams"]
    per_state = streams["robot"]["bytes_per_s"] / viewer["state_hz"] if viewer["state_hz"] else 0.0
    per_frame = streams["camera"]["bytes_per_s"] / viewer["camera_fps"] if viewer["camera_fps"] else 0.0
    app_bytes = per_state * STATE_HZ + per_frame * SENSOR_HZ + streams["scene"]["bytes_per_s"]
    return {
        "state_hz": STATE_HZ,
        "camera_fps": SENSOR_HZ,
        "state_kb_each": round(per_state / 1e3, 2),  # (with the diagnostics and events that come between)
        "camera_kb_per_frame": round(per_frame / 1e3, 2),
        "mbit_s": round(app_bytes * 8 * WIRE_OVERHEAD / 1e6, 3),
    }


def run_network(presses: int = 100, cuts: int = 6, viewer_seconds: float = 20.0, seed: int = 0) -> dict[str, Any]:
    profile = LinkProfile(seed=seed)
    result: dict[str, Any] = {
        "suite": "network",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()},
        "config": {
            "link": {
                "delay_ms": profile.delay_ms,
                "jitter_ms": profile.jitter_ms,
                "loss": profile.loss,
                "rate_kbit_to_operator": profile.rate_kbit,
                "rate_queue_ms": profile.rate_queue_ms,
                "seed": seed,
            },
            "presses": presses,
            "cuts": cuts,
            "viewer": "/ws + /ws/camera + the light 3D view, default settings",
            "access_control": "on (API tokens)",
        },
        "targets": TARGETS,
    }
    if reason := unavailable_reason():
        return {**result, "skipped": reason}
    started, load_before = time.monotonic(), os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp, ImpairedLink(profile) as link, served_across(link, Path(tmp)) as ends:
        result["rtt_ms"] = {
            "e_stop_socket": round_trips(ends.operator, "/ws/stop", 100),
            "page_socket": round_trips(ends.operator, "/ws", 50),
        }
        result["estop"] = {
            "as_the_page": estop_presses(ends.operator, presses, ws_only=False, seed=seed),
            "ws_only": estop_presses(ends.operator, presses, ws_only=True, seed=seed + 1),
        }
        result["teleop_cut"] = cut_while_driving(link, ends.operator, ends.watch, cuts)
        result["viewer"] = viewers_side_by_side(ends, link, VIEWER_SETTLE_S, viewer_seconds)
        result["link_counters"] = link.counters()
        result["incidents"] = ends.watch.incidents
    result["elapsed_s"] = round(time.monotonic() - started, 1)
    # (other work on the machine delays both ends: a figure missed under load is checked on an idle machine)
    result["machine"]["load_average_1min"] = {"before": load_before[0], "after": os.getloadavg()[0]}
    cut = result["teleop_cut"]
    over, demand, nominal = (result["viewer"][k] for k in ("over_the_link", "no_link", "at_nominal_rates"))
    result["pass"] = {
        "estop_p99": result["estop"]["as_the_page"]["latency_ms"]["p99"] <= TARGETS["estop_p99_ms"]
        and result["estop"]["as_the_page"]["missed"] == 0,
        "cut_to_stopping": None not in cut["cut_to_stopping_ms"] and cut["max_ms"] <= TARGETS["cut_to_stopping_max_ms"],
        "viewer_bandwidth": max(demand["mbit_s"], over["wire"]["mbit_s"], nominal["mbit_s"])
        <= TARGETS["viewer_mbit_s"],
        "viewer_state_rate": over["state_hz"] >= TARGETS["viewer_state_rate_of_no_link"] * demand["state_hz"],
        # the robot neither fell, stopped itself (a control loop starved on a loaded machine) nor restarted
        "no_incidents": not result["incidents"],
    }
    return result
