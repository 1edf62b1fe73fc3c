"""Dynamixel Protocol 2.0 framing: CRC-16, byte stuffing, and an incremental packet parser.

Written from the protocol's public specification, for the bus emulator (the backend itself talks through the
real `dynamixel-sdk`). A packet is FF FF FD 00, ID, LEN_L LEN_H (instruction + parameters + CRC), the
instruction, its parameters (FF FF FD stuffed to FF FF FD FD), then the CRC-16 (polynomial 0x8005) of all of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
MAX_PACKET = 1024


class Instruction(IntEnum):
    PING = 0x01
    READ = 0x02
    WRITE = 0x03
    REG_WRITE = 0x04
    ACTION = 0x05
    FACTORY_RESET = 0x06
    REBOOT = 0x08
    CLEAR = 0x10
    STATUS = 0x55
    SYNC_READ = 0x82
    SYNC_WRITE = 0x83
    FAST_SYNC_READ = 0x8A
    BULK_READ = 0x92
    BULK_WRITE = 0x93


class StatusError(IntEnum):
    """The error field of a status packet (bit 7, the alert bit, says a hardware error is latched)."""

    NONE = 0
    RESULT_FAIL = 1
    INSTRUCTION = 2
    CRC = 3
    DATA_RANGE = 4
    DATA_LENGTH = 5
    DATA_LIMIT = 6
    ACCESS = 7


ALERT_BIT = 0x80


def _crc_table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return table


_TABLE = _crc_table()


def crc16(data: bytes, crc: int = 0) -> int:
    """CRC-16 (IBM, polynomial 0x8005) of `data`, continuing from `crc` (the CRC of what came before it)."""
    for byte in data:
        crc = ((crc << 8) ^ _TABLE[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """FF FF FD inside the instruction and parameters becomes FF FF FD FD (so it cannot look like a header)."""
    out = bytearray()
    for byte in body:
        out.append(byte)
        if byte == 0xFD and out[-3:-1] == b"\xff\xff" and len(out) >= 3:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    out = bytearray()
    i = 0
    while i < len(body):
        out.append(body[i])
        if body[i] == 0xFD and i + 1 < len(body) and body[i + 1] == 0xFD and out[-3:-1] == b"\xff\xff":
            i += 1  # drop the stuffed FD
        i += 1
    return bytes(out)


def encode(packet_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A whole packet, stuffed, with its CRC. A status packet's `params` start with its error byte."""
    body = stuff(bytes([instruction]) + params)
    length = len(body) + 2
    head = HEADER + bytes([packet_id, length & 0xFF, length >> 8]) + body
    crc = crc16(head)
    return head + bytes([crc & 0xFF, crc >> 8])


def status(packet_id: int, error: int, params: bytes = b"") -> bytes:
    return encode(packet_id, Instruction.STATUS, bytes([error]) + params)


def fast_sync_status(replies: list[tuple[int, int, bytes]]) -> bytes:
    """The one status packet of a Fast Sync Read: each servo in turn appends its error, ID, data and the CRC of the
    packet so far (the last one is the packet's CRC). Not stuffed: the SDK reads it as sent.
    `replies`: (error, servo ID, data) in the order the read asked for them."""
    length = 1 + sum(len(data) + 4 for _, _, data in replies)
    out = bytearray(HEADER + bytes([BROADCAST_ID, length & 0xFF, length >> 8, Instruction.STATUS]))
    crc = crc16(bytes(out))
    for error, servo_id, data in replies:
        part = bytes([error, servo_id]) + data
        crc = crc16(part, crc)  # each servo continues the CRC of the packet so far
        out += part
        out += bytes([crc & 0xFF, crc >> 8])
        crc = crc16(bytes([crc & 0xFF, crc >> 8]), crc)
    return bytes(out)


@dataclass(frozen=True)
class Packet:
    packet_id: int
    instruction: int
    params: bytes  # unstuffed
    crc_ok: bool = True


class PacketParser:
    """Bytes in, whole packets out; junk before a header is skipped, a packet whose CRC fails is still returned
    (`crc_ok` False) so that the receiver can answer with a CRC error, as a servo does."""

    def __init__(self) -> None:
        self._buffer = bytearray()

    def feed(self, data: bytes) -> list[Packet]:
        self._buffer += data
        packets = []
        while True:
            start = self._buffer.find(HEADER)
            if start < 0:
                del self._buffer[: max(0, len(self._buffer) - 3)]  # keep what may be a header's beginning
                return packets
            del self._buffer[:start]
            if len(self._buffer) < 7:
                return packets
            length = self._buffer[5] | self._buffer[6] << 8
            if length < 3 or length > MAX_PACKET:
                del self._buffer[:4]  # not a packet after all
                continue
            if len(self._buffer) < 7 + length:
                return packets
            raw = bytes(self._buffer[: 7 + length])
            del self._buffer[: 7 + length]
            crc = raw[-2] | raw[-1] << 8
            body = unstuff(raw[7:-2])
            packets.append(Packet(raw[4], body[0], body[1:], crc16(raw[:-2]) == crc))
