"""The robot core with a body it has never seen: a made-up one with joints and nothing else (no IMU, no camera, no
bus), as a new sensor driver or a hardware-in-the-loop rig would plug in. The same loop, latch, arbiter, publisher
and command table drive it; what it lacks is refused with its own reason. Then the units alone, with fakes."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from robot.config import RobotConfig
from robot.control.locomotion import Velocity
from robot.control.stats import LoopStats
from robot.core.body import BodyLinks, BodySnapshot, CommandHandler, Senses
from robot.core.inbox import TELEOP_TIMEOUT_S, MotionInbox
from robot.core.loop import ControlLoop
from robot.core.measurements import Measurements
from robot.core.safety import LatchWords, SafetyLatch
from robot.diagnostics.robot_sources import RobotReadings
from robot.diagnostics.thresholds import Thresholds
from robot.hardware.xm430 import ServoReadings
from robot.interface import (
    CommandReply,
    DiagnosticStatus,
    EStop,
    Level,
    Mode,
    OperatorHeartbeat,
    PerceptionState,
    Posture,
    Refusal,
    ReleaseEStop,
    RunCommand,
    SensorFeed,
    SetPosture,
    Teleop,
)
from robot.model import humanoid_v1
from robot.robot import Robot

NAMES = humanoid_v1.JOINT_NAMES
LACKS = "needs legs that balance, and this test body has none"


class JointsOnlyBody:
    """Joints that go where they are told, a clock of ticks, and nothing else."""

    kind = "test body"
    resettable = False
    senses = Senses(imu=False, foot_sensors=False)
    lacks = LACKS
    latch_words = LatchWords(latched="e-stop latched: freezing")
    physics_hz = 0.0
    stop_by_tick = False
    perception = None
    telemetry = None
    tick_guard = None
    connected = True

    def __init__(self, dt: float = 0.01) -> None:
        self.joint_names = NAMES
        self.dt = dt
        self.ticks = 0
        self.positions = np.array([humanoid_v1.stand_posture()[n] for n in NAMES])
        self.sent: list[np.ndarray] = []  # each tick's targets, as the actuators got them
        self.held_now: list[np.ndarray] = []
        self.fail_ticks = 0  # this many ticks raise, as a driver bug would
        self.links: BodyLinks | None = None

    def bind(self, links: BodyLinks) -> None:
        self.links = links

    def now(self) -> float:
        return self.ticks * self.dt

    def stand_posture(self) -> np.ndarray:
        return self.positions.copy()

    def crouch_posture(self) -> np.ndarray:
        return np.array([humanoid_v1.crouch_posture()[n] for n in NAMES])

    def stop_posture(self) -> tuple[np.ndarray, float] | None:
        return None

    def stop_action(self, walking: bool) -> str:
        return "freezing"

    def motion_refusal(self) -> CommandReply | None:
        return None

    def commands(self) -> dict[type, CommandHandler]:
        return {OperatorHeartbeat: lambda command: CommandReply(True, "heard")}

    def start(self) -> None:
        pass

    def before_shutdown(self) -> None:
        pass

    def close(self) -> None:
        pass

    def place(self, stand: np.ndarray) -> Measurements:
        self.positions = stand.copy()
        return self.latest()

    def reset(self, stand: np.ndarray) -> Measurements:
        raise NotImplementedError

    def before_tick(self) -> None:
        if self.fail_ticks > 0:
            self.fail_ticks -= 1
            raise RuntimeError("driver bug")

    def apply_requests(self) -> None:
        pass

    def sense(self) -> Measurements:
        return self.latest()

    def latest(self) -> Measurements:
        nan3 = np.full(3, np.nan)
        return Measurements(
            self.now(),
            self.positions.copy(),
            np.zeros(len(NAMES)),
            np.array([0.0, 0.0, 0.3]),
            np.array([1.0, 0.0, 0.0, 0.0]),
            np.full(4, np.nan),
            nan3,
            nan3,
            np.full((2, 4), np.nan),
        )

    def actuate(self, targets: np.ndarray) -> Measurements:
        self.sent.append(targets.copy())
        self.positions = targets.copy()
        self.ticks += 1
        return self.latest()

    def hold_now(self, targets: np.ndarray) -> None:
        self.held_now.append(targets.copy())

    def stop_applied(self) -> None:
        pass

    def after_tick(self, targets: np.ndarray, tick_s: float) -> None:
        pass

    def snapshot(self, measured: Measurements) -> BodySnapshot:
        return BodySnapshot((0.0, 0.0, 0.3), 0.0, 0.0, False, tuple(measured.joint_positions.tolist()))

    def tick_error(self, exc: Exception) -> bool:
        return False

    def after_safe_stop(self) -> None:
        pass

    def readings(
        self,
        stats: LoopStats,
        perception: Callable[[], PerceptionState | None],
        sensor_feed: Callable[[], SensorFeed],
        voice: Callable[[], Any],
    ) -> RobotReadings:
        n = len(NAMES)
        zeros = np.zeros(n)
        servos = ServoReadings(zeros, zeros, zeros + 12.0, zeros, zeros, np.zeros(n, dtype=np.int64))
        return RobotReadings(
            joint_names=NAMES,
            stats=stats,
            servos=lambda: servos,
            power=lambda: None,
            battery_cells=0,
            perception=lambda: None,
            sensor_feed=SensorFeed,
            sim_time=self.now,
            imu_stamp=lambda: None,
            voice=lambda: None,
            sensor_hz=0.0,
            has_imu=False,
        )


@pytest.fixture
def body() -> JointsOnlyBody:
    return JointsOnlyBody()


@pytest.fixture
def robot(body: JointsOnlyBody, layout) -> Iterator[Robot]:
    config = RobotConfig(realtime=False, perception=False, diagnostics=Thresholds(control_stale_s=30.0))
    robot = Robot(body, layout, config)
    robot.start()
    yield robot
    robot.stop()


def test_a_new_body_is_driven_by_the_same_core_and_refuses_what_it_lacks_with_its_reason(robot, body) -> None:
    assert robot.wait_for(lambda s: s.sim_time_s > 0.05, 10.0)
    assert robot.submit(OperatorHeartbeat()).message == "heard"  # the body's own command
    teleop = robot.submit(Teleop(0.1, 0.0, 0.0))
    assert teleop.refusal == Refusal.UNSUPPORTED and teleop.message == f"Teleop {LACKS}"
    plan = robot.submit(RunCommand("say hello"))
    assert plan.refusal == Refusal.UNSUPPORTED and LACKS in plan.message
    assert robot.describe().planner == "none (test body)"

    assert robot.submit(SetPosture(Posture.CROUCH)).accepted
    crouch = body.crouch_posture()
    assert robot.wait_for(lambda s: s.sim_time_s > 0 and np.allclose(body.positions, crouch, atol=1e-6), 20.0)
    # the body is there; the state it publishes says so from the next tick on
    assert robot.wait_for(lambda s: np.allclose(s.qpos, crouch, atol=1e-6), 20.0)
    assert robot.state().mode == Mode.IDLE


def test_the_e_stop_freezes_the_joints_at_once_refuses_motion_and_is_released_by_the_rules(robot, body) -> None:
    assert robot.submit(SetPosture(Posture.CROUCH)).accepted
    assert robot.wait_for(lambda s: s.sim_time_s > 0.1, 10.0)
    reply = robot.submit(EStop(source="test", reason="a test"))
    assert reply.accepted and reply.message == "e-stop latched: freezing"
    assert robot.wait_for(lambda s: s.mode == Mode.ESTOP, 10.0)
    latched = next(e for e in robot.recent_events() if e.kind == "estop/latched")
    assert latched.message == "E-STOP latched (test) because a test: freezing" and latched.data["source"] == "test"
    assert body.held_now, "the frozen targets go out when the stop is applied, not at the next tick"
    frozen = body.held_now[0]
    ticks = len(body.sent)
    assert robot.wait_for(lambda s: len(body.sent) > ticks + 20, 10.0)
    assert all(np.allclose(sent, frozen) for sent in body.sent[ticks + 1 :])  # nothing moves while latched
    refused = robot.submit(SetPosture(Posture.STAND))
    assert refused.refusal == Refusal.ESTOP_LATCHED and "release it first" in refused.message
    assert robot.submit(ReleaseEStop(source="test")).accepted
    assert robot.submit(ReleaseEStop(source="test")).refusal == Refusal.NOT_LATCHED
    assert robot.submit(SetPosture(Posture.STAND)).accepted


def test_a_failing_tick_latches_the_e_stop_and_is_said_once_while_it_keeps_failing(robot, body) -> None:
    body.fail_ticks = 50
    assert robot.wait_for(lambda s: s.estop_latched, 10.0)
    assert robot.wait_for(lambda s: body.fail_ticks == 0 and len(body.sent) > 10, 20.0)
    errors = [e for e in robot.recent_events() if e.kind == "control/error"]
    assert len(errors) == 1 and "driver bug" in errors[0].message
    latched = [e for e in robot.recent_events() if e.kind == "estop/latched"]
    assert len(latched) == 1 and latched[0].data["source"] == "control-error"
    assert robot.is_alive()  # the loop survived


# ---------------------------------------------------------------------------------------------------------------
# the units alone


def _latch(unsafe: list[DiagnosticStatus]) -> tuple[SafetyLatch, list[tuple[str, str]]]:
    said: list[tuple[str, str]] = []
    latch = SafetyLatch(threading.RLock(), lambda kind, message, *a, **k: said.append((kind, message)), lambda: unsafe)
    return latch, said


def test_the_latch_is_released_only_once_applied_and_safe_and_runs_its_hooks() -> None:
    unsafe: list[DiagnosticStatus] = []
    latch, said = _latch(unsafe)
    hooks: list[str] = []
    latch.on_latch(lambda: hooks.append("latched"))
    latch.on_release(lambda: hooks.append("released"))
    assert latch.refusal() is None
    assert latch.latch(EStop(source="test")).accepted and latch.latched
    assert latch.latch(EStop(source="again")).message == "e-stop already latched"
    assert hooks == ["latched"]
    assert latch.refusal().refusal == Refusal.ESTOP_LATCHED
    applying = latch.release(ReleaseEStop())
    assert not applying.accepted and "still being applied" in applying.message
    command, _ = latch.take_pending()
    assert command.source == "test" and latch.take_pending() is None
    unsafe.append(DiagnosticStatus("servos/r_knee", Level.ERROR, "overheating"))
    blocked = latch.release(ReleaseEStop())
    assert not blocked.accepted and "servos/r_knee: overheating" in blocked.message
    unsafe.clear()
    assert latch.release(ReleaseEStop(source="op")).accepted and not latch.latched
    assert hooks == ["latched", "released"]
    assert ("estop/released", "E-STOP released (op); the robot stays still until the next command") in said


def test_a_fallen_robot_refuses_motion_and_a_safe_stop_then_does_nothing_more() -> None:
    latch, said = _latch([])
    latch.fall()
    assert "fallen" in latch.refusal().message
    latch.safe_stop("servo overheating")
    assert not latch.latched and said == []  # already down: no stop to make
    latch.stand_up()
    latch.safe_stop("servo overheating")
    assert latch.latched and said[0][0] == "diagnostics/safe_stop"


def test_the_inbox_gives_the_plan_or_the_operator_and_its_deadman_stops_teleop_once() -> None:
    now = [0.0]
    inbox = MotionInbox(threading.RLock(), lambda: now[0])
    assert inbox.teleop(Velocity(0.1, 0.0, 0.0)) and not inbox.teleop(Velocity(0.1, 0.0, 0.0))
    inbox.drive(Velocity(0.0, 0.0, 0.4))
    assert inbox.take(plan_running=False, latched=False) == (Velocity(0.1, 0.0, 0.0), False, False)
    assert inbox.take(plan_running=True, latched=False)[0] == Velocity(0.0, 0.0, 0.4)
    assert inbox.take(plan_running=False, latched=True)[0] == Velocity()
    now[0] = TELEOP_TIMEOUT_S + 0.01
    assert inbox.take(plan_running=False, latched=False) == (Velocity(), True, True)  # the deadman, said once
    assert inbox.take(plan_running=False, latched=False) == (Velocity(), False, False)
    assert inbox.teleop_ended() and not inbox.teleop_ended()


def test_teleop_input_back_after_the_deadman_is_a_start_again_and_steady_input_is_not() -> None:
    now = [0.0]
    inbox = MotionInbox(threading.RLock(), lambda: now[0])
    assert inbox.teleop(Velocity(0.1, 0.0, 0.0))
    now[0] = TELEOP_TIMEOUT_S + 0.01
    assert inbox.take(plan_running=False, latched=False)[2]  # the deadman stops the walk ...
    assert inbox.teleop(Velocity(0.1, 0.0, 0.0))  # ... input back before it has ended: the walk resumes, said
    assert inbox.take(plan_running=False, latched=False) == (Velocity(0.1, 0.0, 0.0), False, False)
    assert not inbox.teleop(Velocity(0.1, 0.0, 0.0))
    assert inbox.release_teleop() and inbox.teleop(Velocity(0.1, 0.0, 0.0))  # after a release, too


def test_the_loop_survives_a_failing_tick_and_wakes_early_for_a_stop() -> None:
    ticks: list[int] = []
    errors: list[Exception] = []
    woken = threading.Event()

    def tick() -> None:
        ticks.append(1)
        if len(ticks) == 3:
            raise RuntimeError("third tick")

    # 2 Hz: a wake-up is seen long before the next deadline
    loop = ControlLoop(2.0, True, tick, errors.append, lambda *a, **k: None, on_wake=woken.set)
    loop.start()
    try:
        loop.wake()
        assert woken.wait(5.0)
        headless = ControlLoop(100.0, False, tick, errors.append, lambda *a, **k: None)
        headless.start()
        deadline = time.monotonic() + 10.0
        while len(ticks) < 10 and time.monotonic() < deadline:
            time.sleep(0.01)
        headless.stop()
        assert len(ticks) >= 10 and [str(e) for e in errors] == ["third tick"]
        assert headless.stats.tick_count >= 9 and not headless.is_alive()
    finally:
        loop.stop()


def test_a_body_that_stops_with_a_tick_is_ticked_as_soon_as_the_stop_wakes_the_loop() -> None:
    """The real robot's stop reaches its servos only with a tick's write: woken by an e-stop, the loop ticks at
    once rather than at its next deadline (here 100 s away), then keeps its pace from there."""
    ticks: list[float] = []
    woken = threading.Event()
    loop = ControlLoop(
        0.01,
        True,
        lambda: ticks.append(time.monotonic()),
        lambda exc: None,
        lambda *a, **k: None,
        on_wake=woken.set,
        tick_on_wake=True,
    )
    loop.start()
    try:
        loop.wake()
        assert woken.wait(30.0)
        deadline = time.monotonic() + 30.0
        while not ticks and time.monotonic() < deadline:
            time.sleep(0.01)
        assert len(ticks) == 1
    finally:
        loop.stop()
