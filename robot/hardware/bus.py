"""The servo bus (as LeRobot's MotorsBus): the XM430s of a `HardwareConfig` behind one U2D2, through the real
`dynamixel-sdk`. Each control tick is one sync write of the goal positions and one sync read of current, velocity
and position (a Fast Sync Read: one reply packet for every servo, 7 bytes a servo shorter, unless the
configuration says otherwise); hardware errors, voltage and temperature are read in turn at a tenth of the rate.
When a fast read fails, the same block is read the plain way to find the servo at fault. A servo that does not
answer three reads in a row is declared lost (and left out of the reads, so the others keep coming).

Servos are set up once at start (`prepare`: position mode, no return delay; shipped XM430s wait 500 us before
each reply, 12 ms a tick for 24 of them) and, with torque on, their bus watchdog is armed: a servo that hears
nothing for `bus_watchdog_ms` (the host hung or died) stops where it is, whatever the host is doing.

Joint values are in the model's units (rad; m for a gripper's finger); the bus converts through each joint's
direction, offset and scale, and clamps every goal to the joint's limits before it is written.
"""

from __future__ import annotations

import logging
import select
import time
from dataclasses import dataclass

import numpy as np
from dynamixel_sdk import COMM_RX_CORRUPT, COMM_SUCCESS, GroupSyncRead, GroupSyncWrite, PacketHandler, PortHandler

from robot.hardware import control_table as ct
from robot.hardware.config import HardwareConfig, JointServo
from robot.hardware.xm430 import HardwareError

log = logging.getLogger(__name__)

LOST_AFTER_FAILED_READS = 3
# A reply is also lost when the host is late, not the servo: the SDK reads the port, and if the host is descheduled
# past the packet's timeout (~34 ms) before it looks at the clock, the reply that came meanwhile is a timeout (the
# suite beside stress-ng and two simulations: a servo missing from `hardware check` after 3 pings, a read lost 5
# times in a row). Asked again, a servo that is there answers.
PING_ATTEMPTS = 5
# A servo that answered its ping is there: a read of it is asked this often before it fails, waiting twice as long
# after each miss (a loaded computer missed three replies in a row once, in the test suite beside two simulations).
READ_ATTEMPTS = 7
LATE_REPLY_WAIT_S = 0.05  # after a missed reply: how long to let it arrive late before dropping it
LATE_REPLY_MAX_WAIT_S = 0.4  # ... doubled after each miss, up to this
FAST = (ct.PRESENT_CURRENT.address, 10)  # current (2), velocity (4), position (4): every tick
POSITION_CONTROL_MODE = 3
SLOW_ERRORS = (ct.HARDWARE_ERROR_STATUS.address, 1)
SLOW_POWER = (ct.PRESENT_INPUT_VOLTAGE.address, 3)  # voltage (2), temperature (1)
SLOW_EVERY = 10  # ticks between two reads of each slow block (one of the two every SLOW_EVERY // 2 ticks)
# A slow block is read in a tick's slack; when the ticks leave none this many ticks in a row, it is read anyway
# (a servo's hardware error or temperature is then said at most about this late).
SLOW_MAX_DEFER_TICKS = 50
# A slow block is read after a tick only with its wire time and this much more left before the next tick (its
# packets' handling in Python takes about 0.5-1 ms; the rest is room for a late wake-up).
SLOW_READ_MARGIN_S = 0.002
STATUS_OVERHEAD_BYTES = 11  # header, ID, length, instruction, error, CRC of a status packet
FAST_STATUS_HEADER_BYTES = 8  # one header, ID, length and instruction for all the servos of a Fast Sync Read
FAST_STATUS_PER_SERVO_BYTES = 4  # error, ID, CRC
INSTRUCTION_OVERHEAD_BYTES = 10  # header, ID, length, instruction, CRC
SYNC_PARAMS_BYTES = 4  # start address and data length


class BusError(RuntimeError):
    pass


