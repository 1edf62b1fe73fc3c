"""A BNO055 on the far end of a pseudo-terminal, answering its UART protocol (`bno055_protocol`): for tests of the
driver without the chip. Faults to inject: replies that are garbled (`corrupt_replies`), a chip that goes silent,
and the cable pulled (`unplug`: the port fails)."""

from __future__ import annotations

import contextlib
import os
import select

import numpy as np

from robot.sensors import bno055_protocol as bno
from robot.sensors.pty_device import PtyDevice


class Bno055Emulator(PtyDevice):
    thread_name = "bno055-emulator"

    def __init__(self) -> None:
        super().__init__()
        self.registers = bytearray(0x80)
        self.registers[bno.CHIP_ID] = bno.CHIP_ID_VALUE
        self.corrupt_replies = 0
        self.silent = False
        self.commands = 0
        self._buffer = bytearray()
        self.sense(np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.array([0.0, 0.0, 9.81]))

    def sense(self, quat: np.ndarray, gyro: np.ndarray, accel: np.ndarray) -> None:
        with self._lock:
            start, length = bno.SAMPLE_BLOCK
            self.registers[start : start + length] = bno.encode_sample(quat, gyro, accel)

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.05)
            if not ready:
                continue
            try:
                self._buffer += os.read(self._master, 256)
            except OSError:
                return
            for reply in self._answers():
                with contextlib.suppress(OSError):
                    os.write(self._master, reply)

    def _answers(self) -> list[bytes]:
        out = []
        while len(self._buffer) >= 4:
            if self._buffer[0] != bno.START:
                del self._buffer[0]
                out.append(bytes([bno.STATUS, bno.WRONG_START_BYTE]))
                continue
            kind, register, length = self._buffer[1], self._buffer[2], self._buffer[3]
            if kind == bno.WRITE and len(self._buffer) < 4 + length:
                break
            data = bytes(self._buffer[4 : 4 + length]) if kind == bno.WRITE else b""
            del self._buffer[: 4 + len(data)]
            self.commands += 1
            reply = self._answer(kind, register, length, data)
            if self.silent:
                continue
            if self.corrupt_replies > 0:
                self.corrupt_replies -= 1
                reply = bytes([0x5A]) + reply[1:]  # a garbled start byte
            out.append(reply)
        return out

    def _answer(self, kind: int, register: int, length: int, data: bytes) -> bytes:
        if length == 0:
            return bytes([bno.STATUS, bno.MIN_LENGTH])
        if register + length > len(self.registers):
            return bytes([bno.STATUS, bno.REGMAP_INVALID_ADDRESS])
        with self._lock:
            if kind == bno.WRITE:
                self.registers[register : register + length] = data
                return bytes([bno.STATUS, bno.WRITE_SUCCESS])
            return bytes([bno.READ_OK, length]) + bytes(self.registers[register : register + length])
