"""The hardware-in-the-loop rig's plant: MuJoCo physics behind the emulated servo bus. The servos' goal positions
and torque switches (as the real-robot code wrote them, byte by byte) steer the simulated joints at the model's
actuator gains; the joints' positions, velocities and torques, the trunk's IMU and the soles' pads go back into
the emulated devices' control tables, where the real-robot code reads them.

`RealTimePhysics` steps it at the wall clock's pace, between the packets the bus answers; `LockstepPhysics` one
control period per tick of the robot.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

from robot.hardware import control_table as ct
from robot.hardware.bus_emulator import EmulatedXM430
from robot.hardware.config import HardwareConfig
from robot.hardware.sensor_emulators import EmulatedFSR, EmulatedOpenCR
from robot.model import humanoid_v1
from robot.sim.backend import MujocoSimBackend

MAX_STEPS_PER_BLOCK = 3  # physics steps taken at once when behind (a packet waits for them); further behind, the
# lag is dropped and counted
MIN_BLOCK_S = 0.002  # the goals are taken and the outputs given back at least this often (a servo's own loop)


@dataclass(frozen=True)
class RigTruth:
    """What the rig knows and the robot does not: where the robot really is, and the world's objects."""

    sim_time_s: float
    base_position: tuple[float, float, float]
    base_yaw_rad: float
    tilt_deg: float
    fallen: bool
    objects: dict[str, tuple[float, float, float]]
    late_blocks: int  # times the physics fell behind the wall clock by more than a block and dropped the lag
    on_stand: bool  # the robot still hangs on its stand (torque has never been on)


class RigPlant:
    """Couples the simulated robot to the emulated devices; called under the bus's lock (no packet is answered
    half-way through a block)."""

    def __init__(
        self,
        backend: MujocoSimBackend,
        config: HardwareConfig,
        servos: Mapping[int, EmulatedXM430],
        imu: EmulatedOpenCR | None,
        feet: Mapping[str, EmulatedFSR],
    ) -> None:
        """`feet`: the FSR modules by side ("left", "right")."""
        self.backend = backend
        names = list(backend.joint_names)
        per_unit = humanoid_v1.servo_torque_per_unit()
        self._joints = [
            (names.index(j.joint), j, servos[j.servo_id], per_unit[names.index(j.joint)])
            for j in config.joints
            if j.servo_id in servos and j.joint in names
        ]
        self._imu = imu
        self._feet = dict(feet)
        self._targets = backend.stand_targets()
        self._limp = np.ones(len(names), dtype=bool)
        self._lock = threading.Lock()  # MjData: the physics thread steps it, `truth` reads it
        self.on_stand = True  # the robot hangs on its stand, unmoving, until torque first comes on
        self.scene_out: Callable[[mujoco.MjData], None] | None = None  # where the scene's pose goes after a block

    def take_goals(self) -> None:
        """The servos' goals and torque switches into the actuators (a limp servo's actuator exerts nothing)."""
        for index, joint, servo, _ in self._joints:
            self._targets[index] = joint.to_joint(servo.goal_rad)
            self._limp[index] = not servo.torque_enabled
        if self.on_stand and not self._limp.all():
            self.on_stand = False
        with self._lock:
            self.backend.write(self._targets)
            self.backend.set_limp(self._limp)

    def step(self, duration_s: float) -> None:
        if self.on_stand:
            return
        with self._lock:
            self.backend.step(duration_s)

    def advance(self, duration_s: float) -> None:
        """The goals in, `duration_s` of physics, the outputs back."""
        self.take_goals()
        self.step(duration_s)
        self.report()

    def report(self) -> None:
        """The joints, the IMU and the pads into the devices' control tables."""
        with self._lock:
            m = self.backend.read()
        for index, joint, servo, per_unit in self._joints:
            gear = joint.direction * joint.scale
            servo.drive(
                joint.to_servo_rad(float(m.joint_positions[index])),
                float(m.joint_velocities[index]) * gear,
                float(m.joint_torques[index]) * per_unit,
            )
        if self._imu is not None:
            self._imu.sense(m.imu_quat, m.imu_gyro, m.imu_accel)
        if self.scene_out is not None:  # for the cameras and the lidar, drawn in their own process
            with self._lock:
                self.scene_out(self.backend.data)
        for row, side in enumerate(("left", "right")):
            if side in self._feet:
                self._feet[side].sense(m.foot_forces[row])

    def truth(self, late_blocks: int = 0) -> RigTruth:
        with self._lock:
            m = self.backend.read()
            objects = self.backend.object_positions()
        return RigTruth(
            sim_time_s=m.sim_time_s,
            base_position=tuple(float(v) for v in m.base_position),
            base_yaw_rad=m.yaw_rad,
            tilt_deg=m.tilt_deg,
            fallen=m.fallen,
            objects=objects,
            late_blocks=late_blocks,
            on_stand=self.on_stand,
        )


class RealTimePhysics:
    """Paces the plant to the wall clock from the bus's own thread (`EmulatedBus.attach`): one thread, so a packet
    never waits for another thread to give up the interpreter, and a physics that cannot keep up pauses the
    robot's world (counted in `late_blocks`) instead of taking the host's cores."""

    def __init__(self, plant: RigPlant, dt: float) -> None:
        self.plant = plant
        self.dt = dt
        self.late_blocks = 0
        self._block = max(1, math.ceil(MIN_BLOCK_S / dt - 1e-9))
        self._start: float | None = None
        self._simulated = 0.0

    def between_packets(self) -> float:
        now = time.monotonic()
        if self._start is None:
            self._start = now
        elapsed = now - self._start
        due = self._simulated + self._block * self.dt
        if elapsed < due:
            return due - elapsed
        steps = min(MAX_STEPS_PER_BLOCK, max(self._block, math.floor((elapsed - self._simulated) / self.dt)))
        self.plant.advance(steps * self.dt)
        self._simulated += steps * self.dt
        lag = time.monotonic() - self._start - self._simulated
        if lag > MAX_STEPS_PER_BLOCK * self.dt:  # the host was busy: the robot's world pauses, as it cannot
            self._start += lag
            self.late_blocks += 1
        return 0.0

    def before_sync_read(self, address: int, length: int) -> None:
        """The outputs are given back after every block already."""


class LockstepPhysics:
    """Advances the plant one control period each time the host reads the servos' positions (once a tick): the
    robot's world then moves with the host's ticks, not the wall clock, so a busy host is slower but sees the
    same physics (for tests and benchmarks on a shared machine)."""

    late_blocks = 0

    def __init__(self, plant: RigPlant, period_s: float) -> None:
        self.plant = plant
        self.period_s = period_s

    def between_packets(self) -> float:
        return math.inf

    def before_sync_read(self, address: int, length: int) -> None:
        if address <= ct.PRESENT_POSITION.address < address + length:
            self.plant.advance(self.period_s)
