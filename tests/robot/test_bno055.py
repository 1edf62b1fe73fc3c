"""The BNO055 IMU driver over its UART protocol, against an emulated chip on a pseudo-terminal."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator

import numpy as np
import pytest

from robot.sensors import bno055_protocol as bno
from robot.sensors.bno055 import Bno055Imu
from robot.sensors.bno055_emulator import Bno055Emulator
from robot.sensors.imu import quat_from_rpy, rpy_from_quat


def wait(predicate, timeout: float = 30.0):  # generous: a loaded machine
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(0.01)
    raise AssertionError("condition not met in time")


@pytest.fixture
def chip() -> Iterator[tuple[Bno055Emulator, Bno055Imu]]:
    with Bno055Emulator() as emulator:
        imu = Bno055Imu(emulator.port_name)
        imu.start()
        yield emulator, imu
        imu.stop()


def test_sample_registers_round_trip() -> None:
    quat = quat_from_rpy(0.1, 0.2, -0.5)
    q, g, a = bno.decode_sample(bno.encode_sample(quat, np.array([0.3, 0.0, -0.2]), np.array([0.0, 1.0, 9.7])))
    assert np.allclose(q, quat, atol=1e-3) and np.allclose(g, [0.3, 0.0, -0.2], atol=2e-3)
    assert np.allclose(a, [0.0, 1.0, 9.7], atol=0.01)


def test_the_driver_sets_fusion_mode_and_streams_samples(chip) -> None:
    emulator, imu = chip
    emulator.sense(quat_from_rpy(math.radians(-8), 0.0, 0.0), np.array([0.0, 0.0, 0.5]), np.array([0, -1.4, 9.7]))
    sample = wait(lambda: (s := imu.latest()) is not None and abs(s.gyro[2] - 0.5) < 0.01 and s)
    assert math.degrees(rpy_from_quat(sample.quat)[0]) == pytest.approx(-8.0, abs=0.1)
    assert emulator.registers[bno.OPR_MODE] == bno.MODE_NDOF and imu.problem() == ""


def test_garbled_replies_are_counted_and_sampling_goes_on(chip) -> None:
    emulator, imu = chip
    wait(lambda: imu.samples > 5)
    emulator.corrupt_replies = 2
    before = imu.samples
    wait(lambda: imu.samples > before + 10)
    assert imu.corrupt_replies == 2 and imu.problem() == ""


def test_a_silent_chip_or_a_pulled_cable_is_said(chip) -> None:
    emulator, imu = chip
    wait(lambda: imu.samples > 5)
    emulator.silent = True
    assert "no valid reply" in wait(imu.problem)
    emulator.silent = False
    wait(lambda: imu.problem() == "")
    emulator.unplug()
    assert wait(lambda: imu.problem() and "no valid reply" not in imu.problem() and imu.problem())
