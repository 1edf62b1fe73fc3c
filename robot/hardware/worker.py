"""The real robot behind the same `RobotPort` as the simulator: the robot core (`robot.robot.Robot`) on the
servo bus's body (`robot.bodies.hardware.HardwareBody`), whose docstring says what it does today and what it
refuses."""

from __future__ import annotations

from robot.bodies.hardware import DEADMAN_S, ESTOP_TORQUE_OFF_AFTER_S, NOT_ON_HARDWARE, HardwareBody
from robot.config import RobotConfig
from robot.diagnostics.thresholds import Thresholds
from robot.hardware.bus import DynamixelBus
from robot.hardware.config import HardwareConfig
from robot.model.world import WorldLayout
from robot.robot import Robot

__all__ = ["DEADMAN_S", "ESTOP_TORQUE_OFF_AFTER_S", "NOT_ON_HARDWARE", "HardwareWorker"]


class HardwareWorker(Robot):
    """`deadman_s`: 0 turns the operator deadman off (a script that keeps torque on by itself, at its risk)."""

    def __init__(
        self,
        config: HardwareConfig,
        layout: WorldLayout,
        bus: DynamixelBus | None = None,
        diagnostics: Thresholds | None = None,
        disk_path: str = ".",
        estop_torque_off_s: float = ESTOP_TORQUE_OFF_AFTER_S,
        deadman_s: float = DEADMAN_S,
    ) -> None:
        body = HardwareBody(config, layout, bus, estop_torque_off_s, deadman_s)
        robot = RobotConfig(
            realtime=True,
            control_hz=config.control_hz,
            perception=False,
            diagnostics=diagnostics or Thresholds(),
            disk_path=disk_path,
        )
        super().__init__(body, layout, robot)
        self.hardware = config
        self.bus = body.bus
