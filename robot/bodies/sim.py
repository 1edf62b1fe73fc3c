"""The simulated body: the OP3 in MuJoCo, with what a real one would also have (the servos' heat and load, the
battery drained by them, the camera and lidar rendered from the scene), what only a simulation can do (reset,
drop an obstacle, inject a fault), and a telemetry record of every tick.

Only the control thread calls `before_tick` to `after_tick`; nothing else touches `MjData`.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from robot.control.stats import LoopStats
from robot.core.body import BodyLinks, BodySnapshot, CommandHandler, Diverged, Senses
from robot.core.measurements import Measurements
from robot.core.safety import LatchWords
from robot.diagnostics.robot_sources import RobotReadings
from robot.interface import (
    CommandReply,
    Fault,
    InjectFault,
    Level,
    ObjectPose,
    OperatorHeartbeat,
    PerceptionState,
    PlaceObstacle,
    PowerState,
    Proprioception,
    Refusal,
    SensorFeed,
    SetTorque,
)
from robot.model import humanoid_v1
from robot.model.world import WorldLayout
from robot.perception.service import SENSOR_HZ, PerceptionService
from robot.power.battery import Battery, ServoElectrical
from robot.sim.backend import MujocoSimBackend, SimulationDiverged
from robot.sim.servo_model import SimulatedServos
from robot.telemetry import TelemetryLayout, TelemetrySampler

CONVERTER_DROPOUT_V = 1.0  # the 12 V converter needs this much headroom over its output


class SimBody:
    """`perception`: render the camera and lidar (a few seconds to start; tests often go without)."""

    kind = "simulation"
    resettable = True
    stop_by_tick = False  # the stop's targets go into the physics at once (`hold_now`)
    senses = Senses(imu=True, foot_sensors=True)
    lacks = ""
    latch_words = LatchWords()

    def __init__(
        self,
        layout: WorldLayout,
        backend: MujocoSimBackend | None = None,
        control_hz: float = 100.0,
        perception: bool = True,
    ) -> None:
        self.layout = layout
        self.backend = backend or MujocoSimBackend(layout)
        self.joint_names = tuple(self.backend.joint_names)
        self.physics_hz = 1.0 / self.backend.physics_dt
        self.dt = 1.0 / control_hz
        self._wants_perception = perception
        self.perception: PerceptionService | None = None
        self._links: BodyLinks | None = None
        self._measured = self.backend.read()
        self._servos = ServoElectrical()
        self.battery = Battery()
        self.servo_model = SimulatedServos(self.joint_names, np.array(humanoid_v1.servo_torque_per_unit()))
        layout_of = TelemetryLayout.for_robot(
            self.joint_names, self.backend.qpos().size, self.backend.mocap_positions().shape[0]
        )
        self.telemetry: TelemetrySampler | None = TelemetrySampler(layout_of, control_hz)
        self._lock = threading.Lock()
        self._obstacles_pending: list[tuple[float, float]] = []
        self._stall_s = 0.0  # injected fault: the next tick hangs this long
        self._kick_pending = False  # injected fault: the physics is made to diverge on the next tick
        self._raise_ticks = 0  # injected fault: this many ticks raise, as a controller bug would

    def bind(self, links: BodyLinks) -> None:
        self._links = links
        if self._wants_perception:
            self.perception = PerceptionService(self.layout, links.latest_state, links.publish)

    def _publish(self, kind: str, message: str, level: Level = Level.OK, **data: Any) -> None:
        assert self._links is not None, "bind the body to a robot first"
        self._links.publish(kind, message, level, **data)

    @property
    def connected(self) -> bool:
        return True

    def now(self) -> float:
        """Simulated time, as the last tick left it."""
        return self._measured.sim_time_s

    @property
    def tick_guard(self) -> None:
        return None  # only the control thread touches the physics

    def stand_posture(self) -> np.ndarray:
        return self.backend.stand_targets()

    def crouch_posture(self) -> np.ndarray:
        posture = humanoid_v1.crouch_posture()
        return np.array([posture[n] for n in self.joint_names])

    def stop_posture(self) -> tuple[np.ndarray, float] | None:
        return None

    def stop_action(self, walking: bool) -> str:
        return "stopping the walk, then holding" if walking else "holding position"

    def motion_refusal(self) -> CommandReply | None:
        return None  # the simulated servos are always powered

    def commands(self) -> dict[type, CommandHandler]:
        return {
            SetTorque: lambda command: CommandReply(
                False, "the simulated servos are always powered: torque is for the real robot", Refusal.UNSUPPORTED
            ),
            OperatorHeartbeat: lambda command: CommandReply(
                True, "operator present (the simulation has no torque to keep on)"
            ),
            PlaceObstacle: self.place_obstacle,
            InjectFault: self.inject_fault,
        }

    # ---------------------------------------------------------------------------------------------------------
    # lifecycle

    def start(self) -> None:
        """Nothing to connect: the core starts the perception once the first state is published."""

    def before_shutdown(self) -> None:
        """Nothing to bring down: a simulation just stops."""

    def close(self) -> None:
        if self.perception is not None:
            self.perception.stop()

    def place(self, stand: np.ndarray) -> Measurements:
        """Stand the robot at its start pose in `stand` (before the loop starts, or from `reset`)."""
        self.backend.reset(stand)
        self._measured = self.backend.read()
        return self._measured

    def reset(self, stand: np.ndarray) -> Measurements:
        if self.perception is not None:  # objects are back where the world puts them; odometry starts over
            self.perception.forget_objects()
            self.perception.clear_map()
        self.backend.reset(stand)
        self.servo_model.reboot()  # a reset power-cycles the servos: latched errors clear, heat stays
        self._measured = self.backend.read()
        return self._measured

    # ---------------------------------------------------------------------------------------------------------
    # the control thread

    def before_tick(self) -> None:
        if self._stall_s > 0:  # injected fault: a controller that hangs
            stall, self._stall_s = self._stall_s, 0.0
            time.sleep(stall)
        if self._raise_ticks > 0:  # injected fault: a controller bug
            self._raise_ticks -= 1
            raise RuntimeError("injected controller fault")

    def apply_requests(self) -> None:
        if not self._obstacles_pending:
            return
        with self._lock:
            pending, self._obstacles_pending = self._obstacles_pending, []
        for x, y in pending:
            try:
                index = self.backend.place_obstacle(x, y)
            except ValueError as exc:
                self._publish("sim/obstacle", f"no obstacle placed: {exc}", Level.WARN)
                continue
            self._publish("sim/obstacle", f"obstacle {index} dropped at ({x:.2f}, {y:.2f})", x=x, y=y)

    def sense(self) -> Measurements:
        return self._measured  # read at the end of the last tick, after the physics stepped

    def latest(self) -> Measurements:
        return self._measured

    def actuate(self, targets: np.ndarray) -> Measurements:
        backend = self.backend
        backend.write(targets)
        if self._kick_pending:
            self._kick_pending = False
            backend.kick()
        try:
            backend.step(self.dt)
        except SimulationDiverged as exc:
            raise Diverged(str(exc)) from exc
        self._measured = measured = backend.read()
        return measured

    def hold_now(self, targets: np.ndarray) -> None:
        self.backend.write(targets)

    def stop_applied(self) -> None:
        """The stop is all in the joint targets."""

    def after_tick(self, targets: np.ndarray, tick_s: float) -> None:
        """What the tick cost the battery and the servos, and a telemetry sample when one is due."""
        m = self._measured
        if m.joint_torques is not None:
            self.battery.step(self._servos.power_w(m.joint_torques, m.joint_velocities), self.dt)
            bus_v = min(self._servos.supply_v, self.battery.reading.voltage_v - CONVERTER_DROPOUT_V)
            self.servo_model.step(m.joint_torques, targets, m.joint_positions, bus_v, self.dt)
        telemetry = self.telemetry
        if telemetry is None or not telemetry.due():
            return
        battery = self.battery.reading
        telemetry.record(
            {
                "sim_time_s": m.sim_time_s,
                "wall_time_s": time.time(),
                "qpos": self.backend.qpos(),
                "mocap_pos": self.backend.mocap_positions().ravel(),
                "joint_target": targets,
                "joint_position": m.joint_positions,
                "joint_velocity": m.joint_velocities,
                "joint_torque": m.joint_torques if m.joint_torques is not None else np.nan,
                "com": m.com if m.com is not None else np.nan,
                "tick_ms": tick_s * 1e3,
                "battery_v": battery.voltage_v,
                "battery_a": battery.current_a,
                "battery_soc": battery.soc,
            }
        )

    def snapshot(self, measured: Measurements) -> BodySnapshot:
        position = measured.base_position
        backend = self.backend
        b = self.battery.reading
        return BodySnapshot(
            base_position=(float(position[0]), float(position[1]), float(position[2])),
            base_yaw_rad=measured.yaw_rad,
            tilt_deg=measured.tilt_deg,
            fallen=measured.fallen,
            qpos=tuple(backend.qpos().tolist()),
            mocap_positions=tuple(backend.mocap_positions().ravel().tolist()),
            objects=tuple(ObjectPose(n, p) for n, p in backend.object_positions().items()),
            proprioception=Proprioception(
                orientation=_floats(measured.imu_quat),
                angular_velocity=_floats(measured.imu_gyro),
                linear_acceleration=_floats(measured.imu_accel),
                left_foot_n=_floats(measured.foot_forces[0]),
                right_foot_n=_floats(measured.foot_forces[1]),
            ),
            power=PowerState(voltage_v=b.voltage_v, current_a=b.current_a, soc=b.soc, power_w=b.power_w),
        )

    def tick_error(self, exc: Exception) -> bool:
        return False

    def after_safe_stop(self) -> None:
        """The loop applies the stop: nothing else to do."""

    def readings(
        self,
        stats: LoopStats,
        perception: Callable[[], PerceptionState | None],
        sensor_feed: Callable[[], SensorFeed],
        voice: Callable[[], Any],
    ) -> RobotReadings:
        assert self._links is not None, "bind the body to a robot first"
        latest_state = self._links.latest_state
        return RobotReadings(
            joint_names=self.joint_names,
            stats=stats,
            servos=self.servo_model.readings,
            power=lambda: latest_state().power,
            battery_cells=self.battery.spec.cells,
            perception=perception,
            sensor_feed=sensor_feed,
            sim_time=lambda: self._measured.sim_time_s,
            imu_stamp=lambda: self._measured.imu_stamp_s,
            voice=voice,
            sensor_hz=SENSOR_HZ,
            locomotion=lambda: latest_state().locomotion,
        )

    # ---------------------------------------------------------------------------------------------------------
    # what only a simulation can do

    def place_obstacle(self, command: PlaceObstacle) -> CommandReply:
        if not all(math.isfinite(v) and abs(v) < 50 for v in (command.x, command.y)):
            return CommandReply(False, "obstacle position must be finite and within 50 m", Refusal.INVALID)
        with self._lock:
            self._obstacles_pending.append((command.x, command.y))
        return CommandReply(True, f"placing an obstacle at ({command.x:.2f}, {command.y:.2f})")

    def inject_fault(self, command: InjectFault) -> CommandReply:
        """Faults for diagnostics to find (and tests to check that they do)."""
        fault, target, value = command.fault, command.target, command.value
        if not math.isfinite(value):
            return CommandReply(False, "the fault's value must be finite", Refusal.INVALID)
        try:
            refused = self._inject(fault, target, value)
        except ValueError as exc:
            return CommandReply(False, str(exc), Refusal.INVALID)
        if refused is not None:
            return CommandReply(False, refused, Refusal.INVALID)
        what = f"{fault.value}" + (f" on {target}" if target else "") + (f" ({value:g})" if value else "")
        level = Level.WARN if fault != Fault.CLEAR else Level.OK
        self._publish("sim/fault", f"fault injected: {what}", level, fault=fault.value, target=target, value=value)
        return CommandReply(True, f"fault injected: {what}")

    def _inject(self, fault: Fault, target: str, value: float) -> str | None:
        """Inject one fault; why not, if it cannot be."""
        if fault == Fault.SERVO_HEAT:
            self.servo_model.heat(target, value)
        elif fault == Fault.SERVO_OVERLOAD:
            self.servo_model.jam(target, value or 100.0)
        elif fault == Fault.IMU_LOST:
            self.backend.lose_imu(True)
        elif fault in (Fault.CAMERA_STALE, Fault.LIDAR_STALE):
            if self.perception is None:
                return "perception is off: no camera or lidar"
            self.perception.silence("camera" if fault == Fault.CAMERA_STALE else "lidar")
        elif fault == Fault.CONTROL_STALL:
            if not 0 < value <= 5:
                return "a control stall lasts 0-5 s"
            self._stall_s = value
        elif fault == Fault.SIM_DIVERGE:
            self._kick_pending = True
        elif fault == Fault.CONTROL_ERROR:
            if not 1 <= value <= 1000:
                return "a controller fault lasts 1-1000 ticks"
            self._raise_ticks = int(value)
        elif fault == Fault.BATTERY_SOC:
            if not 0 <= value <= 1:
                return "a state of charge is 0..1"
            self.battery.soc = value
        elif fault == Fault.CLEAR:
            self.servo_model.clear_faults()
            self.backend.lose_imu(False)
            if self.perception is not None:
                self.perception.silence("camera", False)
                self.perception.silence("lidar", False)
        else:
            return f"unknown fault {fault!r}"
        return None


def _floats(values: np.ndarray) -> tuple[float, ...]:
    return tuple(float(v) for v in values)
