"""The Bosch BNO055's UART protocol and registers, from its datasheet (section 4.7, "UART interface"):

    write:  AA 00 <register> <length> <data...>   ->  EE <status>        (status 01: written)
    read:   AA 01 <register> <length>             ->  BB <length> <data...>, or EE <status> on failure

There is no checksum: a reply is judged by its start byte and length. The chip answers EE 07 ("bus over-run")
when it was busy, which the host retries. Data registers (page 0, default units): the accelerometer at 0x08
(1 m/s^2 = 100 counts, gravity included), the gyroscope at 0x14 (1 deg/s = 16 counts), the fused quaternion at
0x20 (w, x, y, z; 1 = 2^14 counts).
"""

from __future__ import annotations

import math
import struct

import numpy as np

START = 0xAA
WRITE, READ = 0x00, 0x01
READ_OK = 0xBB
STATUS = 0xEE
WRITE_SUCCESS = 0x01
READ_FAIL = 0x02
REGMAP_INVALID_ADDRESS = 0x04
WRONG_START_BYTE = 0x06
BUS_OVER_RUN = 0x07
MAX_LENGTH = 0x08
MIN_LENGTH = 0x09

CHIP_ID, CHIP_ID_VALUE = 0x00, 0xA0
ACC_DATA = 0x08
GYR_DATA = 0x14
QUA_DATA = 0x20
CALIB_STAT = 0x35
SYS_STATUS = 0x39
UNIT_SEL = 0x3B
OPR_MODE = 0x3D
MODE_CONFIG, MODE_NDOF = 0x00, 0x0C
SAMPLE_BLOCK = (ACC_DATA, QUA_DATA + 8 - ACC_DATA)  # accelerometer to quaternion: 32 bytes
ACCEL_COUNTS_PER_M_S2 = 100.0
GYRO_COUNTS_PER_DEG_S = 16.0
QUAT_COUNTS = 1 << 14
BAUDRATE = 115_200


def read_command(register: int, length: int) -> bytes:
    return bytes([START, READ, register, length])


def write_command(register: int, data: bytes) -> bytes:
    return bytes([START, WRITE, register, len(data)]) + data


def decode_sample(block: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The sample block (`SAMPLE_BLOCK`) as (quaternion wxyz, gyro rad/s, accel m/s^2) in the chip's frame."""
    values = struct.unpack("<16h", block[:32])
    accel = np.array(values[0:3], dtype=float) / ACCEL_COUNTS_PER_M_S2
    gyro = np.radians(np.array(values[6:9], dtype=float) / GYRO_COUNTS_PER_DEG_S)
    quat = np.array(values[12:16], dtype=float) / QUAT_COUNTS
    norm = float(np.linalg.norm(quat))
    return (quat / norm if norm > 0.5 else np.array([math.nan] * 4)), gyro, accel


def encode_sample(quat: np.ndarray, gyro: np.ndarray, accel: np.ndarray) -> bytes:
    """What the chip's registers from 0x08 hold for this motion (the emulator's side of `decode_sample`)."""

    def counts(values: np.ndarray, scale: float) -> list[int]:
        return [int(max(-32768, min(32767, round(float(v) * scale)))) for v in values]

    acc = counts(np.asarray(accel), ACCEL_COUNTS_PER_M_S2)
    gyr = counts(np.degrees(np.asarray(gyro)), GYRO_COUNTS_PER_DEG_S)
    qua = counts(np.asarray(quat), QUAT_COUNTS)
    return struct.pack("<16h", *acc, 0, 0, 0, *gyr, 0, 0, 0, *qua)
