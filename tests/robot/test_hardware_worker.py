"""The real-robot backend driven through the Protocol 2.0 bus emulator by the real dynamixel-sdk: start-up checks,
torque, postures, limits, the e-stop's controlled stop, and faults (a dead servo, an overheating one)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator

import numpy as np
import pytest

from robot.bodies.hardware import ESTOP_TORQUE_OFF_AFTER_S
from robot.diagnostics.thresholds import Thresholds
from robot.hardware import control_table as ct
from robot.hardware.bus import BusError, DynamixelBus, tick_budget
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.config import ConfigError, default_config, dump_config, load_config
from robot.hardware.worker import HardwareWorker
from robot.interface import EStop, Level, Mode, Posture, Refusal, ReleaseEStop, SetPosture, SetTorque, Teleop
from robot.model import humanoid_v1

# The emulated servos are a process on the same (possibly loaded) machine, which answers when the scheduler lets it:
# a full machine paused it 200 ms at a time, and three late replies in a row at a 100 ms margin made a servo "lost"
# (and the robot stop safely). A late reply here costs the test time only (a servo made silent costs 1 s a read);
# a real servo gets 2 ms. The servos' bus watchdog at its longest (2.5 s, not 0.5 s) but where a test is about it: a
# loaded machine stalled the control loop 756 ms, the servos stopped, and the robot took it for a lost loop.
CONFIG = dataclasses.replace(default_config(), reply_margin_ms=1000.0, bus_watchdog_ms=2500)
# A loaded test machine can pause the control loop longer than the robot's 0.5 s: diagnostics would take it for a
# stalled loop and stop the robot (the first latch then is theirs, not what a test looks for).
DIAGNOSTICS = Thresholds(control_stale_s=3.0)
# Tests that watch the controlled stop's crouch give it the real robot's time before torque goes off: the crouch
# advances by control ticks, and beside stress-ng a fresh-clone CI's loop ticked too few in 1 s for the knee to
# bend visibly before torque went off (the crouch check timed out).
CROUCH_BEFORE_TORQUE_OFF_S = ESTOP_TORQUE_OFF_AFTER_S


def wait(predicate, timeout: float = 30.0):  # generous: a loaded machine
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(0.02)
    raise AssertionError("condition not met in time")


@pytest.fixture
def emulator() -> Iterator[BusEmulator]:
    with BusEmulator([j.servo_id for j in CONFIG.joints]) as bus:
        yield bus


@pytest.fixture
def robot(emulator, layout) -> Iterator[HardwareWorker]:
    # no deadman here (these tests do not heartbeat); tests/app/test_hardware_api.py tests it through the page
    worker = HardwareWorker(
        dataclasses.replace(CONFIG, port=emulator.port_name),
        layout,
        diagnostics=DIAGNOSTICS,
        estop_torque_off_s=1.0,
        deadman_s=0.0,
    )
    worker.start()
    yield worker
    worker.stop()


def sid(joint: str) -> int:
    return next(j.servo_id for j in CONFIG.joints if j.joint == joint)


def torque_on(emulator: BusEmulator) -> list[int]:
    return [emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in CONFIG.joints]


def test_the_configuration_file_round_trips_and_refuses_nonsense(tmp_path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(dump_config(CONFIG))
    assert load_config(path) == CONFIG
    path.write_text(dump_config(CONFIG).replace("id = 13", "id = 14"))
    with pytest.raises(ConfigError, match="servo IDs repeat"):
        load_config(path)
    path.write_text(dump_config(CONFIG).replace("[joints.r_knee]", "[joints.tail]"))
    with pytest.raises(ConfigError, match="unknown joint 'tail'"):
        load_config(path)


def test_the_bus_budget_is_checked_before_anything_moves(emulator, layout) -> None:
    # a tick at 1 Mbps: 134 bytes of goals, 382 of fast read (542 plain), 38 of slow reads; 1.2 ms of USB latency
    assert tick_budget(24, 1_000_000, 100, 1.0).utilisation == pytest.approx(0.674, abs=0.002)
    assert tick_budget(24, 1_000_000, 100, 1.0, fast=False).utilisation == pytest.approx(0.87, abs=0.01)
    assert tick_budget(24, 4_000_000, 100, 1.0).utilisation < 0.35
    slow = dataclasses.replace(CONFIG, port=emulator.port_name, baudrate=115_200)
    with pytest.raises(BusError, match="raise the baud rate"):
        HardwareWorker(slow, layout).start()


def test_a_servo_missing_at_start_up_is_named(emulator, layout) -> None:
    emulator.set_fault(sid("l_ank_roll"), dead=True)
    with pytest.raises(BusError, match=r"no answer from l_ank_roll \(id 18\)"):
        HardwareWorker(dataclasses.replace(CONFIG, port=emulator.port_name), layout).start()


def test_torque_stays_off_until_enabled_then_postures_move_the_servos(robot, emulator) -> None:
    assert robot.state().torque_enabled is False
    assert not any(torque_on(emulator))
    refused = robot.submit(SetPosture(Posture.STAND))
    assert not refused.accepted and "torque is off" in refused.message
    assert robot.submit(SetTorque(True)).accepted
    wait(lambda: all(torque_on(emulator)))
    assert robot.submit(SetPosture(Posture.STAND)).accepted
    knee = humanoid_v1.stand_posture()["r_knee"]
    wait(lambda: abs(emulator.position_rad(sid("r_knee")) - knee) < 0.02)
    # the mirror draws the measured pose
    state = robot.state()
    assert len(state.qpos) == robot.body.scene.model.nq and state.torque_enabled
    assert robot.submit(Teleop(0.1, 0, 0)).refusal == Refusal.UNSUPPORTED


def test_goals_are_clamped_to_the_joint_limits(emulator) -> None:
    bus = DynamixelBus(dataclasses.replace(CONFIG, port=emulator.port_name))
    bus.open()
    try:
        bus.set_torque(True)
        targets = np.zeros(len(CONFIG.joints))
        targets[CONFIG.joint_names.index("head_pan")] = 3.0  # its limit is 1.5 rad
        bus.write_goals(targets)  # a sync write is not answered: wait for the servo to have it
        limit = round(1.5 * ct.POSITION_PER_RAD + ct.POSITION_CENTRE)
        wait(lambda: emulator.read(sid("head_pan"), ct.GOAL_POSITION) != ct.POSITION_CENTRE)
        assert emulator.read(sid("head_pan"), ct.GOAL_POSITION) == limit
    finally:
        bus.close()


@pytest.mark.parametrize("fast", [True, False], ids=["fast-sync-read", "sync-read"])
def test_a_servo_that_stops_answering_is_lost_within_three_ticks(emulator, fast: bool) -> None:
    bus = DynamixelBus(dataclasses.replace(CONFIG, port=emulator.port_name, fast_sync_read=fast))
    bus.open()
    try:
        bus.read()
        emulator.set_fault(sid("r_knee"), dead=True)
        ticks = 0
        while "r_knee" not in bus.read().lost:
            ticks += 1
            assert ticks < 3
        after = bus.read()
        assert after.failed_reads == 0 and after.lost == ("r_knee",)  # the others keep coming
    finally:
        bus.close()


def test_estop_crouches_then_turns_torque_off(robot, emulator) -> None:
    robot.submit(SetTorque(True))
    wait(lambda: robot.state().torque_enabled)
    assert robot.submit(EStop(source="test")).accepted
    wait(lambda: robot.state().mode == Mode.ESTOP)
    # said once the stop's first goals are written to the servos (what `bench core --backend hil` times): standing,
    # they are written as the stop is applied, not at the next tick
    on_bus = wait(lambda: next((e for e in robot.recent_events() if e.kind == "hardware/stop_on_bus"), None))
    assert on_bus.data["after_applied_ms"] <= 0.0 and "on the bus, as the stop was applied" in on_bus.message
    crouch_knee = humanoid_v1.stand_posture(humanoid_v1.CROUCH_KNEE_BEND)["l_knee"]
    wait(lambda: emulator.read(sid("l_knee"), ct.GOAL_POSITION) > ct.POSITION_CENTRE + 100)  # bending
    wait(lambda: not robot.state().torque_enabled)
    assert not any(torque_on(emulator))
    assert crouch_knee > 1.0
    assert robot.submit(SetTorque(True)).refusal == Refusal.ESTOP_LATCHED
    assert robot.submit(ReleaseEStop()).accepted


def test_hardware_errors_and_lost_servos_reach_diagnostics_and_stop_the_robot(robot, emulator) -> None:
    robot.submit(SetTorque(True))
    wait(lambda: robot.state().torque_enabled)
    emulator.set_temperature(sid("l_el"), 85.0)
    hot = wait(lambda: (d := robot.diagnostics()) and (s := d.find("servos/l_el")) and s.level == Level.ERROR and s)
    assert "overheating" in hot.message and hot.hardware_id == "XM430-W350 id 6"
    wait(lambda: robot.state().estop_latched)
    emulator.set_fault(sid("r_hip_roll"), dead=True)
    lost = wait(lambda: (s := robot.diagnostics().find("servos/r_hip_roll")) and s.level == Level.ERROR and s)
    assert lost.message == "not answering on the bus"
    assert any(e.kind == "hardware/servo_lost" for e in robot.recent_events())
    refused = robot.submit(ReleaseEStop())
    assert not refused.accepted and "r_hip_roll" in refused.message


def test_a_corrupted_or_dropped_reply_costs_nothing_but_a_count(emulator) -> None:
    """A glitch on the bus (a CRC error, a lost reply): the fast read fails, the plain read of the same block gets
    every servo's data this very tick, and the glitch is counted for diagnostics."""
    bus = DynamixelBus(dataclasses.replace(CONFIG, port=emulator.port_name))
    bus.open()
    try:
        bus.read()
        emulator.set_fault(sid("l_knee"), corrupt_replies=1)
        reading = bus.read()
        assert reading.failed_reads == 0 and not reading.lost and bus.counters.crc_errors == 1
        emulator.set_fault(sid("r_ank_roll"), drop_replies=1)
        reading = bus.read()
        assert reading.failed_reads == 0 and not reading.lost and bus.counters.crc_errors + bus.counters.timeouts == 2
    finally:
        bus.close()


