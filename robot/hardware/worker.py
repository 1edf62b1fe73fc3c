"""The real robot behind the same `RobotPort` as the simulator: the robot core (`robot.robot.Robot`) on the
servo bus's body (`robot.bodies.hardware.HardwareBody`), whose docstring says what it does today and what it
refuses."""

from __future__ import annotations

import time
from collections.abc import Callable

from robot.bodies.hardware import DEADMAN_S, ESTOP_TORQUE_OFF_AFTER_S, NOT_ON_HARDWARE, HardwareBody
from robot.bodies.hardware_senses import HardwareSenses, ImuDriver
from robot.config import RobotConfig
from robot.control.locomotion import LocomotionController
from robot.control.stack import build_locomotion
from robot.diagnostics.thresholds import Thresholds
from robot.hardware.bus import DynamixelBus
from robot.hardware.bus_sensors import BusSensors
from robot.hardware.config import HardwareConfig
from robot.model.world import WorldLayout
from robot.robot import Robot
from robot.sensors.bno055 import Bno055Imu
from robot.sensors.camera import UvcCamera
from robot.sensors.ld06 import Ld06Lidar

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
        locomotion: LocomotionController | None = None,
        imu: ImuDriver | None = None,
        walk: bool = False,
        wait_for_plans: bool = False,
    ) -> None:
        """`locomotion`: the legs' controller (None: postures only, unless `walk`); `walk`: build the legs'
        controller when the config names an IMU and foot sensors, which it needs; `imu`: an IMU driver to use
        instead of the one `config.imu` names (tests); `wait_for_plans`: the walk waits for each gait plan, as headless
        (for a rig in lockstep, whose physics waits for the robot: a plan late on a busy machine would otherwise
        change the walk)."""
        bus = bus or DynamixelBus(config)
        started = time.monotonic()  # the body's clock, which its sensors stamp their readings with too

        def clock() -> float:
            return time.monotonic() - started

        sensing = build_senses(config, bus, layout.robot_start, clock, imu)
        walking = locomotion is not None or (walk and sensing.senses.can_walk)
        body = HardwareBody(
            config,
            layout,
            bus,
            estop_torque_off_s,
            deadman_s,
            sensing=sensing,
            walking_enabled=walking,
            started_at=started,
        )
        if walking and locomotion is None:  # the simulation's legs' controller; a late plan never stalls the loop
            locomotion = build_locomotion(body.scene, planner_process=True, realtime=not wait_for_plans)
        robot = RobotConfig(
            realtime=True,
            control_hz=config.control_hz,
            perception=False,
            diagnostics=diagnostics or Thresholds(),
            disk_path=disk_path,
        )
        super().__init__(body, layout, robot, locomotion=locomotion)
        if locomotion is not None:
            body.locate_by(self.localiser.map_trunk)
        self.hardware = config
        self.bus = body.bus


def build_senses(
    config: HardwareConfig,
    bus: DynamixelBus,
    start: tuple[float, ...],
    clock: Callable[[], float],
    imu: ImuDriver | None = None,
) -> HardwareSenses:
    """The senses `config` names: the IMU and feet (boards on the servo bus, or a BNO055 on its own serial port),
    the camera and the lidar; `clock`: the body's, to stamp their readings."""
    if imu is None and config.imu.startswith("bno055:"):
        imu = Bno055Imu(config.imu.split(":", 1)[1], clock)
    boards = BusSensors(bus.port, bus.packets, imu=config.imu == "opencr", feet=config.feet == "fsr", clock=clock)
    camera = lidar = None
    if config.camera.startswith("rig:"):  # the hardware-in-the-loop rig's head camera, as a RealSense
        from robot.sensors.realsense import RealSenseCamera
        from robot.sensors.realsense_rig import RigFrameSource

        camera = RealSenseCamera(RigFrameSource(config.camera.split(":", 1)[1]), clock=clock)
    elif config.camera == "realsense":
        from robot.sensors.realsense import RealSenseCamera  # the optional extra: imported only when asked for

        camera = RealSenseCamera(clock=clock)
    elif config.camera != "none":
        camera = UvcCamera(config.camera, clock)
    if config.lidar != "none":
        model, port = config.lidar.split(":", 1)
        lidar = Ld06Lidar(port, clock, model=model.upper())
    yaw = float(start[2]) if len(start) > 2 else 0.0
    return HardwareSenses(boards, imu, yaw, clock, camera, lidar)
