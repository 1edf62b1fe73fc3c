"""The OP3's sensor boards on the emulated Dynamixel bus (`bus_emulator.EmulatedBus`): the OpenCR at ID 200 with
its IMU registers, and the FSR foot modules. They answer ping, read, write and bulk read through the bus as the
servos do, and take the same injected faults (dead, dropped or corrupted replies). A test or the
hardware-in-the-loop rig sets what they sense with `sense(...)`.
"""

from __future__ import annotations

import time

import numpy as np

from robot.hardware import fsr, opencr
from robot.hardware.control_table import Field
from robot.hardware.emulated_faults import ServoFaults
from robot.hardware.protocol2 import StatusError


class EmulatedBoard:
    """A device with a plain control table: read-only below `eeprom_end` while it runs, no motor."""

    def __init__(
        self, device_id: int, model: int, table_size: int, id_field: Field, level_field: Field, eeprom_end: int
    ) -> None:
        self.table = bytearray(table_size)
        self.faults = ServoFaults()
        self.last_heard_s = time.monotonic()
        self._model = model
        self._id_field = id_field
        self._level_field = level_field
        self._eeprom_end = eeprom_end
        self.set(id_field, device_id)
        self.set(level_field, 2)

    @property
    def servo_id(self) -> int:
        return self.get(self._id_field)

    @property
    def status_return_level(self) -> int:
        return self.get(self._level_field)

    def get(self, field: Field) -> int:
        return field.decode(bytes(self.table[field.address : field.address + field.size]))

    def set(self, field: Field, value: int) -> None:
        self.table[field.address : field.address + field.size] = field.encode(value)

    def ping_info(self) -> bytes:
        return self._model.to_bytes(2, "little") + bytes([self.table[2]])

    def read(self, address: int, length: int) -> tuple[int, bytes]:
        if length < 1 or address + length > len(self.table):
            return StatusError.DATA_LENGTH, b""
        return StatusError.NONE, bytes(self.table[address : address + length])

    def write(self, address: int, data: bytes) -> int:
        if not data or address + len(data) > len(self.table):
            return StatusError.DATA_LENGTH
        if address < self._eeprom_end:
            return StatusError.ACCESS
        self.table[address : address + len(data)] = data
        return StatusError.NONE

    def reboot(self) -> None:
        """Nothing latches on a sensor board."""

    def error_byte(self, error: int) -> int:
        return int(error)

    @property
    def return_delay_s(self) -> float:
        return 0.0

    def step(self, dt: float) -> None:
        """A board has no motor to move."""


class EmulatedOpenCR(EmulatedBoard):
    def __init__(self, device_id: int = opencr.OPENCR_ID, voltage_v: float = 12.0) -> None:
        super().__init__(
            device_id, opencr.OPENCR_MODEL, opencr.TABLE_SIZE, opencr.ID, opencr.STATUS_RETURN_LEVEL, opencr.EEPROM_END
        )
        self.set(opencr.PRESENT_VOLTAGE, round(voltage_v * 10))
        self.sense(np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.array([0.0, 0.0, opencr.STANDARD_GRAVITY]))

    def sense(self, quat: np.ndarray, gyro: np.ndarray, accel: np.ndarray) -> None:
        """The trunk's orientation (wxyz), angular velocity (rad/s) and specific force (m/s^2) into the IMU
        registers."""
        for field, value in opencr.encode_registers(np.asarray(quat), np.asarray(gyro), np.asarray(accel)).items():
            self.set(field, value)


class EmulatedFSR(EmulatedBoard):
    MODEL = 0x0000  # the FSR's model number is not checked by the robot

    def __init__(self, device_id: int) -> None:
        super().__init__(device_id, self.MODEL, fsr.TABLE_SIZE, fsr.ID, fsr.STATUS_RETURN_LEVEL, fsr.EEPROM_END)
        self.sense(np.zeros(4))

    def sense(self, forces_n: np.ndarray) -> None:
        """The four pads' forces (N): front-left, front-right, back-left, back-right."""
        for field, value in fsr.encode_registers(np.asarray(forces_n)).items():
            self.set(field, value)


def op3_sensor_boards() -> list[EmulatedBoard]:
    """The OpenCR and both feet's FSR modules, as on the OP3."""
    return [EmulatedOpenCR(), EmulatedFSR(fsr.RIGHT_FSR_ID), EmulatedFSR(fsr.LEFT_FSR_ID)]
