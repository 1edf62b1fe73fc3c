"""The LDRobot LD06 / LD19 lidar's serial protocol, from its development manual: 230400 baud, 8N1, the sensor
talking on its own (no commands). Each 47-byte packet carries 12 points:

    54 2C | speed (2, deg/s) | start angle (2, 0.01 deg) | 12 x (distance (2, mm), intensity (1))
          | end angle (2, 0.01 deg) | timestamp (2, ms, wraps at 30000) | CRC-8 (1)

all little-endian; the CRC-8 (polynomial 0x4D, initial value 0, no reflection) covers the 46 bytes before it. The
points' angles are spread evenly from the start angle to the end angle (which may have wrapped past 360). Angles
grow clockwise seen from above; a distance of 0 is no return.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np

from robot.perception.lidar import LaserScan

HEADER = 0x54
VER_LEN = 0x2C  # packet type 1, 12 points
POINTS_PER_PACKET = 12
PACKET_BYTES = 47
BAUDRATE = 230_400
RANGE_MIN_M = 0.02
RANGE_MAX_M = 12.0
SCAN_BEAMS = 450  # 4500 points a second at 10 turns a second
EMULATED_POINTS = 456  # a turn of 38 packets
_LAYOUT = "<BBHH" + "HB" * POINTS_PER_PACKET + "HH"


def _crc_table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x4D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return table


_TABLE = _crc_table()


def crc8(data: bytes) -> int:
    crc = 0
    for byte in data:
        crc = _TABLE[(crc ^ byte) & 0xFF]
    return crc


@dataclass(frozen=True)
class Packet:
    speed_deg_s: int
    start_deg: float
    end_deg: float
    distances_mm: tuple[int, ...]
    intensities: tuple[int, ...]
    timestamp_ms: int

    def angles_deg(self) -> np.ndarray:
        """Each point's clockwise angle in [0, 360)."""
        end = self.end_deg + (360.0 if self.end_deg < self.start_deg else 0.0)
        step = (end - self.start_deg) / (POINTS_PER_PACKET - 1)
        return (self.start_deg + step * np.arange(POINTS_PER_PACKET)) % 360.0


def encode(packet: Packet) -> bytes:
    points = [v for pair in zip(packet.distances_mm, packet.intensities, strict=True) for v in pair]
    body = struct.pack(
        _LAYOUT,
        HEADER,
        VER_LEN,
        packet.speed_deg_s,
        round(packet.start_deg * 100) % 36000,
        *points,
        round(packet.end_deg * 100) % 36000,
        packet.timestamp_ms % 30000,
    )
    return body + bytes([crc8(body)])


class PacketParser:
    """Bytes in, whole packets out; a packet whose CRC fails is dropped and counted (`crc_errors`), and the
    search for the next header starts one byte on."""

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.crc_errors = 0
        self.packets = 0

    def feed(self, data: bytes) -> list[Packet]:
        self._buffer += data
        out = []
        while True:
            start = self._buffer.find(bytes([HEADER, VER_LEN]))
            if start < 0:
                del self._buffer[: max(0, len(self._buffer) - 1)]
                return out
            del self._buffer[:start]
            if len(self._buffer) < PACKET_BYTES:
                return out
            raw = bytes(self._buffer[:PACKET_BYTES])
            if crc8(raw[:-1]) != raw[-1]:
                self.crc_errors += 1
                del self._buffer[:1]
                continue
            del self._buffer[:PACKET_BYTES]
            self.packets += 1
            fields = struct.unpack(_LAYOUT, raw[:-1])
            points = fields[4:-2]
            out.append(
                Packet(
                    fields[2],
                    fields[3] / 100.0,
                    fields[-2] / 100.0,
                    tuple(points[0::2]),
                    tuple(points[1::2]),
                    fields[-1],
                )
            )


class ScanAssembler:
    """Packets in, one `LaserScan` a turn out (when the angle wraps past 0): each point in the beam of its angle
    (counter-clockwise from the robot's heading, as the simulated lidar's), the nearest return of a beam kept.
    `mount_yaw_rad`: where the sensor's 0 deg points, counter-clockwise from the robot's heading."""

    def __init__(self, beams: int = SCAN_BEAMS, mount_yaw_rad: float = 0.0, height_m: float = 0.0) -> None:
        self.beams = beams
        self.mount_yaw = mount_yaw_rad
        self.height_m = height_m
        self._ranges = np.full(beams, np.inf, dtype=np.float32)
        self._last_start: float | None = None
        self._points = 0

    def add(self, packet: Packet, stamp_s: float) -> LaserScan | None:
        scan = None
        if self._last_start is not None and packet.start_deg < self._last_start and self._points:
            scan = LaserScan(
                stamp_s, -math.pi, 2 * math.pi / self.beams, RANGE_MIN_M, RANGE_MAX_M, self._ranges, self.height_m
            )
            self._ranges = np.full(self.beams, np.inf, dtype=np.float32)
            self._points = 0
        self._last_start = packet.start_deg
        ranges = np.array(packet.distances_mm, dtype=np.float32) / 1000.0
        valid = (ranges >= RANGE_MIN_M) & (ranges <= RANGE_MAX_M)
        angles = self.mount_yaw - np.radians(packet.angles_deg()[valid])  # clockwise to counter-clockwise
        beam = np.floor(((angles + math.pi) % (2 * math.pi)) / (2 * math.pi / self.beams)).astype(np.int64)
        beam = np.clip(beam, 0, self.beams - 1)
        np.minimum.at(self._ranges, beam, ranges[valid])
        self._points += len(packet.distances_mm)
        return scan


def packets_from_scan(
    scan: LaserScan, speed_deg_s: int = 3600, mount_yaw_rad: float = 0.0, first_timestamp_ms: int = 0
) -> list[Packet]:
    """One turn of packets that would give `scan` (the emulator's side of `ScanAssembler`): the scan's ranges
    sampled at 12 points a packet, clockwise from 0 deg."""
    points = EMULATED_POINTS
    step_deg = 360.0 / points
    cw = np.arange(points) * step_deg
    ccw = (mount_yaw_rad - np.radians(cw) + math.pi) % (2 * math.pi) - math.pi
    index = np.clip(
        np.round((ccw - scan.angle_min) / scan.angle_increment).astype(np.int64) % len(scan.ranges),
        0,
        len(scan.ranges) - 1,
    )
    ranges = scan.ranges[index]
    mm = np.where(np.isfinite(ranges) & (ranges <= RANGE_MAX_M), np.round(ranges * 1000), 0).astype(int)
    packets = []
    ms_per_packet = POINTS_PER_PACKET * step_deg / speed_deg_s * 1000
    for k, i in enumerate(range(0, points - POINTS_PER_PACKET + 1, POINTS_PER_PACKET)):
        packets.append(
            Packet(
                speed_deg_s,
                float(cw[i]),
                float(cw[i + POINTS_PER_PACKET - 1]),
                tuple(int(v) for v in mm[i : i + POINTS_PER_PACKET]),
                tuple(200 if v else 0 for v in mm[i : i + POINTS_PER_PACKET]),
                int(first_timestamp_ms + k * ms_per_packet) % 30000,
            )
        )
    return packets
