"""A Dynamixel Protocol 2.0 bus with XM430s behind a pseudo-terminal: the real `dynamixel-sdk` opens its path as
it would a U2D2's /dev/ttyUSB0. For tests and benchmarks of the hardware backend without hardware.

Each emulated servo has the XM430 control table, a simple motor (position control with the servo's no-load
speed, current from the load, winding temperature), the bus watchdog (address 98: a servo with torque on that
hears nothing for that long stops where it is and refuses new goals until the watchdog is cleared) and faults to
inject: a dead servo, dropped replies (timeouts), corrupted replies (CRC errors), overheating. It answers ping,
read, write, sync read, Fast Sync Read, sync write and reboot (broadcast ping and sync read answered in the order
asked). Servos start as shipped (a 500 us return delay). With `wire_time` the emulator also takes the time the
bytes would take on the wire at the bus's baud rate, and each servo's return delay.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import multiprocessing as mp
import os
import select
import threading
import time
import tty
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any, Protocol

from robot.hardware import control_table as ct
from robot.hardware.emulated_faults import LATE_REPLY_S, ServoFaults
from robot.hardware.protocol2 import (
    ALERT_BIT,
    BROADCAST_ID,
    Instruction,
    Packet,
    PacketParser,
    StatusError,
    fast_sync_status,
    status,
)
from robot.hardware.sensor_emulators import EmulatedBoard, op3_sensor_boards
from robot.hardware.xm430 import HardwareError

NO_LOAD_SPEED_RAD_S = 46.0 * 2 * math.pi / 60  # 46 rpm at 12 V
STALL_TORQUE_NM = 4.1
RESISTANCE_OHM = 12.0 / 2.3
THERMAL_K_PER_W, THERMAL_TAU_S = 6.0, 360.0
EMULATOR_FIFO_PRIORITY = 50  # above the robot worker's own threads (40), as hardware is


class EmulatedXM430:
    def __init__(self, servo_id: int, position_rad: float = 0.0, ambient_c: float = 25.0) -> None:
        self.table = bytearray(ct.TABLE_SIZE)
        self.faults = ServoFaults()
        self.ambient_c = ambient_c
        self.temperature_c = ambient_c
        self.load_nm = 0.0  # external torque on the output (gravity, a jam): what the servo must hold
        self.voltage_v = 12.0
        self._position = position_rad
        self._velocity = 0.0
        self.driven = False  # the output moves as a physics engine says (`drive`), not by this servo's own model
        for field, value in (
            (ct.MODEL_NUMBER, ct.XM430_W350_MODEL),
            (ct.FIRMWARE_VERSION, 48),
            (ct.ID, servo_id),
            (ct.BAUD_RATE, 3),
            (ct.RETURN_DELAY_TIME, ct.RETURN_DELAY_FACTORY),
            (ct.OPERATING_MODE, 3),
            (ct.TEMPERATURE_LIMIT, 80),
            (ct.MAX_VOLTAGE_LIMIT, 160),
            (ct.MIN_VOLTAGE_LIMIT, 95),
            (ct.CURRENT_LIMIT, 1193),
            (ct.MAX_POSITION_LIMIT, 4095),
            (ct.MIN_POSITION_LIMIT, 0),
            (ct.SHUTDOWN, 0x34),
            (ct.STATUS_RETURN_LEVEL, 2),
            (ct.POSITION_P_GAIN, 800),
            (ct.PROFILE_VELOCITY, 0),
        ):
            self._set(field, value)
        self._set(ct.GOAL_POSITION, self._ticks(position_rad))
        self.last_heard_s = time.monotonic()  # the last packet addressed to this servo (the bus watchdog's clock)
        self._refresh_present()

    @property
    def servo_id(self) -> int:
        return self.get(ct.ID)

    def get(self, field: ct.Field) -> int:
        return field.decode(bytes(self.table[field.address : field.address + field.size]))

    @property
    def status_return_level(self) -> int:
        return self.get(ct.STATUS_RETURN_LEVEL)

    def ping_info(self) -> bytes:
        """Model number and firmware version, as a ping's reply carries them."""
        return ct.MODEL_NUMBER.encode(self.get(ct.MODEL_NUMBER)) + bytes([self.get(ct.FIRMWARE_VERSION)])

    def _set(self, field: ct.Field, value: int) -> None:
        self.table[field.address : field.address + field.size] = field.encode(value)

    @staticmethod
    def _ticks(rad: float) -> int:
        return round(rad * ct.POSITION_PER_RAD + ct.POSITION_CENTRE)

    @property
    def position_rad(self) -> float:
        return self._position

    @property
    def torque_enabled(self) -> bool:
        return self.get(ct.TORQUE_ENABLE) == 1

    @property
    def goal_rad(self) -> float:
        """The goal position (rad from the centre), what a plant driving the output steers it to."""
        return (self.get(ct.GOAL_POSITION) - ct.POSITION_CENTRE) / ct.POSITION_PER_RAD

    def drive(self, position_rad: float, velocity_rad_s: float, torque_nm: float) -> None:
        """The output as the plant (the rig's physics) moved it, and the torque it took: from now on the servo
        reports these instead of moving by its own model; its heat, current and protections follow the torque."""
        self.driven = True
        self._position = position_rad
        self._velocity = velocity_rad_s
        self.load_nm = torque_nm
        self._refresh_present()

    # the motor -----------------------------------------------------------------------------------------------

    @property
    def watchdog_tripped(self) -> bool:
        return self.get(ct.BUS_WATCHDOG) < 0

    def _check_watchdog(self) -> None:
        watchdog = self.get(ct.BUS_WATCHDOG)
        silent_ms = (time.monotonic() - self.last_heard_s) * 1e3
        if self.get(ct.TORQUE_ENABLE) and watchdog > 0 and silent_ms > watchdog * ct.BUS_WATCHDOG_UNIT_MS:
            self._set(ct.BUS_WATCHDOG, -1)
            self._set(ct.GOAL_POSITION, self._ticks(self._position))  # it stops where it is, torque still on

    def step(self, dt: float) -> None:
        self._check_watchdog()
        torque_on = self.get(ct.TORQUE_ENABLE) == 1
        if self.driven:  # the plant moves the output; the torque it measured is what the motor gives
            torque = min(STALL_TORQUE_NM, abs(self.load_nm)) if torque_on else 0.0
        elif torque_on:
            goal = (self.get(ct.GOAL_POSITION) - ct.POSITION_CENTRE) / ct.POSITION_PER_RAD
            error = goal - self._position
            speed = max(-NO_LOAD_SPEED_RAD_S, min(NO_LOAD_SPEED_RAD_S, error / max(dt, 0.02)))
            # the load slows it down, and past stall it cannot hold
            slack = max(0.0, 1.0 - abs(self.load_nm) / STALL_TORQUE_NM)
            self._velocity = speed * slack
            torque = min(STALL_TORQUE_NM, abs(self.load_nm) + abs(error) * 8.0)
        else:
            self._velocity = 0.0
            torque = 0.0
        if not self.driven:
            self._position += self._velocity * dt
        current = torque / STALL_TORQUE_NM * 2.3 + 0.04 * torque_on
        heat = current**2 * RESISTANCE_OHM
        self.temperature_c += dt / THERMAL_TAU_S * (heat * THERMAL_K_PER_W - (self.temperature_c - self.ambient_c))
        errors = HardwareError(self.get(ct.HARDWARE_ERROR_STATUS))
        if self.temperature_c >= self.get(ct.TEMPERATURE_LIMIT):
            errors |= HardwareError.OVERHEATING
        if not self.get(ct.MIN_VOLTAGE_LIMIT) <= self.voltage_v * 10 <= self.get(ct.MAX_VOLTAGE_LIMIT):
            errors |= HardwareError.INPUT_VOLTAGE
        self._set(ct.HARDWARE_ERROR_STATUS, int(errors))
        if int(errors) & self.get(ct.SHUTDOWN):
            self._set(ct.TORQUE_ENABLE, 0)  # the servo protects itself: torque off until rebooted
        self._current_a = current if torque_on else 0.0
        self._refresh_present()

    def _refresh_present(self) -> None:
        self._set(ct.PRESENT_POSITION, self._ticks(self._position))
        self._set(ct.PRESENT_VELOCITY, round(self._velocity / ct.VELOCITY_UNIT_RAD_S))
        self._set(ct.PRESENT_CURRENT, round(getattr(self, "_current_a", 0.0) / ct.CURRENT_UNIT_A))
        self._set(ct.PRESENT_INPUT_VOLTAGE, round(self.voltage_v * 10))
        self._set(ct.PRESENT_TEMPERATURE, max(0, min(255, round(self.temperature_c))))
        self._set(ct.MOVING, int(abs(self._velocity) > 0.01))

    # the control table through the protocol ------------------------------------------------------------------

    def read(self, address: int, length: int) -> tuple[int, bytes]:
        if length < 1 or address + length > ct.TABLE_SIZE:
            return StatusError.DATA_LENGTH, b""
        return StatusError.NONE, bytes(self.table[address : address + length])

    def write(self, address: int, data: bytes) -> int:
        if not data or address + len(data) > ct.TABLE_SIZE:
            return StatusError.DATA_LENGTH
        if address < ct.EEPROM_END and self.get(ct.TORQUE_ENABLE):
            return StatusError.ACCESS  # EEPROM is locked while torque is on
        if address <= ct.HARDWARE_ERROR_STATUS.address < address + len(data):
            return StatusError.ACCESS  # read-only
        latched = self.get(ct.HARDWARE_ERROR_STATUS) & self.get(ct.SHUTDOWN)
        enables = address <= ct.TORQUE_ENABLE.address < address + len(data) and data[ct.TORQUE_ENABLE.address - address]
        if latched and enables:
            return StatusError.RESULT_FAIL  # no torque while a shutdown error is latched
        if address <= ct.BUS_WATCHDOG.address < address + len(data):
            value = ct.BUS_WATCHDOG.decode(data[ct.BUS_WATCHDOG.address - address :])
            if (self.watchdog_tripped and value != 0) or value < 0:
                return StatusError.DATA_RANGE  # a tripped watchdog is cleared with 0 before it is set again
        goals = (ct.GOAL_CURRENT.address, ct.GOAL_POSITION.address + ct.GOAL_POSITION.size)
        if self.watchdog_tripped and address < goals[1] and address + len(data) > goals[0]:
            return StatusError.DATA_RANGE  # no new goal until the host clears the watchdog
        if address <= ct.GOAL_POSITION.address and address + len(data) >= ct.GOAL_POSITION.address + 4:
            offset = ct.GOAL_POSITION.address - address
            goal = ct.GOAL_POSITION.decode(data[offset : offset + 4])
            if not self.get(ct.MIN_POSITION_LIMIT) <= goal <= self.get(ct.MAX_POSITION_LIMIT):
                return StatusError.DATA_LIMIT
        self.table[address : address + len(data)] = data
        return StatusError.NONE

    def reboot(self) -> None:
        self._set(ct.HARDWARE_ERROR_STATUS, 0)
        self._set(ct.TORQUE_ENABLE, 0)
        if self.temperature_c >= self.get(ct.TEMPERATURE_LIMIT):
            self._set(ct.HARDWARE_ERROR_STATUS, int(HardwareError.OVERHEATING))

    def error_byte(self, error: int) -> int:
        return int(error) | (ALERT_BIT if self.get(ct.HARDWARE_ERROR_STATUS) else 0)

    @property
    def return_delay_s(self) -> float:
        return self.get(ct.RETURN_DELAY_TIME) * ct.RETURN_DELAY_UNIT_US * 1e-6


