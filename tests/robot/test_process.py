"""The worker in its own process behaves like the in-process one through the same interface."""

from __future__ import annotations

import time

import psutil
import pytest

from robot.interface import EStop, Fault, InjectFault, Level, Mode, PlanState, Refusal, ReleaseEStop, RunCommand
from robot.process import BUSY_SILENCE_S, FreezeWatch, WorkerProcess


@pytest.fixture(scope="module")
def remote():
    worker = WorkerProcess(seed=0)
    worker.start()
    yield worker
    worker.stop()


def test_commands_state_and_events_cross_the_process_boundary(remote) -> None:
    events = remote.subscribe()
    reply = remote.submit(RunCommand("say hello across processes"))
    assert reply.accepted and reply.plan.steps[0].action == "say"
    assert remote.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.SUCCEEDED, 15.0)
    kinds = []
    while (event := events.get(timeout=0.2)) is not None:
        kinds.append(event.kind)
    assert {"command/received", "plan/created", "speech/say", "plan/finished"} <= set(kinds)
    assert "control/priority" in {e.kind for e in remote.recent_events()}
    assert "op3" in remote.describe().mjcf_xml.lower()


def test_invalid_command_is_refused_across_the_boundary(remote) -> None:
    reply = remote.submit(RunCommand("pick up the purple elephant"))
    assert not reply.accepted and reply.refusal == Refusal.INVALID


def test_estop_latches_in_the_child(remote) -> None:
    reply = remote.submit(EStop(source="test", client_time_s=time.time()))
    assert reply.accepted
    assert remote.wait_for(lambda s: s.mode == Mode.ESTOP, 5.0)
    assert remote.submit(RunCommand("say hi")).refusal == Refusal.ESTOP_LATCHED
    assert remote.submit(ReleaseEStop()).accepted
    assert remote.wait_for(lambda s: s.mode == Mode.IDLE, 5.0)


def test_a_stopped_worker_refuses_clearly() -> None:
    worker = WorkerProcess(seed=1)
    worker.start()
    worker.stop()
    reply = worker.submit(RunCommand("say hi"))
    assert not reply.accepted and reply.refusal == Refusal.UNAVAILABLE


def test_liveness_follows_the_child_process() -> None:
    worker = WorkerProcess(seed=2)
    assert not worker.is_alive()
    worker.start()
    assert worker.is_alive()
    worker._process.kill()  # a crash, as the OS would report it
    worker._process.join(timeout=5)
    assert not worker.is_alive()
    assert worker.submit(RunCommand("say hi")).refusal == Refusal.UNAVAILABLE
    worker.stop()


def test_a_restarted_robot_is_latched_from_its_first_state_and_refuses_to_move_until_released() -> None:
    """After a crash the supervisor restarts the robot with the e-stop latched: not a tick later, when a command
    could already have reached it, but before it answers anything."""
    worker = WorkerProcess(seed=3, perception=False)
    worker.start()
    try:
        first_pid = worker.pid
        worker.restart(EStop(source="supervisor", reason="the robot process was restarted after it died"))
        assert worker.pid != first_pid
        assert worker.state().estop_latched  # the very first state the server sees
        refused = worker.submit(RunCommand("walk forward 0.2 m"))
        assert not refused.accepted and refused.refusal == Refusal.ESTOP_LATCHED
        assert worker.submit(ReleaseEStop(source="test")).accepted
    finally:
        worker.stop()


def test_diagnostics_and_faults_cross_the_process_boundary(remote) -> None:
    deadline = time.monotonic() + 10
    while remote.diagnostics() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    first = remote.diagnostics()
    assert first is not None and len([s for s in first.statuses if s.group == "servos"]) == 24
    assert remote.submit(InjectFault(Fault.BATTERY_SOC, value=0.15)).accepted
    while time.monotonic() < deadline + 5:
        battery = remote.diagnostics().find("power/battery")
        if battery.level == Level.WARN:
            break
        time.sleep(0.1)
    assert battery.level == Level.WARN and "battery low" in battery.message
    refused = remote.submit(InjectFault(Fault.SERVO_HEAT, target="antenna", value=10))
    assert not refused.accepted and refused.refusal == Refusal.INVALID and "no servo drives" in refused.message


class _Probe:
    """A process as `FreezeWatch` sees it: its state and the CPU seconds it has used, set by the test."""

    def __init__(self) -> None:
        self.status, self.cpu_s = "sleeping", 1.0

    def __call__(self, pid: int | None) -> tuple[str, float]:
        return self.status, self.cpu_s


def test_a_silent_process_is_frozen_only_when_stopped_or_using_no_cpu_and_a_busy_one_is_slow() -> None:
    probe, now = _Probe(), [100.0]
    watch = FreezeWatch(probe, clock=lambda: now[0])
    heard = 100.0

    def silent_after(seconds: float) -> float:
        now[0] = heard + seconds
        return watch.silent_for_s(4242, heard)

    assert silent_after(0.3) == 0.0  # answering
    # silent and busy (an import holding the interpreter lock, a loaded machine): slow, not frozen
    assert silent_after(0.7) == 0.0
    probe.cpu_s += 0.2
    assert silent_after(1.2) == 0.0
    # then silent and using no CPU for a whole window: frozen (a deadlock)
    assert silent_after(1.4) == 0.0  # not yet a whole window since it was last found busy
    assert silent_after(1.6) == pytest.approx(1.6)
    # it answers again: no longer silent; then stopped (SIGSTOP): frozen at once
    heard = 110.0
    assert silent_after(0.2) == 0.0
    probe.status = psutil.STATUS_STOPPED
    assert silent_after(0.7) == pytest.approx(0.7)
    # busy but silent for very long (a loop that never lets go): not answering either
    probe.status = "running"
    heard = 200.0
    for seconds in (0.7, 5.0, 10.0):
        probe.cpu_s += 1.0
        assert silent_after(seconds) == 0.0
    assert silent_after(BUSY_SILENCE_S + 1) == pytest.approx(BUSY_SILENCE_S + 1)
