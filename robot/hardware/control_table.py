"""The XM430-W350 control table (Protocol 2.0): addresses and sizes of the fields the robot reads and writes.
EEPROM fields (below address 64) can be written only while torque is off."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Field:
    address: int
    size: int
    signed: bool = False

    def decode(self, data: bytes) -> int:
        return int.from_bytes(data[: self.size], "little", signed=self.signed)

    def encode(self, value: int) -> bytes:
        return int(value).to_bytes(self.size, "little", signed=self.signed)


MODEL_NUMBER = Field(0, 2)
FIRMWARE_VERSION = Field(6, 1)
ID = Field(7, 1)
BAUD_RATE = Field(8, 1)
RETURN_DELAY_TIME = Field(9, 1)
DRIVE_MODE = Field(10, 1)
OPERATING_MODE = Field(11, 1)
HOMING_OFFSET = Field(20, 4, signed=True)
TEMPERATURE_LIMIT = Field(31, 1)
MAX_VOLTAGE_LIMIT = Field(32, 2)
MIN_VOLTAGE_LIMIT = Field(34, 2)
CURRENT_LIMIT = Field(38, 2)
MAX_POSITION_LIMIT = Field(48, 4)
MIN_POSITION_LIMIT = Field(52, 4)
SHUTDOWN = Field(63, 1)
EEPROM_END = 64
TORQUE_ENABLE = Field(64, 1)
LED = Field(65, 1)
STATUS_RETURN_LEVEL = Field(68, 1)
HARDWARE_ERROR_STATUS = Field(70, 1)
POSITION_P_GAIN = Field(84, 2)
BUS_WATCHDOG = Field(98, 1, signed=True)  # 20 ms units; 0 off; -1 once it has tripped
GOAL_CURRENT = Field(102, 2, signed=True)
GOAL_VELOCITY = Field(104, 4, signed=True)
PROFILE_ACCELERATION = Field(108, 4)
PROFILE_VELOCITY = Field(112, 4)
GOAL_POSITION = Field(116, 4, signed=True)
REALTIME_TICK = Field(120, 2)
MOVING = Field(122, 1)
PRESENT_PWM = Field(124, 2, signed=True)
PRESENT_CURRENT = Field(126, 2, signed=True)
PRESENT_VELOCITY = Field(128, 4, signed=True)
PRESENT_POSITION = Field(132, 4, signed=True)
PRESENT_INPUT_VOLTAGE = Field(144, 2)
PRESENT_TEMPERATURE = Field(146, 1)
TABLE_SIZE = 147

XM430_W350_MODEL = 1020
# Baud Rate field values (address 8) to bits per second.
BAUD_RATES = {0: 9_600, 1: 57_600, 2: 115_200, 3: 1_000_000, 4: 2_000_000, 5: 3_000_000, 6: 4_000_000}
BUS_WATCHDOG_UNIT_MS = 20
RETURN_DELAY_UNIT_US = 2
RETURN_DELAY_FACTORY = 250  # 500 us: a shipped servo waits this long before each reply
# Units: position 0.088 deg (4096 a turn, 2048 the centre), current 2.69 mA, velocity 0.229 rpm, voltage 0.1 V.
POSITION_PER_RAD = 4096 / (2 * 3.141592653589793)
POSITION_CENTRE = 2048
CURRENT_UNIT_A = 0.00269
VELOCITY_UNIT_RAD_S = 0.229 * 2 * 3.141592653589793 / 60
