"""The robot's power: XM430 servos drawing current for the torque they hold, fed from a 6S LiPo pack through a 12 V
converter. It exists so that the pack's voltage and charge mean something in simulation: they sag and drain with the
work the robot does, as the real pack's would, and operators see (and replay) what a task costs."""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

# Open-circuit voltage of one LiPo cell against its state of charge (typical discharge curve at rest).
_CELL_SOC = np.array([0.0, 0.05, 0.10, 0.20, 0.30, 0.40, 0.50, 0.60, 0.70, 0.80, 0.90, 1.00])
_CELL_OCV = np.array([3.27, 3.61, 3.69, 3.73, 3.77, 3.79, 3.82, 3.87, 3.92, 3.98, 4.06, 4.20])
_SOC_POINTS = tuple(float(v) for v in _CELL_SOC)  # for a scalar, every control tick: plain floats beat np.interp
_OCV_POINTS = tuple(float(v) for v in _CELL_OCV)


def cell_ocv(soc: float) -> float:
    """One cell's open-circuit voltage at `soc` (clamped to 0..1), interpolated on the discharge curve."""
    soc = min(max(soc, 0.0), 1.0)
    j = min(bisect.bisect_right(_SOC_POINTS, soc), len(_SOC_POINTS) - 1) - 1
    x0, x1, y0, y1 = _SOC_POINTS[j], _SOC_POINTS[j + 1], _OCV_POINTS[j], _OCV_POINTS[j + 1]
    return y0 + (y1 - y0) * (soc - x0) / (x1 - x0)


@dataclass(frozen=True)
class ServoElectrical:
    """An XM430-W350 at 12 V: 4.1 Nm at its 2.3 A stall current (so ~1.8 Nm per amp at the output shaft, and the
    winding's resistance is what passes 2.3 A at 12 V)."""

    stall_torque_nm: float = 4.1
    stall_current_a: float = 2.3
    supply_v: float = 12.0
    standby_current_a: float = 0.04  # the servo's electronics, torque on, holding nothing

    @property
    def torque_constant(self) -> float:
        return self.stall_torque_nm / self.stall_current_a

    @property
    def resistance_ohm(self) -> float:
        return self.supply_v / self.stall_current_a

    def currents_a(self, torques_nm: np.ndarray) -> np.ndarray:
        return np.abs(np.asarray(torques_nm, dtype=float)) / self.torque_constant + self.standby_current_a

    def power_w(self, torques_nm: np.ndarray, velocities_rad_s: np.ndarray) -> float:
        """Electrical power of all servos: copper losses plus mechanical work done (braking energy is not
        recovered: the converter cannot push it back into the pack)."""
        torques = np.asarray(torques_nm, dtype=float)
        current = np.abs(torques) / self.torque_constant
        mechanical = np.maximum(torques * np.asarray(velocities_rad_s, dtype=float), 0.0)
        standby = self.standby_current_a * self.supply_v * torques.size
        return float(np.sum(current**2) * self.resistance_ohm + np.sum(mechanical) + standby)


@dataclass(frozen=True)
class PackSpec:
    """A 6S LiPo pack and what hangs on it besides the servos (the computer, sensors, the U2D2)."""

    cells: int = 6
    capacity_ah: float = 2.2
    cell_resistance_ohm: float = 0.008
    wiring_resistance_ohm: float = 0.012
    converter_efficiency: float = 0.9  # 6S -> 12 V for the servo bus
    base_load_w: float = 12.0

    @property
    def resistance_ohm(self) -> float:
        return self.cells * self.cell_resistance_ohm + self.wiring_resistance_ohm

    def open_circuit_v(self, soc: float) -> float:
        return self.cells * cell_ocv(soc)


@dataclass(frozen=True)
class BatteryReading:
    voltage_v: float  # at the pack's terminals, under load
    current_a: float
    soc: float  # state of charge, 0..1
    power_w: float  # drawn from the pack


class Battery:
    """The pack's charge, integrated tick by tick from the load on it."""

    def __init__(self, spec: PackSpec | None = None, soc: float = 1.0) -> None:
        self.spec = spec or PackSpec()
        self.soc = float(soc)
        self.reading = self._reading(0.0)

    def step(self, servo_power_w: float, dt_s: float) -> BatteryReading:
        """Draw `servo_power_w` (on the 12 V bus) plus the base load for `dt_s` seconds."""
        load = max(servo_power_w, 0.0) / self.spec.converter_efficiency + self.spec.base_load_w
        self.reading = self._reading(load)
        self.soc = max(0.0, self.soc - self.reading.current_a * dt_s / (self.spec.capacity_ah * 3600.0))
        return self.reading

    def _reading(self, load_w: float) -> BatteryReading:
        ocv = self.spec.open_circuit_v(self.soc)
        r = self.spec.resistance_ohm
        # P = V I with V = OCV - I R: the smaller root. Past what the pack can deliver it gives out at OCV / 2.
        disc = ocv * ocv - 4.0 * r * load_w
        current = (ocv - math.sqrt(disc)) / (2.0 * r) if disc > 0 else ocv / (2.0 * r)
        return BatteryReading(
            voltage_v=float(ocv - current * r), current_a=float(current), soc=self.soc, power_w=float(load_w)
        )