@dataclass
class BusStats:
    bytes_in: int = 0
    bytes_out: int = 0
    packets_in: int = 0
    replies: int = 0
    busy_s: float = 0.0  # wire time of everything sent both ways, at the bus's baud rate
    # read requests by their first address: what the master asked for
    reads_at: dict[int, int] = dataclasses.field(default_factory=dict)


class BusPlant(Protocol):
    """What moves the servos' outputs when their own motor model does not (the rig's physics)."""

    def between_packets(self) -> float:
        """Run when due; the seconds until it is due again."""
        ...

    def before_sync_read(self, address: int, length: int) -> None:
        """A sync read of the servos' control tables from `address` is about to be answered."""
        ...


class EmulatedBus:
    """Servos on a pseudo-terminal, served by a thread (in `BusEmulator`'s own process)."""

    def __init__(
        self,
        servos: Iterable[EmulatedXM430 | EmulatedBoard],
        baudrate: int = 1_000_000,
        wire_time: bool = False,
        motor_hz: float = 200.0,
    ) -> None:
        self.servos = {s.servo_id: s for s in servos}
        self.baudrate = baudrate
        self.wire_time = wire_time
        self.motor_period = 1.0 / motor_hz
        self.stats = BusStats()
        self._lock = threading.RLock()
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port_name = os.ttyname(self._slave)
        self._parser = PacketParser()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._plant: BusPlant | None = None
        self._line_at = 0.0  # when the wire is free (perf_counter)

    def attach(self, plant: BusPlant) -> None:
        """A plant run from the bus's thread under its lock (the rig's physics), between packets and before a sync
        read is answered."""
        self._plant = plant

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="dynamixel-emulator", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    @property
    def lock(self) -> threading.RLock:
        """Held while a packet is answered: a plant that changes the servos' outputs takes it too."""
        return self._lock

    def control(self, request: tuple) -> Any:
        """A test's request, answered under the bus's lock: ("fault", id, name, value), ("temperature", id, C),
        ("load", id, Nm), ("field", id, address, size), ("position", id), ("stats",)."""
        kind, *args = request
        with self._lock:
            if kind == "stats":
                return dataclasses.replace(self.stats, reads_at=dict(self.stats.reads_at))
            servo = self.servos[args[0]]
            if kind == "fault":
                setattr(servo.faults, args[1], args[2])
            elif kind == "temperature":
                servo.temperature_c = float(args[1])
                servo.step(0.0)  # its errors and present temperature now, not at its next step: a read may come first
            elif kind == "load":
                servo.load_nm = float(args[1])
            elif kind == "field":
                return ct.Field(args[1], args[2]).decode(bytes(servo.table[args[1] : args[1] + args[2]]))
            elif kind == "position":
                return servo.position_rad
            elif kind == "sense":  # a sensor board's reading (see sensor_emulators)
                servo.sense(*args[1:])
            else:
                raise ValueError(f"unknown request {kind!r}")
        return None

    # the bus ---------------------------------------------------------------------------------------------------

    def _run(self) -> None:
        last = time.perf_counter()
        while not self._stop.is_set():
            wait = self.motor_period
            if self._plant is not None:
                with self._lock:
                    wait = min(wait, self._plant.between_packets())
            try:
                ready, _, _ = select.select([self._master], [], [], wait)
            except (OSError, ValueError):
                return
            now = time.perf_counter()
            with self._lock:
                if now - last >= self.motor_period:
                    for servo in self.servos.values():
                        servo.step(now - last)
                    last = now
                if not ready:
                    continue
                try:
                    data = os.read(self._master, 4096)
                except OSError:
                    return
                self.stats.bytes_in += len(data)
                self._wire(len(data))  # the request's bytes, on the wire from when they were written
                for packet in self._parser.feed(data):
                    self.stats.packets_in += 1
                    for reply in self._answer(packet):
                        self._send(reply)

    def _line(self, seconds: float) -> None:
        """The wire is taken `seconds` more, from now or from when it is free (with `wire_time`, a reply goes out
        when the line gets to it: the emulator's own work until then is hidden, as a servo replies while the
        bytes before its reply are still on the wire)."""
        self._line_at = max(self._line_at, time.perf_counter()) + seconds

    def _wire(self, nbytes: int) -> None:
        seconds = nbytes * 10 / self.baudrate  # 8 data bits, a start and a stop bit
        self.stats.busy_s += seconds
        self._line(seconds)

    def _send(self, reply: bytes) -> None:
        self._wire(len(reply))
        if self.wire_time:
            time.sleep(max(0.0, self._line_at - time.perf_counter()))
        self.stats.bytes_out += len(reply)
        self.stats.replies += 1
        os.write(self._master, reply)

    def _reply(
        self, servo: EmulatedXM430 | EmulatedBoard, error: int, params: bytes = b"", is_read: bool = False
    ) -> list[bytes]:
        faults = servo.faults
        level = servo.status_return_level
        if faults.dead or (level == 0) or (level == 1 and not is_read):
            return []
        if faults.drop_replies > 0:
            faults.drop_replies -= 1
            return []
        if not is_read and faults.drop_write_replies > 0:
            faults.drop_write_replies -= 1
            return []
        self._line(servo.return_delay_s)
        if faults.late_replies > 0:
            faults.late_replies -= 1
            time.sleep(LATE_REPLY_S)
        packet = status(servo.servo_id, servo.error_byte(error), params)
        if faults.corrupt_replies > 0:
            faults.corrupt_replies -= 1
            packet = packet[:-1] + bytes([packet[-1] ^ 0xFF])
        return [packet]

    def _fast_sync_read(self, address: int, length: int, servo_ids: bytes) -> list[bytes]:
        """One packet that every servo asked adds its part to, in turn. A servo that is dead or drops its reply
        breaks the chain: the packet ends there, short (the master times out on it)."""
        parts: list[tuple[int, int, bytes]] = []
        corrupt = False
        for servo_id in servo_ids:
            servo = self.servos.get(servo_id)
            if servo is None or servo.faults.dead:
                break
            if servo.faults.drop_replies > 0:
                servo.faults.drop_replies -= 1
                break
            if servo.faults.corrupt_replies > 0:
                servo.faults.corrupt_replies -= 1
                corrupt = True
            error, data = servo.read(address, length)
            parts.append((servo.error_byte(error), servo_id, data.ljust(length, b"\0")))
        if not parts:
            return []
        self._line(self.servos[parts[0][1]].return_delay_s)
        packet = fast_sync_status(parts)
        if len(parts) < len(servo_ids):  # cut where the chain broke: no closing CRC
            packet = packet[:-2]
        elif corrupt:
            packet = packet[:-1] + bytes([packet[-1] ^ 0xFF])
        return [packet]

    def _answer(self, packet: Packet) -> list[bytes]:
        p = packet.params
        target = self.servos.get(packet.packet_id)
        if not packet.crc_ok:
            return self._reply(target, StatusError.CRC) if target is not None else []
        now = time.monotonic()
        heard = [target] if target is not None else []
        if packet.packet_id == BROADCAST_ID:  # a sync or fast read or write: every servo hears it
            heard = list(self.servos.values())
        for servo in heard:
            servo.last_heard_s = now
        instruction = packet.instruction
        reads_all = instruction in (Instruction.FAST_SYNC_READ, Instruction.SYNC_READ)
        if (reads_all or instruction == Instruction.READ) and len(p) >= 4:
            address = p[0] | p[1] << 8
            self.stats.reads_at[address] = self.stats.reads_at.get(address, 0) + 1
        if reads_all and packet.packet_id == BROADCAST_ID and len(p) >= 4 and self._plant is not None:
            self._plant.before_sync_read(p[0] | p[1] << 8, p[2] | p[3] << 8)
        if instruction == Instruction.FAST_SYNC_READ and packet.packet_id == BROADCAST_ID and len(p) >= 4:
            return self._fast_sync_read(p[0] | p[1] << 8, p[2] | p[3] << 8, p[4:])
        if instruction == Instruction.PING:
            servos = (
                sorted(self.servos.values(), key=lambda s: s.servo_id)
                if packet.packet_id == BROADCAST_ID
                else [target]
                if target is not None
                else []
            )
            out = []
            for servo in servos:
                if not servo.faults.dead:  # a ping is answered whatever the status return level
                    out.append(status(servo.servo_id, servo.error_byte(0), servo.ping_info()))
            return out
        if instruction == Instruction.SYNC_READ and packet.packet_id == BROADCAST_ID and len(p) >= 4:
            address, length = p[0] | p[1] << 8, p[2] | p[3] << 8
            out = []
            for servo_id in p[4:]:
                servo = self.servos.get(servo_id)
                if servo is not None:
                    error, data = servo.read(address, length)
                    out += self._reply(servo, error, data, is_read=True)
            return out
        if instruction == Instruction.BULK_READ and packet.packet_id == BROADCAST_ID and len(p) >= 5:
            out = []  # each device asked answers in turn, with its own block
            for i in range(0, len(p) - 4, 5):
                device = self.servos.get(p[i])
                if device is not None:
                    error, data = device.read(p[i + 1] | p[i + 2] << 8, p[i + 3] | p[i + 4] << 8)
                    out += self._reply(device, error, data, is_read=True)
            return out
        if instruction == Instruction.SYNC_WRITE and packet.packet_id == BROADCAST_ID and len(p) >= 4:
            address, length = p[0] | p[1] << 8, p[2] | p[3] << 8
            for i in range(4, len(p) - length, length + 1):
                servo = self.servos.get(p[i])
                if servo is not None and not servo.faults.dead:
                    servo.write(address, p[i + 1 : i + 1 + length])
            return []
        if target is None:
            return []  # nobody with that ID on the bus
        if instruction == Instruction.READ and len(p) == 4:
            error, data = target.read(p[0] | p[1] << 8, p[2] | p[3] << 8)
            return self._reply(target, error, data, is_read=True)
        if instruction == Instruction.WRITE and len(p) >= 3:
            return self._reply(target, target.write(p[0] | p[1] << 8, p[2:]))
        if instruction == Instruction.REBOOT:
            target.reboot()
            return self._reply(target, StatusError.NONE)
        return self._reply(target, StatusError.INSTRUCTION)