def test_start_up_sets_the_servos_up_and_torque_arms_their_bus_watchdog(robot, emulator) -> None:
    # shipped servos wait 500 us before each reply (12 ms a tick for 24): start-up sets it to none
    assert all(emulator.read(j.servo_id, ct.RETURN_DELAY_TIME) == 0 for j in CONFIG.joints)
    setup = next(e for e in robot.recent_events() if e.kind == "hardware/setup")
    assert len(setup.data["changes"]) == len(CONFIG.joints)
    assert emulator.read(sid("r_knee"), ct.BUS_WATCHDOG) == 0
    robot.submit(SetTorque(True))
    wait(lambda: robot.state().torque_enabled)
    assert all(emulator.read(j.servo_id, ct.BUS_WATCHDOG) == CONFIG.bus_watchdog_ms // 20 for j in CONFIG.joints)


def test_a_stalled_control_loop_is_stopped_by_the_servos_then_crouches_and_turns_torque_off(emulator, layout) -> None:
    """The control loop hangs for 300 ms, past the servos' bus watchdog (set to 100 ms here): the servos stop
    where they are on their own; when the loop comes back it takes that as a loss of control: e-stop, crouch,
    torque off."""
    config = dataclasses.replace(CONFIG, port=emulator.port_name, bus_watchdog_ms=100)
    robot = HardwareWorker(
        config, layout, diagnostics=DIAGNOSTICS, estop_torque_off_s=CROUCH_BEFORE_TORQUE_OFF_S, deadman_s=0.0
    )
    robot.start()
    try:
        robot.submit(SetTorque(True))
        wait(lambda: robot.state().torque_enabled)
        assert emulator.read(sid("r_knee"), ct.BUS_WATCHDOG) == 5
        real_read = robot.bus.read
        stalls = [0.3]

        def stalling_read():
            if stalls:
                time.sleep(stalls.pop())
            return real_read()

        robot.bus.read = stalling_read
        tripped = wait(lambda: next((e for e in robot.recent_events() if e.kind == "hardware/watchdog"), None))
        assert len(tripped.data["joints"]) == len(CONFIG.joints) and tripped.data["gap_ms"] >= 250
        wait(lambda: robot.state().estop_latched)  # (the state is published at the end of the tick)
        latched = next(e for e in robot.recent_events() if e.kind == "estop/latched")
        assert latched.data["source"] == "watchdog" and "stalled" in latched.data["reason"]
        wait(lambda: emulator.read(sid("l_knee"), ct.GOAL_POSITION) > ct.POSITION_CENTRE + 100)  # crouching again
        wait(lambda: not robot.state().torque_enabled)
        assert not any(torque_on(emulator))
    finally:
        robot.stop()


def test_a_robot_process_started_on_servos_left_holding_takes_them_over_then_makes_the_controlled_stop(
    emulator, layout
) -> None:
    """The robot process before this one died with torque on: the servos' watchdog stopped them and they hold the
    robot up. The new process must not drop it (turning torque off to set the servos up): it holds them where they
    stand, then crouches and turns torque off, as its own e-stop would."""
    config = dataclasses.replace(CONFIG, port=emulator.port_name, bus_watchdog_ms=100)
    first = HardwareWorker(config, layout, diagnostics=DIAGNOSTICS, estop_torque_off_s=1.0, deadman_s=0.0)
    first.start()
    first.submit(SetTorque(True))
    wait(lambda: first.state().torque_enabled)
    first.loop.stop(timeout_s=2)  # the process dies: no controlled stop, no torque off, the port just goes quiet
    first.bus.close()
    wait(lambda: all(emulator.read(j.servo_id, ct.BUS_WATCHDOG) == -1 for j in CONFIG.joints))  # tripped
    assert all(torque_on(emulator))
    second = HardwareWorker(
        config, layout, diagnostics=DIAGNOSTICS, estop_torque_off_s=CROUCH_BEFORE_TORQUE_OFF_S, deadman_s=0.0
    )
    second.start()
    try:
        takeover = next(e for e in second.recent_events() if e.kind == "hardware/takeover")
        assert len(takeover.data["joints"]) == len(CONFIG.joints)
        assert all(torque_on(emulator))  # not dropped
        assert not any(e.kind == "hardware/setup" for e in second.recent_events())
        wait(lambda: second.state().estop_latched)
        wait(lambda: emulator.read(sid("l_knee"), ct.GOAL_POSITION) > ct.POSITION_CENTRE + 100)  # crouching
        wait(lambda: not second.state().torque_enabled)
        assert not any(torque_on(emulator))
    finally:
        second.stop()


def test_a_sustained_load_is_said_as_the_servos_smoothed_load(robot, emulator) -> None:
    """A servo's load in diagnostics is averaged over about a second, as the simulation's: a walking step's current
    spike is no alarm, a load held is."""
    assert robot.submit(SetTorque(True)).accepted
    emulator.set_load(sid("r_knee"), 3.8)  # 93 % of the XM430's stall torque, held
    seen: list[float] = []

    def warned():
        status = robot.sample_diagnostics().find("servos/r_knee")
        seen.append(dict(status.values)["load_pct"])
        return status.level == Level.WARN and "heavily loaded" in status.message

    wait(warned)
    assert any(20.0 < load < 80.0 for load in seen)  # it rose to the alarm, not jumped
    assert 80.0 <= seen[-1] <= 93.0
