"""The supervisor restarts a robot process that died: safely (e-stop latched, the old session closed as crashed
with all it had kept, a new session), while the server keeps serving; a robot that keeps dying is left down."""

from __future__ import annotations

import contextlib
import os
import signal
import time

import pytest
from sqlalchemy import select

from app.sessions.models import CommandRow, EventRow, SessionRow
from app.supervisor import WorkerSupervisor, describe_exit
from robot.events import EventBus
from robot.interface import EStop, Level
from tests.app.test_api import wait_until


class DyingWorker:
    """A stand-in robot process that can be told to die, and whose restarts are counted."""

    def __init__(self, fail_restart: bool = False) -> None:
        self.alive = True
        self.silent_s = 0.0  # how long it has not answered (frozen, not dead)
        self.stopped = 0
        self.exitcode: int | None = None
        self.restarted = 0
        self.commands: list = []
        self.bus = EventBus()
        self.fail_restart = fail_restart

    def die(self, code: int) -> None:
        self.alive, self.exitcode = False, code

    def is_alive(self) -> bool:
        return self.alive

    def silent_for_s(self) -> float:
        return self.silent_s if self.alive else 0.0

    def restart(self, latched) -> None:
        if self.fail_restart:
            raise RuntimeError("no robot today")
        self.commands.append(latched)  # the new robot starts with it latched
        self.restarted += 1
        self.alive, self.exitcode, self.silent_s = True, None, 0.0

    def stop(self) -> None:
        self.stopped += 1
        self.alive = False

    def announce(self, kind, message, level=Level.OK, **data):
        return self.bus.publish(kind, message, level, **data)


def test_exits_are_described_for_a_person() -> None:
    assert describe_exit(-9) == "killed by SIGKILL"
    assert describe_exit(70) == "exit code 70"
    assert describe_exit(None) == "it stopped answering"


def test_a_dead_worker_is_restarted_with_the_estop_latched_and_one_that_keeps_dying_is_left_down() -> None:
    worker = DyingWorker()
    deaths, restarts = [], []
    supervisor = WorkerSupervisor(
        worker,
        on_death=deaths.append,
        on_restart=lambda: restarts.append(1),
        max_restarts=2,
        window_s=60,
        first_backoff_s=0.05,
    )
    supervisor.start()
    try:
        for n in (1, 2):
            worker.die(-11)
            wait_until(lambda n=n: worker.restarted == n and restarts == [1] * n, timeout=5)
            assert isinstance(worker.commands[-1], EStop) and worker.commands[-1].source == "supervisor"
        worker.die(-9)
        wait_until(lambda: supervisor.gave_up, timeout=5)
        time.sleep(0.5)
        assert worker.restarted == 2 and not worker.alive  # left down
        assert deaths == ["killed by SIGSEGV", "killed by SIGSEGV", "killed by SIGKILL"]
        kinds = [(e.kind, e.level) for e in worker.bus.history()]
        assert kinds.count(("worker/died", Level.ERROR)) == 3 and kinds.count(("worker/restarted", Level.WARN)) == 2
        assert "left down" in supervisor.gave_up
    finally:
        supervisor.stop()


def test_a_frozen_worker_is_restarted_after_the_grace_period_and_one_that_keeps_freezing_is_stopped() -> None:
    worker = DyingWorker()
    supervisor = WorkerSupervisor(worker, max_restarts=1, window_s=60, first_backoff_s=0.05, frozen_grace_s=2.0)
    supervisor.start()
    try:
        worker.silent_s = 1.5  # a hiccup within the grace period: left alone
        time.sleep(0.5)
        assert worker.restarted == 0
        worker.silent_s = 2.5
        wait_until(lambda: worker.restarted == 1, timeout=5)
        assert isinstance(worker.commands[-1], EStop) and "stopped answering" in worker.commands[-1].reason
        died = [e for e in worker.bus.history() if e.kind == "worker/died"]
        assert "stopped answering (it stopped answering for 2 s)" in died[0].message
        worker.silent_s = 3.0  # again: left down, and stopped so that it cannot wake up and go on
        wait_until(lambda: supervisor.gave_up, timeout=5)
        assert worker.stopped == 1 and worker.restarted == 1
    finally:
        supervisor.stop()


def test_a_restart_that_fails_is_said_and_tried_again() -> None:
    worker = DyingWorker(fail_restart=True)
    supervisor = WorkerSupervisor(worker, max_restarts=2, window_s=60, first_backoff_s=0.05)
    supervisor.start()
    try:
        worker.die(1)
        wait_until(lambda: supervisor.gave_up, timeout=5)
        failures = [e for e in worker.bus.history() if e.kind == "worker/restart_failed"]
        assert len(failures) == 2 and "no robot today" in failures[0].message
    finally:
        supervisor.stop()


