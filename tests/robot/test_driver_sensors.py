"""Perception on the real robot's drivers: the head camera's and the LD06's frames, placed by the robot's
kinematics at its estimated pose, give the same detections, scan and map as the simulated sensors' own."""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np
import pytest

from robot.model.world import generate_world
from robot.perception.driver_sensors import DriverSensors
from robot.perception.lidar import LaserScan
from robot.perception.suite import SensorSnapshot, SensorSuite
from robot.sensors.camera import CameraImage
from robot.sensors.ld06 import Ld06Lidar
from robot.sensors.ld06_emulator import Ld06Emulator
from robot.sim.backend import MujocoSimBackend


class StillCamera:
    """A camera that gives one image (what the simulated head camera rendered)."""

    def __init__(self, image: CameraImage | None) -> None:
        self.image = image

    def latest(self) -> CameraImage | None:
        return self.image


def wait(predicate, timeout: float = 30.0):  # generous: a loaded machine
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(0.01)
    raise AssertionError("condition not met in time")


@pytest.fixture(scope="module")
def suite() -> SensorSuite:
    s = SensorSuite(generate_world(0))
    yield s
    s.close()


def counter_qpos(suite: SensorSuite) -> np.ndarray:
    qpos = MujocoSimBackend(suite.layout, suite.model).qpos()
    qpos[0:2] = (1.55 - 0.9, 0.35)
    qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    qpos[suite.model.joint("head_tilt").qposadr[0]] = -math.atan2(0.43 - 0.25, 0.9 + 0.08)
    return qpos


def test_real_frames_detect_scan_and_map_as_the_simulated_ones(suite) -> None:
    qpos = counter_qpos(suite)
    snapshot = SensorSnapshot(1.0, qpos, qpos[0:3].copy(), qpos[3:7].copy())
    simulated = suite.process(snapshot)
    rendered = suite.camera.capture(suite.data)
    image = CameraImage(rendered.rgb, rendered.depth, rendered.intrinsics, 1.0, 1)
    with Ld06Emulator(simulated.scan.scan) as sensor:
        lidar = Ld06Lidar(sensor.port_name)
        lidar.start()
        try:
            wait(lambda: lidar.scans >= 2)
        finally:
            lidar.stop()  # its last scan stays the newest
    sensors = DriverSensors(suite.layout, StillCamera(image), lidar, map_every=1)
    out = sensors.process(snapshot)
    want = {d.label: d.position for d in simulated.camera.detections}
    got = {d.label: d.position for d in out.camera.detections}
    assert set(got) == set(want) == {"red mug", "blue bottle", "green apple"}
    assert all(math.dist(got[k], want[k]) < 0.01 for k in got)
    assert out.camera.jpeg[:2] == b"\xff\xd8" and out.scan is not None and out.grid is not None
    assert math.dist(out.scan.pose[:2], simulated.scan.pose[:2]) < 0.02
    assert out.scan.scan.height_m == pytest.approx(simulated.scan.scan.height_m, abs=1e-6)
    # the same image and scan are not taken twice
    again = sensors.process(snapshot)
    assert again.camera is None and again.scan is None


def test_a_colour_only_camera_goes_to_the_page_without_detections(suite) -> None:
    qpos = counter_qpos(suite)
    mujoco.mj_kinematics(suite.model, suite.data)
    rendered = suite.camera.capture(suite.data)
    sensors = DriverSensors(
        suite.layout, StillCamera(CameraImage(rendered.rgb, None, rendered.intrinsics, 2.0, 7)), None
    )
    out = sensors.process(SensorSnapshot(2.0, qpos, qpos[0:3].copy(), qpos[3:7].copy()))
    assert out.camera is not None and out.camera.detections == () and out.camera.seq == 7 and out.scan is None


class OneScan:
    """A lidar whose newest scan is set by the test."""

    def __init__(self) -> None:
        self.scan: LaserScan | None = None

    def latest(self) -> LaserScan | None:
        return self.scan


def test_a_scan_taken_while_turning_is_mapped_where_the_lidar_was_mid_sweep(suite) -> None:
    """A real lidar's scan reaches perception after its sweep (and later on a busy machine): placed where the
    robot is when it is processed, a turn smears the map and misleads the scan matching."""

    def snapshot(t: float, yaw: float) -> SensorSnapshot:
        qpos = MujocoSimBackend(suite.layout, suite.model).qpos()
        qpos[3:7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        return SensorSnapshot(t, qpos, qpos[0:3].copy(), qpos[3:7].copy())

    def scan(stamp_s: float) -> LaserScan:
        return LaserScan(stamp_s, -math.pi, 2 * math.pi / 360, 0.02, 12.0, np.full(360, 2.0, dtype=np.float32), 0.3)

    lidar = OneScan()
    still = DriverSensors(suite.layout, None, lidar)
    lidar.scan = scan(0.05)  # its sweep from 0.0 to 0.1 s, the robot not turning yet
    mount_yaw = still.process(snapshot(0.0, 0.0)).scan.odom_pose[2]

    lidar.scan = None
    turning = DriverSensors(suite.layout, None, lidar)
    for t, yaw in ((0.0, 0.0), (0.1, 0.1), (0.2, 0.2)):  # turning at 1 rad/s
        if t == 0.2:
            lidar.scan = scan(0.15)  # swept from 0.05 to 0.15 s: taken, on average, at 0.1 s
        out = turning.process(snapshot(t, yaw))
    assert out.scan is not None
    assert out.scan.odom_pose[2] == pytest.approx(mount_yaw + 0.1, abs=1e-3)  # not + 0.2, where it is now
