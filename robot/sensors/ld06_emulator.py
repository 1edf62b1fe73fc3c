"""An LD06 lidar on the far end of a pseudo-terminal: it sends the packets of a scan it is given (`set_scan`), a
turn every 0.1 s, paced as the sensor is, for tests of the driver without the sensor. Faults to inject: packets
with a wrong CRC (`corrupt_packets`), the sensor going quiet (`quiet`), the cable pulled (`unplug`)."""

from __future__ import annotations

import os
import time

from robot.perception.lidar import LaserScan
from robot.sensors.ld06_protocol import encode, packets_from_scan
from robot.sensors.pty_device import PtyDevice

TURN_S = 0.1


class Ld06Emulator(PtyDevice):
    thread_name = "ld06-emulator"

    def __init__(self, scan: LaserScan, mount_yaw_rad: float = 0.0) -> None:
        super().__init__()
        self.mount_yaw = mount_yaw_rad
        self.corrupt_packets = 0
        self.quiet = False
        self.turns = 0
        self._packets = [encode(p) for p in packets_from_scan(scan, mount_yaw_rad=mount_yaw_rad)]

    def set_scan(self, scan: LaserScan) -> None:
        packets = [encode(p) for p in packets_from_scan(scan, mount_yaw_rad=self.mount_yaw)]
        with self._lock:
            self._packets = packets

    def _run(self) -> None:
        next_turn = time.monotonic()
        while not self._stop.is_set():
            with self._lock:
                packets = list(self._packets)
            if not self.quiet:
                for packet in packets:
                    if self.corrupt_packets > 0:
                        self.corrupt_packets -= 1
                        packet = packet[:-1] + bytes([packet[-1] ^ 0x5A])
                    try:
                        os.write(self._master, packet)
                    except OSError:
                        return
                self.turns += 1
            next_turn += TURN_S
            self._stop.wait(max(0.0, next_turn - time.monotonic()))