@pytest.mark.slow
def test_a_killed_robot_process_is_restarted_stopped_and_the_server_never_stops_serving(served) -> None:
    rt = served.runtime
    assert served.post("/api/commands", json={"text": "say before the crash"}).status_code == 202
    first_session, first_pid = rt.recorder.session_id, rt.worker.pid
    os.kill(first_pid, signal.SIGKILL)  # as a segfault in the physics would
    down = wait_until(lambda: (r := served.get("/api/health")).status_code == 503 and r, timeout=5)
    assert down.json()["status"] == "worker_down"  # the server answers while the robot is down
    # (the new process answers a moment before its session is opened)
    health = wait_until(
        lambda: (r := served.get("/api/health")).status_code == 200 and r.json()["session_id"] != first_session and r,
        timeout=120,
    ).json()
    assert rt.worker.pid != first_pid
    assert health["estop_latched"]  # nothing moves until an operator says so
    refused = served.post("/api/commands", json={"text": "say after the crash"})
    assert refused.status_code == 409
    with rt.db() as db:
        old = db.get(SessionRow, first_session)
        assert old.outcome == "crashed" and "SIGKILL" in old.summary["cause"]
        said = db.scalars(select(CommandRow.text).where(CommandRow.session_id == first_session)).all()
        assert "say before the crash" in said  # nothing recorded before the crash is lost
        died = db.scalars(
            select(EventRow).where(EventRow.session_id == first_session, EventRow.kind == "worker/died")
        ).one()
        assert "SIGKILL" in died.message
    restarted = wait_until(
        lambda: next((e for e in served.get("/api/events").json() if e["kind"] == "worker/restarted"), None), timeout=10
    )
    assert "e-stop latched" in restarted["message"]
    worker_status = next(
        s
        for g in served.get("/api/diagnostics").json()["groups"].values()
        for s in g["statuses"]
        if s["name"] == "links/robot_worker"
    )
    assert worker_status["level_name"] == "OK" and "restarted 1 times" in worker_status["message"]
    assert served.post("/api/estop/reset").status_code == 200
    assert served.post("/api/commands", json={"text": "say after the crash"}).status_code == 202
    wait_until(lambda: rt.recorder.session_id == health["session_id"], timeout=5)


def _robot_worker_status(diagnostics: dict) -> dict:
    return next(s for g in diagnostics["groups"].values() for s in g["statuses"] if s["name"] == "links/robot_worker")


@pytest.mark.slow
def test_a_frozen_robot_process_never_holds_up_the_server_and_is_restarted_stopped(served) -> None:
    """SIGSTOP leaves the robot process alive but silent: an e-stop pressed then must not freeze the console, the
    health says so with the reason, every page keeps its feed, and after the grace period it is restarted with the
    e-stop latched."""
    rt = served.runtime
    wait_until(lambda: served.get("/api/health").status_code == 200, timeout=30)
    frozen_pid = rt.worker.pid
    with served.websocket_connect("/ws") as operator, served.websocket_connect("/ws") as watcher:
        os.kill(frozen_pid, signal.SIGSTOP)
        try:
            operator.send_json({"type": "estop", "client_time_s": time.time()})
            health = wait_until(lambda: (r := served.get("/api/health")).status_code == 503 and r.json(), timeout=30)
            assert health["status"] == "worker_not_answering" and "has not answered" in health["reason"]
            assert health["robot_pid"] == frozen_pid
            refused = served.post("/api/commands", json={"text": "say hello"})
            assert refused.status_code == 503 and "not answering" in refused.json()["detail"]["message"]
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:  # the other page's feed goes on, and says what is wrong
                message = watcher.receive_json()
                if message["type"] == "diagnostics":
                    status = _robot_worker_status(message["diagnostics"])
                    if status["level_name"] == "ERROR":
                        break
            else:
                raise AssertionError("the other page was not told that the robot is not answering")
            assert "has not answered" in status["message"]
        except BaseException:
            with contextlib.suppress(ProcessLookupError):  # (the supervisor kills it when it restarts it)
                os.kill(frozen_pid, signal.SIGCONT)
            raise
    health = wait_until(lambda: (r := served.get("/api/health")).status_code == 200 and r.json(), timeout=180)
    assert health["robot_pid"] != frozen_pid and health["estop_latched"]
    restarted = wait_until(
        lambda: next((e for e in served.get("/api/events").json() if e["kind"] == "worker/restarted"), None), 10
    )
    assert "after it stopped answering" in restarted["message"] and "e-stop latched" in restarted["message"]
