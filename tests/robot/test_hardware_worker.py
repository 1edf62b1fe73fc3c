"""The real-robot backend driven through the Protocol 2.0 bus emulator by the real dynamixel-sdk: start-up checks,
torque, postures, limits, the e-stop's controlled stop, and faults (a dead servo, an overheating one)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator

import numpy as np
import pytest

from robot.hardware import control_table as ct
from robot.hardware.bus import BusError, DynamixelBus, tick_budget
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.config import ConfigError, default_config, dump_config, load_config
from robot.hardware.worker import HardwareWorker
from robot.interface import EStop, Level, Mode, Posture, Refusal, ReleaseEStop, SetPosture, SetTorque, Teleop
from robot.model import humanoid_v1

# The emulator answers when the scheduler lets it: a busy test machine needs more than the 2 ms a real servo gets.
CONFIG = dataclasses.replace(default_config(), reply_margin_ms=100.0)


def wait(predicate, timeout: float = 5.0):
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
    worker = HardwareWorker(dataclasses.replace(CONFIG, port=emulator.port_name), layout, estop_torque_off_s=1.0)
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
    assert tick_budget(24, 1_000_000, 100, 1.0).utilisation == pytest.approx(0.87, abs=0.02)
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
    wait(lambda: abs(emulator.position_rad(sid("r_knee")) - knee) < 0.02, timeout=8)
    # the mirror draws the measured pose
    state = robot.state()
    assert len(state.qpos) == robot._scene.model.nq and state.torque_enabled
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


def test_a_servo_that_stops_answering_is_lost_within_three_ticks(emulator) -> None:
    bus = DynamixelBus(dataclasses.replace(CONFIG, port=emulator.port_name))
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
    crouch_knee = humanoid_v1.stand_posture(humanoid_v1.CROUCH_KNEE_BEND)["l_knee"]
    wait(lambda: emulator.read(sid("l_knee"), ct.GOAL_POSITION) > ct.POSITION_CENTRE + 100)  # bending
    wait(lambda: not robot.state().torque_enabled, timeout=4)
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
