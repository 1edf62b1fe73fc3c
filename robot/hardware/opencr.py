"""The OpenCR sub-controller of the ROBOTIS OP3 (Dynamixel ID 200, Protocol 2.0): its control table and what its
IMU registers mean. Written from the OP3's published device description (the `OPEN-CR` sensor file of the
ROBOTIS framework) and the OpenCR OP3 firmware's register units:

- gyro x, y, z at 32, 34, 36: signed, +-2000 deg/s over +-32800 (16.4 counts a deg/s);
- accelerometer x, y, z at 38, 40, 42: signed, +-2 g over +-32768 (16384 counts a g);
- roll, pitch, yaw at 44, 46, 48: signed, 0.1 deg (yaw 0-360 deg, from where the board started);
- present voltage at 31 in 0.1 V, the buttons at 30 (mode, start, user: bits 0-2).

The board sits in the OP3's trunk turned half a turn about the vertical axis: its x and y axes point backwards
and to the right, so x and y (and roll and pitch) change sign into the trunk frame (x forward, y left, z up), as
the OP3's own driver does.
"""

from __future__ import annotations

import math

import numpy as np

from robot.hardware.control_table import Field
from robot.sensors.imu import ImuSample, quat_from_rpy, rpy_from_quat

OPENCR_ID = 200
OPENCR_MODEL = 0x7400
MODEL_NUMBER = Field(0, 2)
FIRMWARE_VERSION = Field(2, 1)
ID = Field(3, 1)
BAUD_RATE = Field(4, 1)
RETURN_DELAY_TIME = Field(5, 1)
STATUS_RETURN_LEVEL = Field(16, 1)
DYNAMIXEL_POWER = Field(24, 1)
LED = Field(25, 1)
BUTTON = Field(30, 1)
PRESENT_VOLTAGE = Field(31, 1)
GYRO = (Field(32, 2, signed=True), Field(34, 2, signed=True), Field(36, 2, signed=True))
ACCEL = (Field(38, 2, signed=True), Field(40, 2, signed=True), Field(42, 2, signed=True))
RPY = (Field(44, 2, signed=True), Field(46, 2, signed=True), Field(48, 2, signed=True))
IMU_CONTROL = Field(50, 1)
TABLE_SIZE = 51
EEPROM_END = 24

GYRO_RAD_S_PER_COUNT = math.radians(2000.0 / 32800.0)
ACCEL_G_PER_COUNT = 2.0 / 32768.0
STANDARD_GRAVITY = 9.80665
ANGLE_DEG_PER_COUNT = 0.1
# Read each tick: the voltage, then the gyro, accelerometer and angles (31 to 49).
TICK_BLOCK = (PRESENT_VOLTAGE.address, RPY[2].address + 2 - PRESENT_VOLTAGE.address)
MOUNT = np.diag([-1.0, -1.0, 1.0])  # trunk axes from the board's: half a turn about z


def decode_block(data: bytes, stamp_s: float) -> ImuSample:
    """The tick's block (`TICK_BLOCK`) as a sample in the trunk frame."""

    def field(f: Field) -> int:
        start = f.address - TICK_BLOCK[0]
        return f.decode(data[start : start + f.size])

    gyro = MOUNT @ np.array([field(f) for f in GYRO], dtype=float) * GYRO_RAD_S_PER_COUNT
    accel = MOUNT @ np.array([field(f) for f in ACCEL], dtype=float) * ACCEL_G_PER_COUNT * STANDARD_GRAVITY
    roll, pitch, yaw = (math.radians(field(f) * ANGLE_DEG_PER_COUNT) for f in RPY)
    quat = quat_from_rpy(-roll, -pitch, yaw)  # the board's roll and pitch are the trunk's, reversed
    return ImuSample(quat, gyro, accel, stamp_s, field(PRESENT_VOLTAGE) / 10.0)


def encode_registers(quat: np.ndarray, gyro: np.ndarray, accel: np.ndarray) -> dict[Field, int]:
    """What the board's registers hold for a trunk moving so (the emulator's side of `decode_block`)."""
    roll, pitch, yaw = rpy_from_quat(quat)
    g = MOUNT.T @ np.asarray(gyro, dtype=float) / GYRO_RAD_S_PER_COUNT
    a = MOUNT.T @ np.asarray(accel, dtype=float) / (ACCEL_G_PER_COUNT * STANDARD_GRAVITY)
    out: dict[Field, int] = {}
    for fields, values in ((GYRO, g), (ACCEL, a)):
        for f, v in zip(fields, values, strict=True):
            out[f] = int(max(-32768, min(32767, round(float(v)))))
    angles = (-math.degrees(roll), -math.degrees(pitch), math.degrees(yaw) % 360.0)
    for f, v in zip(RPY, angles, strict=True):
        out[f] = round(v / ANGLE_DEG_PER_COUNT)
    return out
