"""The LD06/LD19 lidar driver over its serial protocol, against an emulated sensor on a pseudo-terminal sending the
packets of a scan the simulated lidar took: the scan comes back through the wire, maps and localises as the
simulated one does, and corrupt packets, a quiet sensor and a pulled cable are said."""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np
import pytest

from robot.perception.lidar import LaserScan
from robot.perception.occupancy import GridSpec
from robot.perception.scan_mapping import ScanMapping
from robot.perception.suite import MAP_SIZE_M, SensorSuite
from robot.sensors.ld06 import Ld06Lidar
from robot.sensors.ld06_emulator import Ld06Emulator
from robot.sensors.ld06_protocol import (
    PACKET_BYTES,
    Packet,
    PacketParser,
    ScanAssembler,
    crc8,
    encode,
    packets_from_scan,
)


def wait(predicate, timeout: float = 30.0):  # generous: a loaded machine
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(0.01)
    raise AssertionError("condition not met in time")


@pytest.fixture(scope="module")
def sim_scan(layout) -> LaserScan:
    """What the simulated lidar sees from the robot's start pose."""
    suite = SensorSuite(layout)
    mujoco.mj_kinematics(suite.model, suite.data)
    return suite.lidar.scan(suite.data)


def room_scan(beams: int = 720, half_x: float = 2.0, half_y: float = 1.5) -> LaserScan:
    """A sensor in the middle of a walled 4 m x 3 m room, facing +x."""
    angles = -math.pi + 2 * math.pi / beams * np.arange(beams)
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        ranges = np.minimum(np.where(c != 0, half_x / np.abs(c), np.inf), np.where(s != 0, half_y / np.abs(s), np.inf))
    return LaserScan(0.0, -math.pi, 2 * math.pi / beams, 0.02, 12.0, ranges.astype(np.float32), 0.3)


def agreement(got: LaserScan, want: LaserScan) -> float:
    """Share of the returns that lie within 3 cm of one of the scan's returns (as points around the sensor),
    given at least 90 % of the beams have one."""
    mine, theirs = got.points(0.0, 0.0, 0.0), want.points(0.0, 0.0, 0.0)
    if len(mine) < 0.9 * np.isfinite(want.ranges).mean() * len(got.ranges):
        return 0.0
    nearest = np.min(np.linalg.norm(mine[:, None, :] - theirs[None, :, :], axis=-1), axis=1)
    return float(np.mean(nearest < 0.03))


def test_crc8_and_packet_layout_follow_the_manual() -> None:
    packet = Packet(3600, 10.0, 19.68, tuple(range(1000, 1012)), (200,) * 12, 1234)
    raw = encode(packet)
    assert len(raw) == PACKET_BYTES and raw[:2] == b"\x54\x2c" and raw[-1] == crc8(raw[:-1])
    parser = PacketParser()
    (back,) = parser.feed(b"\x00\x54" + raw)
    assert back == packet
    assert parser.feed(raw[:-1] + bytes([raw[-1] ^ 1])) == [] and parser.crc_errors == 1
    angles = Packet(3600, 355.0, 3.8, (1,) * 12, (1,) * 12, 0).angles_deg()  # across the wrap
    assert angles[0] == pytest.approx(355.0) and angles[-1] == pytest.approx(3.8) and angles[1] == pytest.approx(355.8)


def test_a_turn_of_packets_assembles_back_into_the_scan() -> None:
    want = room_scan()
    assembler = ScanAssembler()
    scans = [s for p in packets_from_scan(want) * 2 if (s := assembler.add(p, 1.0)) is not None]
    assert len(scans) == 1 and agreement(scans[0], want) > 0.98


def test_the_driver_streams_the_simulated_lidars_scan_and_it_maps_the_same(sim_scan, layout) -> None:
    with Ld06Emulator(sim_scan) as sensor:
        lidar = Ld06Lidar(sensor.port_name, height_m=sim_scan.height_m)
        lidar.start()
        try:
            got = wait(lambda: lidar.scans >= 2 and lidar.latest())
        finally:
            lidar.stop()
    assert agreement(got, sim_scan) > 0.95
    x, y, yaw = layout.robot_start
    spec = GridSpec.around(round(x, 1), round(y, 1), *MAP_SIZE_M)
    through_wire, simulated = ScanMapping(spec), ScanMapping(spec)
    for mapping, scan in ((through_wire, got), (simulated, sim_scan)):
        for _ in range(3):
            frame = mapping.add(scan, (x, y, yaw))
    wired, sim = through_wire.mapper.snapshot(), simulated.mapper.snapshot()
    occupied_sim = sim.occupied()
    overlap = np.sum(wired.occupied() & occupied_sim) / max(1, np.sum(occupied_sim))
    assert overlap > 0.8  # the same walls
    assert math.dist(frame.pose[:2], (x, y)) < 0.05


def test_corrupt_packets_are_dropped_and_counted() -> None:
    with Ld06Emulator(room_scan()) as sensor:
        lidar = Ld06Lidar(sensor.port_name)
        lidar.start()
        try:
            wait(lambda: lidar.scans >= 1)
            sensor.corrupt_packets = 5
            before = lidar.scans
            wait(lambda: lidar.scans >= before + 3)  # the turn with the gap, then whole ones again
            assert lidar.crc_errors == 5 and lidar.problem() == ""
            assert agreement(lidar.latest(), room_scan()) > 0.98
        finally:
            lidar.stop()


def test_a_quiet_sensor_and_a_pulled_cable_are_said() -> None:
    with Ld06Emulator(room_scan()) as sensor:
        lidar = Ld06Lidar(sensor.port_name)
        lidar.start()
        try:
            wait(lambda: lidar.scans >= 1)
            sensor.quiet = True
            assert "no packets" in wait(lidar.problem)
            sensor.quiet = False
            wait(lambda: lidar.problem() == "")
            sensor.unplug()
            assert "no packets" not in wait(lambda: (p := lidar.problem()) and "no packets" not in p and p)
        finally:
            lidar.stop()
