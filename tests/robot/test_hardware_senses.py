"""The real robot's own senses through the emulated bus: the OpenCR's IMU and the FSR foot modules read each tick
with the servos (and a BNO055 on its own port instead), what they say in diagnostics, a fall seen by the IMU,
and a sense lost while torque is on bringing the robot down."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Iterator

import numpy as np
import pytest

from robot.hardware import fsr, opencr
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.config import ConfigError, default_config
from robot.hardware.worker import HardwareWorker
from robot.interface import Level, Refusal, RunCommand, SetTorque, Teleop
from robot.sensors.bno055 import Bno055Imu
from robot.sensors.bno055_emulator import Bno055Emulator
from robot.sensors.imu import quat_from_rpy

CONFIG = dataclasses.replace(default_config(), reply_margin_ms=100.0, imu="opencr", feet="fsr")


def wait(predicate, timeout: float = 30.0):  # generous: a loaded machine
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(0.02)
    raise AssertionError("condition not met in time")


@pytest.fixture
def emulator() -> Iterator[BusEmulator]:
    with BusEmulator([j.servo_id for j in CONFIG.joints], sensors=True) as bus:
        yield bus


@pytest.fixture
def robot(emulator, layout) -> Iterator[HardwareWorker]:
    worker = HardwareWorker(dataclasses.replace(CONFIG, port=emulator.port_name), layout, deadman_s=0.0)
    worker.start()
    yield worker
    worker.stop()


def status(robot: HardwareWorker, name: str, level: Level):
    return wait(lambda: (d := robot.sample_diagnostics()) and (s := d.find(name)) and s.level == level and s)


def test_imu_and_feet_reach_the_measurements_and_diagnostics(robot, emulator) -> None:
    assert robot.body.senses.can_walk and "legs' controller" in robot.body.lacks
    emulator.sense_imu(quat_from_rpy(math.radians(12), 0.0, 0.0), [0.2, 0.0, 0.0], [0.0, 2.0, 9.6])
    emulator.sense_foot(fsr.LEFT_FSR_ID, [20.0, 20.0, 15.0, 15.0])
    emulator.sense_foot(fsr.RIGHT_FSR_ID, [10.0, 10.0, 5.0, 5.0])
    # the three were set one after another; a tick may read between them, so wait for one that saw them all
    wait(lambda: abs(robot.state().tilt_deg - 12.0) < 0.5 and robot.body.latest().foot_forces[1][0] > 0)
    measured = robot.body.latest()
    assert np.allclose(measured.foot_forces, [[20, 20, 15, 15], [10, 10, 5, 5]], atol=1e-3)
    assert measured.imu_gyro[0] == pytest.approx(0.2, abs=0.01) and measured.imu_stamp_s is not None
    assert status(robot, "sensors/imu", Level.OK).hardware_id == "OpenCR IMU"
    assert status(robot, "sensors/left_foot", Level.OK) and status(robot, "sensors/right_foot", Level.OK)
    assert robot.submit(Teleop(0.1, 0, 0)).refusal == Refusal.UNSUPPORTED  # no legs' controller given


def test_a_fall_seen_by_the_imu_makes_the_controlled_stop_and_upright_again_it_may_move(robot, emulator) -> None:
    assert robot.submit(SetTorque(True)).accepted
    wait(lambda: robot.state().torque_enabled)
    emulator.sense_imu(quat_from_rpy(0.0, math.radians(70), 0.0), [0, 0, 0], [9.0, 0.0, 3.0])
    wait(lambda: robot.state().fallen and robot.state().estop_latched)
    assert any(e.kind == "robot/fell" for e in robot.recent_events())
    wait(lambda: not robot.state().torque_enabled)  # crouched, then let go
    emulator.sense_imu(quat_from_rpy(0.0, math.radians(3), 0.0), [0, 0, 0], [0.5, 0.0, 9.8])  # picked up
    wait(lambda: not robot.state().fallen)
    assert any(e.kind == "hardware/upright" for e in robot.recent_events())


def test_an_imu_lost_with_torque_on_stops_the_robot_and_is_said(robot, emulator) -> None:
    assert robot.submit(SetTorque(True)).accepted
    wait(lambda: robot.state().torque_enabled)
    emulator.set_fault(opencr.OPENCR_ID, dead=True)
    wait(lambda: robot.state().estop_latched)
    lost = next(e for e in robot.recent_events() if e.kind == "hardware/sensor_lost")
    assert "OpenCR IMU" in lost.message
    assert "not answering" in status(robot, "sensors/imu", Level.ERROR).message
    assert status(robot, "sensors/left_foot", Level.OK)  # the feet keep coming


def test_a_corrupt_foot_reply_costs_a_count_not_a_stop(robot, emulator) -> None:
    robot.submit(SetTorque(True))
    wait(lambda: robot.state().torque_enabled)
    emulator.set_fault(fsr.RIGHT_FSR_ID, corrupt_replies=1)
    wait(lambda: dict(status(robot, "sensors/right_foot", Level.OK).values)["crc_errors"] == 1)
    assert not robot.state().estop_latched


def test_a_robot_without_senses_says_what_it_lacks(layout) -> None:
    with BusEmulator([j.servo_id for j in CONFIG.joints]) as bus:  # no sensor boards on this bus
        robot = HardwareWorker(dataclasses.replace(CONFIG, port=bus.port_name, imu="none"), layout, deadman_s=0.0)
        robot.start()
        try:
            reply = robot.submit(RunCommand("go to the kitchen"))
            assert reply.refusal == Refusal.UNSUPPORTED and "needs an IMU" in reply.message
            assert "right foot FSR" in next(e for e in robot.recent_events() if e.kind == "hardware/sensors").message
            assert "not found" in status(robot, "sensors/right_foot", Level.ERROR).message
        finally:
            robot.stop()


def test_a_bno055_on_its_own_port_is_the_imu(layout) -> None:
    with BusEmulator([j.servo_id for j in CONFIG.joints], sensors=True) as bus, Bno055Emulator() as chip:
        config = dataclasses.replace(CONFIG, port=bus.port_name, imu=f"bno055:{chip.port_name}")
        robot = HardwareWorker(config, layout, deadman_s=0.0)
        assert isinstance(robot.body.sensing.imu_driver, Bno055Imu)
        robot.start()
        try:
            chip.sense(quat_from_rpy(0.0, math.radians(-9), 0.0), np.zeros(3), np.array([0.0, 0.0, 9.8]))
            wait(lambda: abs(robot.state().tilt_deg - 9.0) < 0.5)
            assert status(robot, "sensors/imu", Level.OK).hardware_id == "BNO055 IMU"
        finally:
            robot.stop()


def test_sensor_settings_are_checked() -> None:
    with pytest.raises(ConfigError, match="imu"):
        dataclasses.replace(CONFIG, imu="mpu6050")
    with pytest.raises(ConfigError, match="lidar"):
        dataclasses.replace(CONFIG, lidar="rplidar:/dev/ttyUSB0")


def test_a_stalled_camera_and_an_unplugged_lidar_are_said_and_nothing_else_breaks(layout) -> None:
    from robot.perception.lidar import LaserScan
    from robot.sensors.ld06_emulator import Ld06Emulator
    from robot.sensors.mjpeg_server import MjpegServer

    ranges = np.full(360, 2.0, dtype=np.float32)
    scan = LaserScan(0.0, -math.pi, 2 * math.pi / 360, 0.02, 12.0, ranges, 0.3)
    image = np.full((120, 160, 3), 90, dtype=np.uint8)
    with (
        BusEmulator([j.servo_id for j in CONFIG.joints], sensors=True) as bus,
        MjpegServer(image) as camera,
        Ld06Emulator(scan) as lidar,
    ):
        config = dataclasses.replace(CONFIG, port=bus.port_name, camera=camera.url, lidar=f"ld06:{lidar.port_name}")
        robot = HardwareWorker(config, layout, deadman_s=0.0)
        robot.start()
        try:
            assert status(robot, "sensors/camera_driver", Level.OK) and status(robot, "sensors/lidar_driver", Level.OK)
            lidar.corrupt_packets = 3
            wait(lambda: dict(status(robot, "sensors/lidar_driver", Level.OK).values)["crc_errors"] == 3)
            camera.stall = True
            assert "stalled" in status(robot, "sensors/camera_driver", Level.ERROR).message
            lidar.unplug()
            assert "LD06 lidar" in status(robot, "sensors/lidar_driver", Level.ERROR).message
            # the servos, the IMU and the feet go on: torque, and the robot holds where it is
            assert robot.submit(SetTorque(True)).accepted
            wait(lambda: robot.state().torque_enabled)
            assert status(robot, "sensors/imu", Level.OK) and not robot.state().estop_latched
        finally:
            robot.stop()


def test_a_walking_robots_perception_starts_once_it_has_a_state_and_maps_its_lidar(layout, monkeypatch) -> None:
    """Perception places its sensors by the robot's state: started before the first one (a slow start on a busy
    machine), it failed for good and the robot never had a map to walk by."""
    from robot.perception.lidar import LaserScan
    from robot.perception.service import PerceptionService
    from robot.sensors.ld06_emulator import Ld06Emulator

    robots: list[HardwareWorker] = []
    started_with_state: list[bool] = []
    original_start = PerceptionService.start

    def start(service: PerceptionService) -> None:
        try:
            started_with_state.append(robots[0].state() is not None)
        except RuntimeError:  # no state yet
            started_with_state.append(False)
        original_start(service)

    monkeypatch.setattr(PerceptionService, "start", start)
    ranges = np.full(360, 2.0, dtype=np.float32)
    scan = LaserScan(0.0, -math.pi, 2 * math.pi / 360, 0.02, 12.0, ranges, 0.3)
    with (
        BusEmulator([j.servo_id for j in CONFIG.joints], sensors=True) as bus,
        Ld06Emulator(scan) as lidar,
    ):
        config = dataclasses.replace(CONFIG, port=bus.port_name, lidar=f"ld06:{lidar.port_name}")
        robot = HardwareWorker(config, layout, deadman_s=0.0, walk=True)
        robots.append(robot)
        robot.start()
        try:
            assert started_with_state == [True]
            wait(lambda: robot.state().perception.map_scans >= 3)
            assert robot.state().perception.status == "ok"
            # said in diagnostics as the simulation's are (a perception that failed would be an ERROR here), for
            # the sensors it has: a lidar, no camera
            lidar_status = wait(
                lambda: (s := robot.sample_diagnostics().find("sensors/lidar")) and s.message != "starting" and s
            )
            assert lidar_status.level in (Level.OK, Level.WARN) and "Hz" in lidar_status.message
            assert robot.sample_diagnostics().find("sensors/camera") is None
        finally:
            robot.stop()
