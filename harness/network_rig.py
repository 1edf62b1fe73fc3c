"""The console across an impaired network link, as a rig: the real server (`humanoid serve`, access control on,
bound to its namespace's address) on one side of `harness.impaired_link`, and the operator's and viewers'
clients (`harness.network_client`, programs of their own) on the other; what an operator does across it (round
trips, e-stop presses, driving while the link is cut) and what the robot's side saw (its events).

`humanoid bench network` measures with it; the tests check that it carries the console as a link does.
"""

from __future__ import annotations

import collections
import json
import os
import queue
import select
import statistics
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from harness.impaired_link import ImpairedLink, Side
from harness.network_client import TOKEN_ENV
from harness.server import ServerProcess
from harness.stats import percentiles

CLIENT = [sys.executable, "-m", "harness.network_client"]
STOP_KINDS = frozenset({"teleop/deadman", "teleop/stop"})
# what would spoil a run, said in it: the robot process died or restarted, the robot fell or stopped itself
INCIDENTS = frozenset({"worker/died", "worker/restarted", "robot/fell", "diagnostics/safe_stop"})
WATCHED = ("estop/latched", "teleop/started", "teleop/ended", *sorted(STOP_KINDS), *sorted(INCIDENTS))
DRIVE_BEFORE_CUT_S = 1.5
CUT_HOLD_S = 1.0  # the link stays cut at least this long (well past the deadman), and until the walk has ended
EVENT_TIMEOUT_S = 20.0
CLIENT_TIMEOUT_S = 600.0
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
        self.recent: collections.deque[str] = collections.deque(maxlen=30)  # (said when a run fails)
        self._events: queue.Queue[dict[str, Any]] = queue.Queue()
        first = process.stdout.readline()  # type: ignore[union-attr]
        if not first or not json.loads(first).get("ready"):
            raise RuntimeError(f"the event watch did not start: {first!r}")
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stdout:  # type: ignore[union-attr]
            message = json.loads(line)
            if "event" in message:
                self.recent.append(f"{message['event']['wall_time_s']:.3f} {message['event']['kind']}")
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
    return {**percentiles(rtts), "min": round(min(rtts), 3)}


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
        "latency_ms": percentiles(latencies),
        "missed": len(result["presses"]) - len(latched),  # no latch within 10 s
        "first_path": dict(Counter(p["source"] for p in latched)),
        "over_100_ms": sum(1 for v in latencies if v > 100.0),
        # where the time went: the press to the web server taking it (the client sending it, the link, the server
        # reading it), and from there to the control loop applying it (the server's relay and the robot process)
        "parts_ms": {
            "press_to_sent": percentiles([p["sent_ms"] for p in latched]),
            "press_to_server": percentiles([a - b for a, b in zip(latencies, in_server, strict=True)]),
            "server_to_applied": percentiles(in_server),
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
    delays, kinds, held, cuts_at = [], [], [], []
    failure = None
    try:
        since = time.time()
        for _ in range(cuts):
            _driving(watch, since)
            cut_s = link.cut()
            cuts_at.append(round(cut_s, 3))
            stopping = watch.next(STOP_KINDS, cut_s, EVENT_TIMEOUT_S)
            delays.append(None if stopping is None else round((stopping["wall_time_s"] - cut_s) * 1e3, 1))
            kinds.append(None if stopping is None else stopping["kind"])
            if watch.next({"teleop/ended"}, cut_s, EVENT_TIMEOUT_S) is None:
                raise RuntimeError(f"the walk did not end within {EVENT_TIMEOUT_S:.0f} s of the cut")
            time.sleep(max(0.0, cut_s + CUT_HOLD_S - time.time()))
            since = link.restore()
            held.append(round(since - cut_s, 2))
    except RuntimeError as exc:
        failure = exc
    finally:
        drive = operator.stop("drive", driver)
    if failure is not None:
        raise RuntimeError(
            f"{failure}; the driver: {drive}; its log: {operator.log('drive')}; incidents: {watch.incidents}; "
            f"cuts at {cuts_at}, stopping after {delays} ms ({kinds}); the last events: {list(watch.recent)}"
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


def read_line(process: subprocess.Popen, timeout_s: float) -> dict[str, Any]:
    readable, _, _ = select.select([process.stdout], [], [], timeout_s)
    line = process.stdout.readline() if readable else ""  # type: ignore[union-attr]
    if not line:
        raise RuntimeError("a viewer said nothing")
    return json.loads(line)
