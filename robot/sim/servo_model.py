"""Simulated XM430 internals: the current each servo draws for the torque it holds, the winding temperature that
current makes, the supply voltage and the hardware error bits, so that servo diagnostics mean in simulation what
they mean on the real robot (a servo held near stall for minutes gets hot, and trips its overload protection).

The thermal model is one first-order lump per servo: copper losses I^2 R heat the winding, which loses heat to
the air through a thermal resistance. With the defaults a servo at 1 A (5.2 W) settles 31 K over ambient, with a
time constant of 6 min. Measured (stop 76): the simulated walk's knees draw about 1.8 A rms, often the stall
current, and warm about 0.3 K a second: 55 C after some 100 s of walking, where a behaviour rests before it walks
on (`BehaviourRobot.rest_if_hot`); standing, a knee cools from 67 to 57 C in about 2.5 min (it settles near
37 C). Whether the real OP3's knees draw that much walking is not measured here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robot.hardware import xm430
from robot.hardware.xm430 import LOAD_AVERAGE_S, HardwareError, ServoReadings
from robot.power.battery import ServoElectrical


@dataclass(frozen=True)
class ThermalSpec:
    ambient_c: float = 25.0
    winding_to_ambient_k_per_w: float = 6.0
    heat_capacity_j_per_k: float = 60.0


class SimulatedServos:
    """The robot's servos, stepped with the torques the physics says they exert."""

    def __init__(
        self,
        joint_names: Sequence[str],
        torque_per_unit: np.ndarray | None = None,
        electrical: ServoElectrical | None = None,
        thermal: ThermalSpec | None = None,
    ) -> None:
        """`torque_per_unit` converts each actuator's force to servo torque (1 for revolute joints; a gripper's
        finger force in N becomes the torque of the servo that drives it)."""
        self.joint_names = tuple(joint_names)
        n = len(self.joint_names)
        self.electrical = electrical or ServoElectrical()
        self.thermal = thermal or ThermalSpec()
        self._scale = np.ones(n) if torque_per_unit is None else np.asarray(torque_per_unit, dtype=float)
        self.temperature_c = np.full(n, self.thermal.ambient_c)
        self._current = np.full(n, self.electrical.standby_current_a)
        self._load = np.zeros(n)
        self._error = np.zeros(n)
        self._voltage = np.full(n, self.electrical.supply_v)
        self._overloaded_s = np.zeros(n)
        self._jammed_pct = np.zeros(n)  # injected: a load the output is held at whatever it is asked
        self._bits = np.zeros(n, dtype=np.int64)  # latched until the servo is rebooted, as on the real one

    def index(self, joint: str) -> int:
        try:
            return self.joint_names.index(joint)
        except ValueError:
            raise ValueError(f"no servo drives {joint!r}; servos: {', '.join(self.joint_names)}") from None

    def step(self, torques: np.ndarray, targets: np.ndarray, positions: np.ndarray, bus_v: float, dt_s: float) -> None:
        torque = np.maximum(
            np.abs(np.asarray(torques, dtype=float)) * self._scale, self._jammed_pct / 100.0 * xm430.STALL_TORQUE_NM
        )
        load = torque / xm430.STALL_TORQUE_NM * 100.0
        self._load += (load - self._load) * min(1.0, dt_s / LOAD_AVERAGE_S)
        self._current = self.electrical.currents_a(torque)
        self._error = np.asarray(targets, dtype=float) - np.asarray(positions, dtype=float)
        self._voltage[:] = bus_v
        heat_w = self._current**2 * self.electrical.resistance_ohm
        spec = self.thermal
        cooling_w = (self.temperature_c - spec.ambient_c) / spec.winding_to_ambient_k_per_w
        self.temperature_c += (heat_w - cooling_w) * dt_s / spec.heat_capacity_j_per_k
        loaded = load >= xm430.OVERLOAD_LOAD_PCT
        self._overloaded_s = np.where(loaded, self._overloaded_s + dt_s, 0.0)
        self._bits |= np.where(self.temperature_c >= xm430.TEMPERATURE_LIMIT_C, int(HardwareError.OVERHEATING), 0)
        self._bits |= np.where(self._overloaded_s >= xm430.OVERLOAD_AFTER_S, int(HardwareError.OVERLOAD), 0)
        bad_supply = not xm430.MIN_VOLTAGE_V <= bus_v <= xm430.MAX_VOLTAGE_V
        self._bits |= np.full_like(self._bits, int(HardwareError.INPUT_VOLTAGE) if bad_supply else 0)

    def readings(self) -> ServoReadings:
        return ServoReadings(
            temperature_c=self.temperature_c.copy(),
            current_a=self._current.copy(),
            voltage_v=self._voltage.copy(),
            load_pct=self._load.copy(),
            position_error_rad=self._error.copy(),
            error_bits=self._bits.copy(),
        )

    # faults ------------------------------------------------------------------------------------------------------

    def heat(self, joint: str, kelvin: float) -> None:
        """A servo suddenly `kelvin` hotter (a blocked fan, a bearing gone): it then cools at its own pace."""
        self.temperature_c[self.index(joint)] += kelvin

    def jam(self, joint: str, load_pct: float) -> None:
        """A servo whose output is held (a jammed gear): its load stays at `load_pct` whatever it is asked."""
        self._jammed_pct[self.index(joint)] = max(0.0, load_pct)

    def clear_faults(self) -> None:
        """Faults removed and every servo rebooted (its latched error bits cleared; heat does not go away)."""
        self._jammed_pct[:] = 0.0
        self.reboot()

    def reboot(self) -> None:
        self._overloaded_s[:] = 0.0
        self._bits[:] = 0
