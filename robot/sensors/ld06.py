"""An LDRobot LD06 or LD19 lidar on its serial port (pyserial), feeding the same `LaserScan` as the simulated lidar:
a thread reads its packets (`ld06_protocol`), drops those whose CRC fails (counted), and assembles a scan each
turn; the perception takes the newest. A port that fails (unplugged) or goes quiet is said (`problem`), and the
port is reopened every second.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import serial

from robot.perception.lidar import LaserScan
from robot.sensors.ld06_protocol import BAUDRATE, PacketParser, ScanAssembler

log = logging.getLogger(__name__)

READ_TIMEOUT_S = 0.05
QUIET_AFTER_S = 0.5  # no packet for this long: the sensor is not sending (10 turns a second, 38 packets each)
REOPEN_AFTER_S = 1.0


class Ld06Lidar:
    """`port`: the serial device (or a pyserial URL); `clock`: the body's clock, to stamp scans;
    `mount_yaw_rad` and `height_m`: where the sensor's 0 deg points and how high its plane is."""

    def __init__(
        self,
        port: str,
        clock: Callable[[], float] = time.monotonic,
        mount_yaw_rad: float = 0.0,
        height_m: float = 0.0,
        model: str = "LD06",
    ) -> None:
        self.port_name = port
        self.name = f"{model} lidar"
        self.clock = clock
        self._assembler = ScanAssembler(mount_yaw_rad=mount_yaw_rad, height_m=height_m)
        self._parser = PacketParser()
        self._lock = threading.Lock()
        self._latest: LaserScan | None = None
        self._last_packet_s: float | None = None
        self._problem = "not started"
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.scans = 0

    @property
    def crc_errors(self) -> int:
        return self._parser.crc_errors

    def start(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="ld06", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
            self._thread = None

    def latest(self) -> LaserScan | None:
        with self._lock:
            return self._latest

    def problem(self) -> str:
        """Why there are no scans now ("" while they come)."""
        with self._lock:
            if self._problem:
                return self._problem
            if self._last_packet_s is not None and time.monotonic() - self._last_packet_s > QUIET_AFTER_S:
                return f"no packets for {time.monotonic() - self._last_packet_s:.1f} s"
            return ""

    def _say(self, problem: str) -> None:
        with self._lock:
            if problem != self._problem:
                log.error("%s on %s: %s", self.name, self.port_name, problem)
            self._problem = problem

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                port = serial.serial_for_url(self.port_name, baudrate=BAUDRATE, timeout=READ_TIMEOUT_S)
            except (serial.SerialException, OSError) as exc:
                self._say(f"cannot open {self.port_name}: {exc}")
                self._stop.wait(REOPEN_AFTER_S)
                continue
            with self._lock:
                self._problem = ""
            try:
                self._read(port)
            except (serial.SerialException, OSError) as exc:
                self._say(f"{self.port_name} failed: {exc}")
            finally:
                port.close()
            self._stop.wait(REOPEN_AFTER_S)

    def _read(self, port: serial.SerialBase) -> None:
        while not self._stop.is_set():
            data = port.read(max(1, port.in_waiting))
            if not data:
                continue
            for packet in self._parser.feed(data):
                now = self.clock()
                with self._lock:
                    self._last_packet_s = time.monotonic()
                scan = self._assembler.add(packet, now)
                if scan is not None:
                    with self._lock:
                        self._latest = scan
                        self.scans += 1
