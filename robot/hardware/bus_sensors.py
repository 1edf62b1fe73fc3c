"""The sensor boards on the servo bus, read in the same control tick as the servos: the OpenCR's IMU (ID 200) and
the FSR foot modules (IDs 111 and 112). Their control tables differ from the servos' (and from each other's), so
they are read with one Protocol 2.0 bulk read (each board its own block) right after the servos' sync read.

A board that does not answer keeps its last values for the tick and is charged a failure; after three failures
in a row it is declared lost and left out of the read (so the others keep coming), said in `lost`. A board that
was never found at start is `missing`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from dynamixel_sdk import COMM_RX_CORRUPT, COMM_SUCCESS, GroupBulkRead, PacketHandler, PortHandler

from robot.hardware import fsr, opencr
from robot.sensors.imu import ImuSample

log = logging.getLogger(__name__)

LOST_AFTER_FAILED_READS = 3
PING_ATTEMPTS = 5  # see robot.hardware.bus.PING_ATTEMPTS
INSTRUCTION_OVERHEAD_BYTES = 10
BULK_PARAMS_PER_DEVICE = 5
STATUS_OVERHEAD_BYTES = 11


@dataclass(frozen=True)
class Board:
    name: str
    device_id: int
    block: tuple[int, int]  # start address, length


OPENCR = Board("OpenCR IMU", opencr.OPENCR_ID, opencr.TICK_BLOCK)
LEFT_FOOT = Board("left foot FSR", fsr.LEFT_FSR_ID, fsr.TICK_BLOCK)
RIGHT_FOOT = Board("right foot FSR", fsr.RIGHT_FSR_ID, fsr.TICK_BLOCK)


@dataclass
class BoardHealth:
    failures: int = 0
    lost: bool = False
    missing: bool = False
    reads: int = 0
    failed_reads: int = 0
    crc_errors: int = 0
    last_read_s: float | None = None


@dataclass(frozen=True)
class BoardReading:
    """This tick's sensor boards: the IMU sample (None if the OpenCR is not read), the feet's pad forces (2, 4),
    left then right, NaN for a foot whose module is not read; `lost` and `missing` name the boards at fault."""

    imu: ImuSample | None
    feet: np.ndarray
    feet_stamp_s: float | None
    lost: tuple[str, ...] = ()
    missing: tuple[str, ...] = ()


@dataclass
class _Last:
    imu: ImuSample | None = None
    feet: np.ndarray = field(default_factory=lambda: np.full((2, 4), np.nan))
    feet_stamp_s: float | None = None


class BusSensors:
    """`imu`: the OpenCR is on the bus; `feet`: the FSR modules are. `clock`: the body's clock, for stamps."""

    def __init__(
        self,
        port: PortHandler,
        packets: PacketHandler,
        imu: bool = True,
        feet: bool = True,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.port = port
        self.packets = packets
        self.boards = ([OPENCR] if imu else []) + ([LEFT_FOOT, RIGHT_FOOT] if feet else [])
        self.health = {b.device_id: BoardHealth() for b in self.boards}
        self.clock = clock
        self._last = _Last()
        self._reader: GroupBulkRead | None = None

    @property
    def empty(self) -> bool:
        return not self.boards

    def probe(self) -> list[str]:
        """Ping every board; those that do not answer are missing (left out of the reads). Their names."""
        silent = []
        for board in self.boards:
            for _ in range(PING_ATTEMPTS):
                model, result, _ = self.packets.ping(self.port, board.device_id)
                if result == COMM_SUCCESS:
                    break
            if result != COMM_SUCCESS:
                self.health[board.device_id].missing = True
                silent.append(f"{board.name} (id {board.device_id})")
            elif board is OPENCR and model != opencr.OPENCR_MODEL:
                log.warning(
                    "id %d answers as model %#x, not the OpenCR's %#x", board.device_id, model, opencr.OPENCR_MODEL
                )
        self._reader = None
        return silent

    def wire_bytes(self) -> int:
        """Bytes on the wire each tick for the bulk read: the instruction, then each board's status packet."""
        boards = self._live()
        if not boards:
            return 0
        asked = INSTRUCTION_OVERHEAD_BYTES + BULK_PARAMS_PER_DEVICE * len(boards)
        return asked + sum(STATUS_OVERHEAD_BYTES + b.block[1] for b in boards)

    def read(self) -> BoardReading:
        """One bulk read of every live board (nothing on the wire when there are none)."""
        boards = self._live()
        if boards:
            self._bulk_read(boards)
        last = self._last
        return BoardReading(
            imu=last.imu if self._readable(OPENCR) else None,
            feet=last.feet.copy(),
            feet_stamp_s=last.feet_stamp_s,
            lost=tuple(b.name for b in self.boards if self.health[b.device_id].lost),
            missing=tuple(b.name for b in self.boards if self.health[b.device_id].missing),
        )

    # internals -----------------------------------------------------------------------------------------------

    def _readable(self, board: Board) -> bool:
        health = self.health.get(board.device_id)
        return health is not None and not (health.lost or health.missing)

    def _live(self) -> list[Board]:
        return [b for b in self.boards if self._readable(b)]

    def _bulk_read(self, boards: list[Board]) -> None:
        if self._reader is None:
            self._reader = GroupBulkRead(self.port, self.packets)
            for b in boards:
                self._reader.addParam(b.device_id, *b.block)
        reader = self._reader
        for entry in reader.data_dict.values():
            entry[0] = []
        result = reader.txRxPacket()
        now = self.clock()
        for b in boards:
            data = reader.data_dict[b.device_id][0]
            health = self.health[b.device_id]
            health.reads += 1
            if len(data) == b.block[1]:
                health.failures = 0
                health.last_read_s = now
                self._store(b, bytes(data), now)
        if result == COMM_SUCCESS:
            return
        self.port.clearPort()  # what came late must not be taken for the next tick's replies
        culprit = next((b for b in boards if len(reader.data_dict[b.device_id][0]) != b.block[1]), None)
        if culprit is None:
            return
        health = self.health[culprit.device_id]
        health.failures += 1
        health.failed_reads += 1
        health.crc_errors += result == COMM_RX_CORRUPT
        if health.failures >= LOST_AFTER_FAILED_READS and not health.lost:
            health.lost = True
            log.error("%s (id %d) stopped answering", culprit.name, culprit.device_id)
            self._reader = None

    def _store(self, board: Board, data: bytes, now: float) -> None:
        if board is OPENCR:
            self._last.imu = opencr.decode_block(data, now)
        else:
            self._last.feet[0 if board is LEFT_FOOT else 1] = fsr.decode_block(data)
            self._last.feet_stamp_s = now
