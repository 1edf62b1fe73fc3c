"""A BNO055 IMU on its own serial port (UART at 115200 baud, through pyserial), as the seed's bill of materials
names it: an alternative to the OpenCR's IMU. A thread sets the chip to its fusion mode (NDOF) and reads the
accelerometer, gyroscope and quaternion in one 32-byte read, as fast as the link allows (about 300 Hz); the
control tick takes the newest sample. Mount it with its axes on the trunk's (x forward, y left, z up) or set its
axis remap registers so.

A reply that is not what was asked (a wrong start byte, a short reply) is counted and the port flushed; a port
that fails (unplugged) is said, and reopened every second.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import serial

from robot.sensors import bno055_protocol as bno
from robot.sensors.imu import ImuSample
from robot.sensors.reader_thread import ReaderThread, SourceFailed

REPLY_TIMEOUT_S = 0.05
RETRIES = 3


class Bno055Error(SourceFailed):
    pass


class Bno055Link:
    """Register reads and writes over the UART protocol (one command at a time)."""

    def __init__(self, port: serial.SerialBase) -> None:
        self.port = port
        self.corrupt_replies = 0

    def read(self, register: int, length: int) -> bytes:
        for _ in range(RETRIES):
            self.port.write(bno.read_command(register, length))
            head = self.port.read(2)
            if len(head) == 2 and head[0] == bno.READ_OK and head[1] == length:
                data = self.port.read(length)
                if len(data) == length:
                    return data
            if len(head) == 2 and head[0] == bno.STATUS and head[1] == bno.BUS_OVER_RUN:
                continue  # the chip was busy: ask again
            self._corrupt(head)
        raise Bno055Error(f"no valid reply reading register {register:#04x}")

    def write(self, register: int, data: bytes) -> None:
        for _ in range(RETRIES):
            self.port.write(bno.write_command(register, data))
            head = self.port.read(2)
            if head == bytes([bno.STATUS, bno.WRITE_SUCCESS]):
                return
            if len(head) == 2 and head[0] == bno.STATUS and head[1] == bno.BUS_OVER_RUN:
                continue
            self._corrupt(head)
        raise Bno055Error(f"no valid reply writing register {register:#04x}")

    def _corrupt(self, head: bytes) -> None:
        if head:
            self.corrupt_replies += 1
        time.sleep(REPLY_TIMEOUT_S)  # let what is left of the reply arrive, then drop it
        self.port.reset_input_buffer()


class Bno055Imu(ReaderThread[ImuSample, serial.SerialBase]):
    """`port`: the serial device (or a pyserial URL); `clock`: the body's clock, to stamp samples."""

    name = "BNO055 IMU"
    thread_name = "bno055"

    def __init__(
        self,
        port: str,
        clock: Callable[[], float] = time.monotonic,
        open_port: Callable[[str], serial.SerialBase] | None = None,
    ) -> None:
        super().__init__()
        self.port_name = port
        self.clock = clock
        self._open_port = open_port or (
            lambda name: serial.serial_for_url(name, baudrate=bno.BAUDRATE, timeout=REPLY_TIMEOUT_S)
        )
        self.samples = 0
        self.corrupt_replies = 0

    def _source_label(self) -> str:
        return self.port_name

    def _open(self) -> serial.SerialBase:
        return self._open_port(self.port_name)

    def _close(self, source: serial.SerialBase) -> None:
        source.close()

    def _serve(self, source: serial.SerialBase) -> None:
        self._sample(Bno055Link(source))

    def _sample(self, link: Bno055Link) -> None:
        chip = link.read(bno.CHIP_ID, 1)[0]
        if chip != bno.CHIP_ID_VALUE:
            raise Bno055Error(f"chip id {chip:#04x} is not a BNO055's ({bno.CHIP_ID_VALUE:#04x})")
        link.write(bno.OPR_MODE, bytes([bno.MODE_CONFIG]))
        link.write(bno.UNIT_SEL, bytes([0]))  # m/s^2, deg/s, degrees
        link.write(bno.OPR_MODE, bytes([bno.MODE_NDOF]))
        while not self.stopping:
            block = link.read(*bno.SAMPLE_BLOCK)
            quat, gyro, accel = bno.decode_sample(block)
            self.samples += 1
            self.corrupt_replies = link.corrupt_replies
            self._publish(ImuSample(quat, gyro, accel, self.clock()))
