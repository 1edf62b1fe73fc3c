"""Facts of the Dynamixel XM430-W350 that both the simulated servos and the real bus report in: its hardware
error bits (control table address 70, "Hardware Error Status") and its protective limits."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntFlag

import numpy as np


class HardwareError(IntFlag):
    """Hardware Error Status bits. The servo turns its torque off when one of them is set (shutdown default)."""

    INPUT_VOLTAGE = 1 << 0  # supply outside the operating voltage range
    OVERHEATING = 1 << 2  # internal temperature above the Temperature Limit
    MOTOR_ENCODER = 1 << 3
    ELECTRICAL_SHOCK = 1 << 4
    OVERLOAD = 1 << 5  # a persistent load above the maximum output

    def describe(self) -> str:
        return ", ".join(flag.name.lower().replace("_", " ") for flag in HardwareError if flag in self) or "none"


TEMPERATURE_LIMIT_C = 80.0  # control table default (address 31)
MIN_VOLTAGE_V = 9.5  # Min Voltage Limit default (address 34), 95 x 0.1 V
MAX_VOLTAGE_V = 16.0  # Max Voltage Limit default (address 32)
STALL_TORQUE_NM = 4.1  # at 12 V
STALL_CURRENT_A = 2.3
LOAD_AVERAGE_S = 1.0  # the load reported is averaged this long, as the servo's Present Load is smoothed
OVERLOAD_LOAD_PCT = 95.0  # a load this high ...
OVERLOAD_AFTER_S = 3.0  # ... held this long trips the overload bit (a grasp pushes at stall for ~0.5 s)


@dataclass(frozen=True)
class ServoReadings:
    """What every servo of the robot reports (arrays in joint order), whether simulated or read from the bus."""

    temperature_c: np.ndarray
    current_a: np.ndarray
    voltage_v: np.ndarray
    load_pct: np.ndarray  # of the stall torque, unsigned, averaged over about a second
    position_error_rad: np.ndarray  # goal minus present position
    error_bits: np.ndarray  # HardwareError per servo (int)