class BusEmulator:
    """The emulated bus in its own process, as a real U2D2 and its servos are: nothing the test or the backend does
    in its interpreter can delay a reply (in one process, the SDK's busy-waiting read held the interpreter lock
    past its 4 ms timeout). Use as a context manager; `port_name` is the pseudo-terminal the SDK opens."""

    def __init__(
        self,
        servo_ids: Iterable[int],
        baudrate: int = 1_000_000,
        wire_time: bool = False,
        positions: dict[int, float] | None = None,
        sensors: bool = False,
    ) -> None:
        """`positions`: servo angles (rad from the centre) where servos start, by ID (0 for the others);
        `sensors`: the OP3's OpenCR (ID 200) and FSR foot modules (111, 112) on the bus too."""
        self.servo_ids = tuple(servo_ids)
        self.sensors = sensors
        self.positions = dict(positions or {})
        self.baudrate = baudrate
        self.wire_time = wire_time
        self.port_name = ""
        self._conn: Connection | None = None
        self._process: mp.process.BaseProcess | None = None
        self._lock = threading.Lock()

    def __enter__(self) -> BusEmulator:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    daemon_process = True  # ended with the process that made it (one that starts processes of its own cannot be)
    start_timeout_s = 30.0  # how long its process may take to open its port

    def _child(self) -> tuple[Callable[..., None], tuple]:
        """What the emulator's process runs, and its arguments after the pipe's end."""
        return _serve, (self.servo_ids, self.baudrate, self.wire_time, self.positions, self.sensors)

    def start(self) -> None:
        context = mp.get_context("spawn")
        parent, child = context.Pipe()
        target, args = self._child()
        self._process = context.Process(
            target=target, args=(child, *args), name="dynamixel-emulator", daemon=self.daemon_process
        )
        self._process.start()
        child.close()
        self._conn = parent
        deadline = time.monotonic() + self.start_timeout_s
        while not parent.poll(0.5):  # (a process that ended makes the pipe readable too)
            if time.monotonic() > deadline:
                self._process.kill()
                raise RuntimeError(f"the bus emulator did not start within {self.start_timeout_s:.0f} s")
        try:
            self.port_name = parent.recv()
        except EOFError:
            self._process.join(timeout=5)
            raise RuntimeError(f"the bus emulator exited while starting (exit code {self._process.exitcode})") from None

    def stop(self) -> None:
        if self._conn is not None:
            with contextlib.suppress(OSError, EOFError):
                self._call("stop")
            self._conn.close()
            self._conn = None
        if self._process is not None:
            self._process.join(timeout=5)
            if self._process.is_alive():
                self._process.kill()
            self._process = None

    def _call(self, *request: Any) -> Any:
        assert self._conn is not None, "start() first"
        with self._lock:
            self._conn.send(request)
            ok, value = self._conn.recv()
        if not ok:
            raise RuntimeError(value)
        return value

    # what tests do to the servos ---------------------------------------------------------------------------------

    def set_fault(self, servo_id: int, **faults: Any) -> None:
        """dead=True, drop_replies=n, corrupt_replies=n, late_replies=n, drop_write_replies=n (see ServoFaults)."""
        for name, value in faults.items():
            self._call("fault", servo_id, name, value)

    def set_temperature(self, servo_id: int, celsius: float) -> None:
        self._call("temperature", servo_id, celsius)

    def set_load(self, servo_id: int, torque_nm: float) -> None:
        self._call("load", servo_id, torque_nm)

    def read(self, servo_id: int, field: ct.Field) -> int:
        """A control-table field as the servo holds it now (signedness as the field's)."""
        raw = self._call("field", servo_id, field.address, field.size)
        return field.decode(int(raw).to_bytes(field.size, "little")) if field.signed else raw

    def position_rad(self, servo_id: int) -> float:
        return self._call("position", servo_id)

    def stats(self) -> BusStats:
        return self._call("stats")

    def sense_imu(self, quat: Any, gyro: Any, accel: Any, device_id: int = 200) -> None:
        """What the OpenCR's IMU reads now: trunk orientation (wxyz), rad/s, m/s^2 (trunk frame)."""
        self._call("sense", device_id, list(quat), list(gyro), list(accel))

    def sense_foot(self, device_id: int, forces_n: Any) -> None:
        """What an FSR module's four pads read now (N)."""
        self._call("sense", device_id, list(forces_n))


