"""The hardware-in-the-loop rig: the real-robot code (`HardwareWorker`, the Dynamixel SDK, the sensor boards'
drivers) drives the simulated robot through the byte-level emulators, and cannot tell it from the robot. The rig
runs in lockstep here (one control period of physics per tick of the host), so a busy machine is slower, not
different."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Iterator

import numpy as np
import pytest

from robot.hardware.bus import DynamixelBus
from robot.hardware.bus_sensors import BusSensors
from robot.hardware.config import default_config
from robot.hardware.worker import HardwareWorker
from robot.hil.rig import HilRig, rig_config
from robot.interface import EStop, Level, SetTorque, Teleop
from robot.model.world import generate_world
from robot.sensors.imu import rpy_from_quat

SEED = 1
CONFIG = rig_config(lockstep=True)


def wait(predicate, timeout: float = 120.0, every=None):  # generous: a loaded machine
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if every is not None:
            every()
        if value := predicate():
            return value
        time.sleep(0.05)
    raise AssertionError("condition not met in time")


@pytest.fixture
def rig() -> Iterator[HilRig]:
    with HilRig(generate_world(SEED), CONFIG, lockstep=True) as rig:
        yield rig


def test_the_servos_move_the_simulated_joints_and_the_boards_sense_the_simulated_trunk(rig) -> None:
    bus = DynamixelBus(dataclasses.replace(CONFIG, port=rig.port_name))
    bus.open()
    try:
        assert all(s.model is not None for s in bus.ping_all())
        bus.prepare()
        boards = BusSensors(bus.port, bus.packets, imu=True, feet=True, clock=time.monotonic)
        assert boards.probe() == []
        standing = bus.read().positions
        assert rig.truth().on_stand  # hanging still until torque comes on: nothing has moved
        pan = CONFIG.joint_names.index("head_pan")
        goals = standing.copy()
        goals[pan] = 0.5
        bus.write_goals(goals)
        bus.set_torque(True)

        def turned() -> bool:
            bus.write_goals(goals)
            return abs(bus.read().positions[pan] - 0.5) < 0.01

        wait(turned)
        truth = rig.truth()
        assert not truth.on_stand and not truth.fallen
        feet = boards.read().feet
        assert feet.sum() == pytest.approx(3.0 * 9.81, rel=0.5)  # its weight on its soles' pads (N)

        bus.set_torque(False)  # limp: it falls, and its IMU says so as the simulation has it

        def fell() -> bool:
            bus.read()
            return rig.truth().fallen

        wait(fell)
        truth = rig.truth()
        roll, pitch, _ = rpy_from_quat(boards.read().imu.quat)
        sensed_tilt = math.degrees(math.acos(math.cos(roll) * math.cos(pitch)))
        assert sensed_tilt == pytest.approx(truth.tilt_deg, abs=2.0)
    finally:
        bus.close()


def test_the_real_robot_code_walks_through_the_rig_knows_where_it_went_and_stops_on_the_estop(rig) -> None:
    robot = HardwareWorker(
        dataclasses.replace(CONFIG, port=rig.port_name), generate_world(SEED), deadman_s=0.0, walk=True
    )
    robot.start()
    try:
        assert robot.body.lacks == ""  # IMU and feet on the bus, and the legs' controller: nothing refused
        assert robot.submit(SetTorque(True)).accepted
        start = np.array(rig.truth().base_position[:2])

        def walk() -> None:
            robot.submit(Teleop(-0.15, 0.0, 0.1))  # backwards: this seed's robot faces furniture

        def walked() -> bool:
            truth = rig.truth()
            assert not truth.fallen
            return np.hypot(*(np.array(truth.base_position[:2]) - start)) > 0.5

        wait(walked, every=walk)
        truth, state = rig.truth(), robot.state()
        # the robot's own estimate (leg odometry and the IMU, from the bus alone) against where it really is
        assert np.hypot(*(np.array(state.base_position[:2]) - truth.base_position[:2])) < 0.1
        assert abs(math.remainder(state.base_yaw_rad - truth.base_yaw_rad, math.tau)) < 0.15

        bus = dict(robot.sample_diagnostics().find("hardware/bus").values)  # the tick's bus round trip, said
        assert 0 < bus["bus_p50_ms"] <= bus["bus_p99_ms"] and 0 < bus["compute_p50_ms"] <= bus["compute_p99_ms"]

        assert robot.submit(EStop(source="test")).accepted
        wait(lambda: not robot.state().torque_enabled)  # the controlled stop: a crouch, then torque off
        assert any(e.level == Level.WARN and "torque off" in e.message for e in robot.recent_events())
        stopped = np.array(rig.truth().base_position[:2])
        assert np.hypot(*(stopped - truth.base_position[:2])) < 0.15  # it stopped where it was, not walked on
    finally:
        robot.stop()


def test_in_lockstep_a_paused_machine_trips_no_wall_clock_watchdog_and_in_real_time_the_robots_own_limits_stand():
    from robot.diagnostics.thresholds import Thresholds
    from robot.hil.rig import LOCKSTEP_STALE_S, rig_config, rig_thresholds

    own = Thresholds()
    assert rig_thresholds(own) == own and rig_config().bus_watchdog_ms == default_config().bus_watchdog_ms
    paced = rig_thresholds(own, lockstep=True)
    for limit in ("control_stale_s", "imu_stale_s", "camera_stale_s", "lidar_stale_s"):
        assert getattr(paced, limit) >= LOCKSTEP_STALE_S > getattr(own, limit)
    assert paced.servo_temperature_error_c == own.servo_temperature_error_c  # only the clocks' limits change
    lockstep = rig_config(lockstep=True)
    assert lockstep.bus_watchdog_ms > 2000  # (a valid configuration: it is checked as it is made)
