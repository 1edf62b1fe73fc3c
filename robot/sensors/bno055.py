"""A BNO055 IMU on its own serial port (UART at 115200 baud, through pyserial), as the seed's bill of materials
names it: an alternative to the OpenCR's IMU. A thread sets the chip to its fusion mode (NDOF) and reads the
accelerometer, gyroscope and quaternion in one 32-byte read, as fast as the link allows (about 300 Hz); the
control tick takes the newest sample. Mount it with its axes on the trunk's (x forward, y left, z up) or set its
axis remap registers so.

A reply that is not what was asked (a wrong start byte, a short reply) is counted and the port flushed; a port
that fails (unplugged) is said, and reopened every second.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import serial

from robot.sensors import bno055_protocol as bno
from robot.sensors.imu import ImuSample

log = logging.getLogger(__name__)

REPLY_TIMEOUT_S = 0.05
REOPEN_AFTER_S = 1.0
RETRIES = 3


class Bno055Error(RuntimeError):
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


class Bno055Imu:
    """`port`: the serial device (or a pyserial URL); `clock`: the body's clock, to stamp samples."""

    name = "BNO055 IMU"

    def __init__(
        self,
        port: str,
        clock: Callable[[], float] = time.monotonic,
        open_port: Callable[[str], serial.SerialBase] | None = None,
    ) -> None:
        self.port_name = port
        self.clock = clock
        self._open_port = open_port or (
            lambda name: serial.serial_for_url(name, baudrate=bno.BAUDRATE, timeout=REPLY_TIMEOUT_S)
        )
        self._lock = threading.Lock()
        self._latest: ImuSample | None = None
        self._problem = "not started"
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.samples = 0
        self.corrupt_replies = 0

    def start(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="bno055", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
            self._thread = None

    def latest(self) -> ImuSample | None:
        with self._lock:
            return self._latest

    def problem(self) -> str:
        with self._lock:
            return self._problem

    def _say(self, problem: str) -> None:
        with self._lock:
            if problem and problem != self._problem:
                log.error("BNO055 on %s: %s", self.port_name, problem)
            self._problem = problem

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                port = self._open_port(self.port_name)
            except (serial.SerialException, OSError) as exc:
                self._say(f"cannot open {self.port_name}: {exc}")
                self._stop.wait(REOPEN_AFTER_S)
                continue
            try:
                self._sample(Bno055Link(port))
            except (serial.SerialException, OSError) as exc:
                self._say(f"{self.port_name} failed: {exc}")
            except Bno055Error as exc:
                self._say(str(exc))
            finally:
                port.close()
            self._stop.wait(REOPEN_AFTER_S)

    def _sample(self, link: Bno055Link) -> None:
        chip = link.read(bno.CHIP_ID, 1)[0]
        if chip != bno.CHIP_ID_VALUE:
            raise Bno055Error(f"chip id {chip:#04x} is not a BNO055's ({bno.CHIP_ID_VALUE:#04x})")
        link.write(bno.OPR_MODE, bytes([bno.MODE_CONFIG]))
        link.write(bno.UNIT_SEL, bytes([0]))  # m/s^2, deg/s, degrees
        link.write(bno.OPR_MODE, bytes([bno.MODE_NDOF]))
        while not self._stop.is_set():
            block = link.read(*bno.SAMPLE_BLOCK)
            quat, gyro, accel = bno.decode_sample(block)
            sample = ImuSample(quat, gyro, accel, self.clock())
            with self._lock:
                self._latest = sample
                self._problem = ""
                self.samples += 1
                self.corrupt_replies = link.corrupt_replies