def _serve(
    conn: Connection,
    servo_ids: tuple[int, ...],
    baudrate: int,
    wire_time: bool,
    positions: dict[int, float],
    sensors: bool,
) -> None:
    devices: list[EmulatedXM430 | EmulatedBoard] = [EmulatedXM430(i, positions.get(i, 0.0)) for i in servo_ids]
    bus = EmulatedBus(devices + (op3_sensor_boards() if sensors else []), baudrate, wire_time)
    serve_bus(conn, bus, bus.control)


def serve_bus(conn: Connection, bus: EmulatedBus, answer: Callable[[tuple], Any]) -> None:
    """Start the bus at a real-time priority, say its port, then answer the parent's requests until "stop"."""
    # Real servos answer whatever the host is doing: where it may (root, or CAP_SYS_NICE), the emulator runs
    # ahead of ordinary processes. It sleeps in select() between packets, so it takes nothing from them. Threads
    # started before this keep their own policy.
    with contextlib.suppress(OSError, AttributeError):
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(EMULATOR_FIFO_PRIORITY))
    bus.start()
    conn.send(bus.port_name)
    try:
        while True:
            request = conn.recv()
            if request[0] == "stop":
                conn.send((True, None))
                break
            try:
                conn.send((True, answer(request)))
            except Exception as exc:  # a test's mistake: said, not a dead emulator
                conn.send((False, repr(exc)))
    except EOFError:
        pass
    finally:
        bus.stop()
