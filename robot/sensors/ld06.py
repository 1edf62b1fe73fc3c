"""An LDRobot LD06 or LD19 lidar on its serial port (pyserial), feeding the same `LaserScan` as the simulated lidar:
a thread reads its packets (`ld06_protocol`), drops those whose CRC fails (counted), and assembles a scan each
turn; the perception takes the newest. A port that fails (unplugged) or goes quiet is said (`problem`), and the
port is reopened every second.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import serial

from robot.perception.lidar import LaserScan
from robot.sensors.ld06_protocol import BAUDRATE, PacketParser, ScanAssembler
from robot.sensors.reader_thread import ReaderThread

READ_TIMEOUT_S = 0.05
QUIET_AFTER_S = 0.5  # no packet for this long: the sensor is not sending (10 turns a second, 38 packets each)


class Ld06Lidar(ReaderThread[LaserScan, serial.SerialBase]):
    """`port`: the serial device (or a pyserial URL); `clock`: the body's clock, to stamp scans;
    `mount_yaw_rad` and `height_m`: where the sensor's 0 deg points and how high its plane is."""

    thread_name = "ld06"
    silent_after_s = QUIET_AFTER_S

    def __init__(
        self,
        port: str,
        clock: Callable[[], float] = time.monotonic,
        mount_yaw_rad: float = 0.0,
        height_m: float = 0.0,
        model: str = "LD06",
    ) -> None:
        super().__init__()
        self.port_name = port
        self.name = f"{model} lidar"
        self.clock = clock
        self._assembler = ScanAssembler(mount_yaw_rad=mount_yaw_rad, height_m=height_m)
        self._parser = PacketParser()
        self.scans = 0

    @property
    def crc_errors(self) -> int:
        return self._parser.crc_errors

    def _silence(self, silent_s: float) -> str:
        return f"no packets for {silent_s:.1f} s"

    def _source_label(self) -> str:
        return self.port_name

    def _open(self) -> serial.SerialBase:
        return serial.serial_for_url(self.port_name, baudrate=BAUDRATE, timeout=READ_TIMEOUT_S)

    def _close(self, source: serial.SerialBase) -> None:
        source.close()

    def _serve(self, source: serial.SerialBase) -> None:
        while not self.stopping:
            data = source.read(max(1, source.in_waiting))
            if not data:
                continue
            for packet in self._parser.feed(data):
                self._heard()
                scan = self._assembler.add(packet, self.clock())
                if scan is not None:
                    self.scans += 1
                    self._publish(scan)