class LowLatencyPortHandler(PortHandler):
    """The SDK's port with the packet timeout computed for the U2D2's latency timer as set (1 ms with the udev rule
    the README gives; the SDK assumes the FTDI default of 16 ms, which makes every missing reply cost 34 ms)."""

    def __init__(self, port_name: str, latency_timer_ms: float = 1.0, reply_margin_ms: float = 2.0) -> None:
        super().__init__(port_name)
        self.latency_timer_ms = latency_timer_ms
        self.reply_margin_ms = reply_margin_ms

    def setPacketTimeout(self, packet_length: int) -> None:  # the SDK names it
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = self.tx_time_per_byte * packet_length + self.latency_timer_ms * 2.0 + self.reply_margin_ms

    def readPort(self, length: int) -> bytes:
        """The SDK polls a non-blocking port in a loop until the reply is in: at real-time priority that spin
        takes a whole core and can starve the kernel threads that deliver the reply's bytes (the emulator's
        pseudo-terminal, the USB serial driver under load), and trips the kernel's real-time throttling. Sleep
        in select() until bytes come or the packet's time is up instead."""
        if self.ser.in_waiting == 0:
            remaining_ms = self.packet_timeout - (self.getCurrentTime() - self.packet_start_time)
            if remaining_ms > 0:
                select.select([self.ser.fileno()], [], [], remaining_ms / 1e3)
        return self.ser.read(length)


@dataclass(frozen=True)
class ServoInfo:
    joint: str
    servo_id: int
    model: int | None  # None: it did not answer
    firmware: int | None = None
    hardware_error: int = 0


@dataclass(frozen=True)
class BusBudget:
    """Bytes on the wire per control tick and the share of the tick they take at the configured baud rate."""

    bytes_per_tick: float
    wire_ms_per_tick: float
    latency_ms_per_tick: float
    utilisation: float  # (wire + latency) / tick period

    @property
    def fits(self) -> bool:
        return self.utilisation <= 0.8


def read_bytes(servos: int, data_bytes: int, fast: bool) -> int:
    """Bytes on the wire for one sync read of `data_bytes` from each servo: the instruction, then the replies."""
    asked = INSTRUCTION_OVERHEAD_BYTES + SYNC_PARAMS_BYTES + servos
    if fast:
        return asked + FAST_STATUS_HEADER_BYTES + servos * (FAST_STATUS_PER_SERVO_BYTES + data_bytes)
    return asked + servos * (STATUS_OVERHEAD_BYTES + data_bytes)


def tick_budget(
    servos: int,
    baudrate: int,
    control_hz: float,
    latency_timer_ms: float,
    fast: bool = True,
    extra_bytes: int = 0,
    extra_reads: int = 0,
) -> BusBudget:
    """What one tick costs: a sync write of 4-byte goals, a sync read of the fast block, and the slow blocks'
    share; each transaction waits out the USB latency once. `extra_bytes` and `extra_reads`: the sensor boards'
    bulk read, if any (see `bus_sensors.BusSensors.wire_bytes`)."""
    write = INSTRUCTION_OVERHEAD_BYTES + SYNC_PARAMS_BYTES + servos * 5
    read = read_bytes(servos, FAST[1], fast)
    slow = sum(read_bytes(servos, n, fast) for _, n in (SLOW_ERRORS, SLOW_POWER)) / SLOW_EVERY
    total = write + read + slow + extra_bytes
    wire_ms = total * 10 / baudrate * 1e3
    # the read (and the slow reads, and the sensors' bulk read) each wait for the USB frame
    latency_ms = latency_timer_ms * (1 + 2 / SLOW_EVERY + extra_reads)
    return BusBudget(total, wire_ms, latency_ms, (wire_ms + latency_ms) / (1e3 / control_hz))


