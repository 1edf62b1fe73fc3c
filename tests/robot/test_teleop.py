"""Teleop, postures, e-stop while walking, falls and reset, through the worker's public interface only."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest

from robot.interface import (
    CancelPlan,
    EStop,
    Event,
    ExecutePlan,
    Mode,
    Posture,
    Refusal,
    ResetRobot,
    RobotState,
    RunCommand,
    SetPosture,
    StopTeleop,
    Teleop,
)
from tests.robot.test_worker import wait_event


def _drive(worker, command: Teleop, until, timeout_s: float = 60.0, period_s: float = 0.1) -> tuple[float, RobotState]:
    """Send the teleop command repeatedly, as the browser does while a key is held, until `until(state)` holds for
    the state read after a send (or `timeout_s` passes, however busy the machine). Returns the wall time read just
    before the last send (the deadman counts from the command's arrival, never before it) and the state read just
    after it."""
    deadline = time.monotonic() + timeout_s
    while True:
        sent = time.time()
        assert worker.submit(command).accepted
        state = worker.state()
        if until(state) or time.monotonic() >= deadline:
            return sent, state
        time.sleep(period_s)


def _forward_of_start(start: RobotState, state: RobotState) -> float:
    dx, dy = state.base_position[0] - start.base_position[0], state.base_position[1] - start.base_position[1]
    return math.cos(start.base_yaw_rad) * dx + math.sin(start.base_yaw_rad) * dy


def _last(events: list[Event], kind: str) -> Event:
    return next(e for e in reversed(events) if e.kind == kind)


def test_teleop_walks_forward_and_the_deadman_stops_it(make_worker) -> None:
    worker = make_worker(realtime=True)
    start = worker.state()
    # held until it walked, however busy (past the 0.2 m asserted below: the trunk sways as it steps)
    last_input, state = _drive(worker, Teleop(vx=0.12, source="test"), lambda s: _forward_of_start(start, s) > 0.25)
    assert state.mode == Mode.TELEOP and state.locomotion.phase == "walking"
    assert state.locomotion.footsteps and state.locomotion.com is not None  # what the mirror draws
    assert _forward_of_start(start, state) > 0.2
    # input stops: within 300 ms the deadman stops the walk, then the robot stands and teleop ends
    assert worker.wait_for(lambda s: s.mode == Mode.IDLE, 30.0)
    # the last deadman and end: a loaded machine can pause the sends past the deadman mid-drive (the walk then
    # stops, and the next send starts it again), but none comes after the last send's
    events = worker.recent_events()
    deadman, ended = _last(events, "teleop/deadman"), _last(events, "teleop/ended")
    # never before 300 ms of silence, then at once in the robot's time: the control loop paces simulated time by
    # the wall clock, so it walks at most about 300 ms of it on the old input however long a loaded machine pauses
    # the loop (how soon in real time is `humanoid bench` business)
    assert deadman.wall_time_s - last_input >= 0.3
    assert deadman.sim_time_s - state.sim_time_s < 1.0
    # decelerate, two steps in place, stand: no walking on. Alone 2.1-2.35 s of simulated time (6 runs); once, under
    # the suite's load, 3.2 s (the gait planner's process answers the stop a few periods late, and a late plan is
    # walked along the current one, up to 1 s ahead); walking out the old 8-step plan took about 5 s.
    assert 0.0 < ended.sim_time_s - deadman.sim_time_s < 4.5
    state = worker.state()
    assert state.mode == Mode.IDLE and state.locomotion.phase == "standing" and not state.fallen
    assert state.locomotion.footsteps == ()


def test_teleop_and_plans_are_mutually_exclusive(make_worker) -> None:
    worker = make_worker(realtime=True)
    long_say = {"steps": [{"action": "say", "args": {"text": "one two three four five six seven eight nine ten"}}]}
    assert worker.submit(ExecutePlan(long_say)).accepted
    assert worker.wait_for(lambda s: s.mode == Mode.EXECUTING, 30.0)
    refused = worker.submit(Teleop(vx=0.1))
    assert not refused.accepted and refused.refusal == Refusal.BUSY
    worker.submit(CancelPlan())
    assert worker.wait_for(lambda s: s.mode == Mode.IDLE, 30.0)
    assert worker.submit(Teleop(vx=0.1)).accepted
    assert worker.wait_for(lambda s: s.mode == Mode.TELEOP, 30.0)
    refused = worker.submit(RunCommand("say hello"))
    assert not refused.accepted and refused.refusal == Refusal.BUSY
    refused = worker.submit(SetPosture(Posture.CROUCH))
    assert not refused.accepted and refused.refusal == Refusal.BUSY
    worker.submit(StopTeleop(source="test"))
    assert worker.wait_for(lambda s: s.mode == Mode.IDLE, 30.0)
    assert worker.submit(RunCommand("say hello")).accepted


def test_bad_teleop_input_is_refused(make_worker) -> None:
    worker = make_worker(realtime=False)
    reply = worker.submit(Teleop(vx=float("nan")))
    assert not reply.accepted and reply.refusal == Refusal.INVALID
    reply = worker.submit(Teleop(vx=5.0))  # accepted, clipped to the walking limits
    assert reply.accepted and "vx 0.20" in reply.message


def test_estop_mid_stride_stops_the_walk_and_leaves_it_standing(make_worker) -> None:
    worker = make_worker(realtime=True)
    stop_driving = threading.Event()

    def drive() -> None:
        while not stop_driving.is_set():
            worker.submit(Teleop(vx=0.15, source="test"))
            time.sleep(0.1)

    driver = threading.Thread(target=drive, daemon=True)
    driver.start()
    try:
        assert worker.wait_for(lambda s: s.locomotion.phase == "walking", 30.0)
        walking_at = worker.state().sim_time_s
        assert worker.wait_for(lambda s: s.sim_time_s >= walking_at + 1.5, 30.0)  # into its stride
        assert worker.wait_for(lambda s: s.locomotion.support in ("left", "right"), 30.0)  # one foot in the air
        assert worker.submit(EStop(source="test")).accepted
        refused = worker.submit(Teleop(vx=0.15))
        assert not refused.accepted and refused.refusal == Refusal.ESTOP_LATCHED
    finally:
        stop_driving.set()
        driver.join()
    assert worker.wait_for(lambda s: s.locomotion.phase == "standing", 30.0)
    stood_at = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s >= stood_at + 1.0, 30.0)  # and stays standing
    state = worker.state()
    assert state.mode == Mode.ESTOP and not state.fallen and state.tilt_deg < 10.0
    assert state.locomotion.velocity == (0.0, 0.0, 0.0)


def test_crouch_and_stand_postures(make_worker) -> None:
    worker = make_worker(realtime=False)
    stand_height = worker.state().base_position[2]
    assert worker.submit(SetPosture(Posture.CROUCH)).accepted
    assert worker.wait_for(lambda s: s.locomotion.posture == "crouch", 10.0)
    assert worker.wait_for(lambda s: s.sim_time_s > 3.0, 10.0)
    crouched = worker.state()
    # 1.8 cm lower: standing, the walk's solver already holds the trunk 7.6 mm low (the arms at rest raise the CoM)
    assert crouched.base_position[2] < stand_height - 0.015 and not crouched.fallen
    assert worker.submit(SetPosture(Posture.STAND)).accepted
    assert worker.wait_for(lambda s: s.locomotion.posture == "stand", 10.0)
    # and stays standing: rising too fast, the robot pitched 15 degrees and fell a second after the legs got there
    risen = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s > risen + 1.5, 10.0)
    standing = worker.state()
    assert not standing.fallen and standing.tilt_deg < 5.0
    assert standing.base_position[2] == pytest.approx(stand_height, abs=0.01)


def test_a_fall_is_detected_reported_and_reset_puts_it_back_standing(make_worker) -> None:
    worker = make_worker(realtime=False)
    events = worker.subscribe()
    start = worker.state()
    trunk = worker.backend.model.body("body_link").id
    worker.backend.data.xfrc_applied[trunk, 0] = 60.0  # a hard shove from behind (test access to the sim)
    fell = wait_event(events, "robot/fell", timeout=10.0)
    worker.backend.data.xfrc_applied[trunk, 0] = 0.0
    assert fell.level >= 2
    assert worker.wait_for(lambda s: s.mode == Mode.FALLEN, 2.0)
    refused = worker.submit(Teleop(vx=0.1))
    assert not refused.accepted
    assert worker.submit(ResetRobot()).accepted
    wait_event(events, "robot/reset", timeout=5.0)
    reset_at = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s > reset_at + 1.0, 10.0)
    state = worker.state()
    assert state.mode == Mode.IDLE and not state.fallen and state.tilt_deg < 3.0
    assert np.allclose(state.base_position[:2], start.base_position[:2], atol=0.02)
    assert worker.submit(Teleop(vx=0.1)).accepted