@dataclass
class BusReading:
    """One tick's read: joint positions and velocities in joint units, servo current; NaN where a servo is lost."""

    positions: np.ndarray
    velocities: np.ndarray
    currents_a: np.ndarray
    voltages_v: np.ndarray
    temperatures_c: np.ndarray
    hardware_errors: np.ndarray
    lost: tuple[str, ...] = ()  # joints whose servo stopped answering
    failed_reads: int = 0
    read_ms: float = 0.0
    write_ms: float = 0.0


@dataclass
class _ServoHealth:
    failures: int = 0
    lost: bool = False


@dataclass
class BusCounters:
    ticks: int = 0
    failed_reads: int = 0
    crc_errors: int = 0
    timeouts: int = 0


class DynamixelBus:
    def __init__(self, config: HardwareConfig, port: PortHandler | None = None) -> None:
        self.config = config
        self.joints = config.joints
        self.port = port or LowLatencyPortHandler(config.port, config.latency_timer_ms, config.reply_margin_ms)
        self.packets = PacketHandler(2.0)
        self._health = {j.servo_id: _ServoHealth() for j in self.joints}
        self._index = {j.servo_id: i for i, j in enumerate(self.joints)}
        n = len(self.joints)
        self._last = BusReading(
            np.zeros(n), np.zeros(n), np.zeros(n), np.full(n, np.nan), np.full(n, np.nan), np.zeros(n, dtype=np.int64)
        )
        self._tick = 0
        self._slow_tick = 0  # the tick of the last slow block read
        self._slow_turn = 0  # which slow block is next
        self.counters = BusCounters()
        self._fast: GroupSyncRead | None = None
        self._is_open = False
        self._last_sent_s: float | None = None  # when the servos were last sent a packet
        self._longest_silence_s = 0.0  # the longest time they heard nothing, since `take_longest_silence_s`

    # lifecycle ---------------------------------------------------------------------------------------------------

    def open(self) -> None:
        if not self.port.openPort():
            raise BusError(f"cannot open {self.config.port}")
        if not self.port.setBaudRate(self.config.baudrate):
            raise BusError(f"{self.config.port} does not take {self.config.baudrate} baud")
        self._is_open = True
        self._fast = self._reader(*FAST)

    def close(self) -> None:
        if self._is_open:
            self.port.closePort()
            self._is_open = False

    def budget(self, extra_bytes: int = 0, extra_reads: int = 0) -> BusBudget:
        """This configuration's tick, with the sensor boards' read (`extra_bytes` in `extra_reads` reads) if any."""
        c = self.config
        return tick_budget(
            len(self.joints), c.baudrate, c.control_hz, c.latency_timer_ms, c.fast_sync_read, extra_bytes, extra_reads
        )

    def ping_all(self) -> list[ServoInfo]:
        """Every configured servo: its model and firmware, and its latched hardware error; model None if silent."""
        out = []
        for j in self.joints:
            for _ in range(PING_ATTEMPTS):  # one lost reply is a glitch, not a missing servo
                model, result, _ = self.packets.ping(self.port, j.servo_id)
                if result == COMM_SUCCESS:
                    break
                self._drop_late_reply()
            if result != COMM_SUCCESS:
                out.append(ServoInfo(j.joint, j.servo_id, None))
                continue
            firmware = self._read_byte(j, ct.FIRMWARE_VERSION)
            errors = self._read_byte(j, ct.HARDWARE_ERROR_STATUS)
            out.append(ServoInfo(j.joint, j.servo_id, model, firmware, errors))
        return out

    def _read_byte(self, joint: JointServo, field: ct.Field) -> int:
        """One byte of a servo's control table, asked again if the reply is lost (a servo that answered its ping
        is there); BusError if it never comes."""
        for attempt in range(READ_ATTEMPTS):
            value, result, _ = self.packets.read1ByteTxRx(self.port, joint.servo_id, field.address)
            if result == COMM_SUCCESS:
                return value
            self._drop_late_reply(min(LATE_REPLY_WAIT_S * 2**attempt, LATE_REPLY_MAX_WAIT_S))
        raise BusError(f"servo {joint.servo_id} ({joint.joint}): {self.packets.getTxRxResult(result)}")

    def _drop_late_reply(self, wait_s: float = LATE_REPLY_WAIT_S) -> None:
        """A reply that missed its time may still come, and the next request would take it for its own (a
        firmware version read as a hardware error): let it arrive (`wait_s`), then drop it."""
        time.sleep(wait_s)
        self.port.clearPort()

    def prepare(self) -> list[str]:
        """Torque off, then each servo in position control with no return delay (EEPROM: written only where it
        differs). What was changed, said for the operator."""
        self.set_torque(False)
        changes = []
        for j in self.joints:
            for field, wanted in ((ct.OPERATING_MODE, POSITION_CONTROL_MODE), (ct.RETURN_DELAY_TIME, 0)):
                value = self._read_byte(j, field)
                if value != wanted:
                    self._write_byte(j, field, wanted)
                    changes.append(f"servo {j.servo_id} ({j.joint}): address {field.address} {value} -> {wanted}")
        return changes

    def _write_byte(self, joint: JointServo, field: ct.Field, value: int) -> None:
        """One byte of a servo's control table. A lost status is asked about again (the write may have landed:
        it is read back); a servo that refuses the write, or never answers, is a `BusError`."""
        for _ in range(PING_ATTEMPTS):
            result, error = self.packets.write1ByteTxRx(self.port, joint.servo_id, field.address, value)
            if result == COMM_SUCCESS and not error & 0x7F:
                return
            if result == COMM_SUCCESS:
                break  # the servo answered, and refused
            self._drop_late_reply()
            if self._read_byte(joint, field) == value:
                return
        raise BusError(f"servo {joint.servo_id} ({joint.joint}): cannot set address {field.address}")

    def arm_watchdog(self, milliseconds: int) -> None:
        """Every servo's bus watchdog to `milliseconds` (0: off), cleared first (a tripped one takes no new
        value, and no goals, until it is set to 0)."""
        units = round(milliseconds / ct.BUS_WATCHDOG_UNIT_MS)
        self._sending()
        for value in (0, units) if units else (0,):
            writer = GroupSyncWrite(self.port, self.packets, ct.BUS_WATCHDOG.address, 1)
            for j in self.joints:
                writer.addParam(j.servo_id, list(ct.BUS_WATCHDOG.encode(value)))
            result = writer.txPacket()
            if result != COMM_SUCCESS:
                raise BusError(f"bus watchdog: {self.packets.getTxRxResult(result)}")

    def torque_held(self) -> list[str]:
        """Joints whose servo has torque on (at start-up: a robot process before this one died holding them)."""
        reader = self._reader(ct.TORQUE_ENABLE.address, 1)
        reader.txRxPacket()
        return [self.joints[self._index[i]].joint for i, data in reader.data_dict.items() if data and data[0]]

    def watchdog_tripped(self) -> list[str]:
        """Joints whose servo's bus watchdog has tripped (it stopped, and takes no goals until re-armed)."""
        reader = self._reader(ct.BUS_WATCHDOG.address, 1)
        reader.txRxPacket()
        return [
            self.joints[self._index[i]].joint
            for i, data in reader.data_dict.items()
            if data and ct.BUS_WATCHDOG.decode(bytes(data)) < 0
        ]

    # per tick ------------------------------------------------------------------------------------------------

    def take_longest_silence_s(self) -> float:
        """The longest the servos went without a packet since this was last asked: past their bus watchdog they
        have stopped and take no goals. The control loop's own tick-to-tick gap can miss such a silence (a host
        paused between one tick's last packet and the next tick's first, split across two ticks), and the servos
        then ignored every goal after it: a loaded test run once froze a controlled stop that way."""
        longest, self._longest_silence_s = self._longest_silence_s, 0.0
        return longest

    def _sending(self) -> None:
        now = time.perf_counter()
        if self._last_sent_s is not None:
            self._longest_silence_s = max(self._longest_silence_s, now - self._last_sent_s)
        self._last_sent_s = now

    def set_torque(self, enabled: bool) -> None:
        """Torque on or off for every servo that answers (one sync write, then checked)."""
        self._sending()
        writer = GroupSyncWrite(self.port, self.packets, ct.TORQUE_ENABLE.address, 1)
        for j in self.joints:
            writer.addParam(j.servo_id, [int(enabled)])
        result = writer.txPacket()
        if result != COMM_SUCCESS:
            raise BusError(f"torque {'on' if enabled else 'off'}: {self.packets.getTxRxResult(result)}")

    def write_goals(self, targets: np.ndarray) -> float:
        """Each target clamped to its joint's limits, converted to servo ticks, all in one sync write (ms taken)."""
        started = time.perf_counter()
        self._sending()
        writer = GroupSyncWrite(self.port, self.packets, ct.GOAL_POSITION.address, 4)
        for j, value in zip(self.joints, targets, strict=True):
            if self._health[j.servo_id].lost or not np.isfinite(value):
                continue
            writer.addParam(j.servo_id, list(ct.GOAL_POSITION.encode(j.to_ticks(j.clamp(float(value))))))
        result = writer.txPacket()
        if result != COMM_SUCCESS:
            raise BusError(f"goal positions: {self.packets.getTxRxResult(result)}")
        return (time.perf_counter() - started) * 1e3

    def read(self) -> BusReading:
        """This tick's reading: current, velocity and position (the last good values stand in for a servo that
        did not answer this time); the hardware errors, voltages and temperatures as `read_slow` last read them."""
        started = time.perf_counter()
        self._sending()
        self._tick += 1
        failed = self._read_block(self._fast, FAST)
        self.counters.ticks += 1
        self.counters.failed_reads += failed
        last = self._last  # the arrays kept up to date by _store; copied so the caller's cannot change under it
        return BusReading(
            last.positions.copy(),
            last.velocities.copy(),
            last.currents_a.copy(),
            last.voltages_v.copy(),
            last.temperatures_c.copy(),
            last.hardware_errors.copy(),
            lost=tuple(j.joint for j in self.joints if self._health[j.servo_id].lost),
            failed_reads=failed,
            read_ms=(time.perf_counter() - started) * 1e3,
        )

    @property
    def slow_due(self) -> bool:
        """A slow block is due: one of the two every SLOW_EVERY // 2 ticks."""
        return self._tick - self._slow_tick >= SLOW_EVERY // 2

    @property
    def slow_overdue(self) -> bool:
        """No slow block for SLOW_MAX_DEFER_TICKS ticks: read one whatever the tick's time."""
        return self._tick - self._slow_tick >= SLOW_MAX_DEFER_TICKS

    def slow_read_s(self) -> float:
        """What the larger slow block's read takes on the wire, with the USB latency (the caller's margin aside)."""
        servos = sum(not h.lost for h in self._health.values())
        wire_bytes = max(read_bytes(servos, n, self.config.fast_sync_read) for _, n in (SLOW_ERRORS, SLOW_POWER))
        return wire_bytes * 10 / self.config.baudrate + self.config.latency_timer_ms / 1e3

    def read_slow_if_room(self, room_s: float) -> bool:
        """The next slow block if one is due and its read fits in `room_s` with a margin, or whatever the room
        if it is overdue; whether one was read."""
        if not self.slow_due or (self.slow_read_s() + SLOW_READ_MARGIN_S > room_s and not self.slow_overdue):
            return False
        self.read_slow()
        return True

    def read_slow(self) -> int:
        """The next slow block in turn (the hardware errors, then voltage and temperature), read apart from the
        tick's own read so that the control path never waits for it (see `slow_due`). Returns the servos that
        failed."""
        block = (SLOW_ERRORS, SLOW_POWER)[self._slow_turn]
        self._slow_turn = 1 - self._slow_turn
        self._slow_tick = self._tick
        self._sending()
        failed = self._read_block(self._reader(*block), block)
        self.counters.failed_reads += failed
        return failed

    def reboot(self, joint: str) -> bool:
        """Reboot one servo (clears a latched hardware error; its torque comes back off). It is read again."""
        j = next(j for j in self.joints if j.joint == joint)
        result, _ = self.packets.reboot(self.port, j.servo_id)
        if result == COMM_SUCCESS:
            self._health[j.servo_id] = _ServoHealth()
            self._fast = self._reader(*FAST)
        return result == COMM_SUCCESS

    # internals -----------------------------------------------------------------------------------------------

    def _reader(self, address: int, length: int) -> GroupSyncRead:
        reader = GroupSyncRead(self.port, self.packets, address, length)
        for j in self.joints:
            if not self._health[j.servo_id].lost:
                reader.addParam(j.servo_id)
        return reader

    def _read_block(self, reader: GroupSyncRead, block: tuple[int, int]) -> int:
        """Sync read (fast, then plain if the fast one failed); the SDK stops at the first servo that does not
        answer, so that one is charged a failure and the ones after it keep their last values this tick.
        Returns the number of failed servos."""
        address, length = block
        ids = list(reader.data_dict)
        if not ids:
            return 0
        fast_result = COMM_SUCCESS
        if self.config.fast_sync_read:
            try:
                fast_result = reader.fastSyncRead()
            except (IndexError, ValueError):  # the SDK's parser trips on stale bytes (a reply that came too late)
                self.port.clearPort()
                fast_result = COMM_RX_CORRUPT
            if fast_result == COMM_SUCCESS:
                for servo_id in ids:
                    self._health[servo_id].failures = 0
                    self._store(servo_id, address, bytes(reader.data_dict[servo_id]))
                return 0
        for servo_id in ids:
            reader.data_dict[servo_id] = []
        result = reader.txRxPacket()
        answered = [i for i in ids if len(reader.data_dict.get(i) or []) == length]
        for servo_id in answered:
            self._health[servo_id].failures = 0
            self._store(servo_id, address, bytes(reader.data_dict[servo_id]))
        if result == COMM_SUCCESS:
            if fast_result != COMM_SUCCESS:
                self._count_failure(fast_result)  # a glitch the plain read got past
            return 0
        self._count_failure(result)
        culprit = next((i for i in ids if i not in answered), None)
        if culprit is None:
            return 0
        health = self._health[culprit]
        health.failures += 1
        if health.failures >= LOST_AFTER_FAILED_READS and not health.lost:
            health.lost = True
            joint = self.joints[self._index[culprit]].joint
            log.error("servo %d (%s) stopped answering", culprit, joint)
            self._fast = self._reader(*FAST)
        return 1

    def _count_failure(self, result: int) -> None:
        if result == COMM_RX_CORRUPT:
            self.counters.crc_errors += 1
        else:
            self.counters.timeouts += 1

    def _store(self, servo_id: int, address: int, data: bytes) -> None:
        i = self._index[servo_id]
        j = self.joints[i]
        last = self._last

        def field(f: ct.Field) -> int:
            return f.decode(data[f.address - address : f.address - address + f.size])

        if address == FAST[0]:
            last.currents_a[i] = abs(field(ct.PRESENT_CURRENT)) * ct.CURRENT_UNIT_A
            last.velocities[i] = field(ct.PRESENT_VELOCITY) * ct.VELOCITY_UNIT_RAD_S / (j.direction * j.scale)
            last.positions[i] = j.from_ticks(field(ct.PRESENT_POSITION))
        elif address == SLOW_ERRORS[0]:
            last.hardware_errors[i] = int(HardwareError(field(ct.HARDWARE_ERROR_STATUS)))
        elif address == SLOW_POWER[0]:
            last.voltages_v[i] = field(ct.PRESENT_INPUT_VOLTAGE) / 10.0
            last.temperatures_c[i] = field(ct.PRESENT_TEMPERATURE)
