"""MuJoCo backend: the simulated robot behind the same read/write/step calls a servo bus would offer.

Only the control thread calls these methods; nothing else touches `MjData`.
"""

from __future__ import annotations

import mujoco
import numpy as np

from robot.core.measurements import Measurements
from robot.model import humanoid_v1
from robot.model.scene import (
    SPARE_OBSTACLE_HALF,
    SPARE_OBSTACLES,
    SPARE_PARKING,
    build_scene,
    object_body_name,
    spare_obstacle_name,
)
from robot.model.world import WorldLayout

# Gap left under the soles when the robot is placed, so it settles onto the floor instead of starting in it (m).
SOLE_CLEARANCE_M = 0.001


class SimulationDiverged(RuntimeError):
    """The physics blew up (NaN, inf or huge values): the scene was reset by MuJoCo and must be set up again."""


_DIVERGENCE_WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQPOS: "bad position",
    mujoco.mjtWarning.mjWARN_BADQVEL: "bad velocity",
    mujoco.mjtWarning.mjWARN_BADQACC: "bad acceleration",
}


class MujocoSimBackend:
    """The OP3 in its apartment, stepped at the physics rate, commanded through position actuators."""

    def __init__(self, layout: WorldLayout, model: mujoco.MjModel | None = None) -> None:
        self.layout = layout
        # physics only: the robot's detailed meshes are drawn by the cameras' and views' own models
        self.model = model if model is not None else build_scene(layout, drawn=False)
        self.data = mujoco.MjData(self.model)
        self._joint_qpos = np.array([self.model.joint(n).qposadr[0] for n in humanoid_v1.JOINT_NAMES])
        self._joint_dof = np.array([self.model.joint(n).dofadr[0] for n in humanoid_v1.JOINT_NAMES])
        self._actuator = np.array([self.model.actuator(n + "_act").id for n in humanoid_v1.JOINT_NAMES])
        self._trunk = self.model.body(humanoid_v1.TRUNK_BODY).id
        self._robot_root = self._root_of(self._trunk)
        self._object_bodies = {o.name: self.model.body(object_body_name(o.name)).id for o in layout.objects}
        self.joint_names = humanoid_v1.JOINT_NAMES
        self._gyro = self._sensor_slice("imu_gyro")
        self._imu_quat = self._sensor_slice("imu_quat")
        self._accel = self._sensor_slice("imu_accel")
        self._fsr = [self._sensor_slice(f"{side}_foot_fsr{i}") for side in ("left", "right") for i in range(4)]
        self._spares = [
            int(self.model.body_mocapid[self.model.body(spare_obstacle_name(i)).id]) for i in range(SPARE_OBSTACLES)
        ]
        self._spares_placed = 0
        self._imu_frozen: tuple[float, np.ndarray, np.ndarray, np.ndarray] | None = None
        self.reset()

    def place_obstacle(self, x: float, y: float) -> int:
        """Drop one of the spare obstacles (a 14 x 14 x 30 cm box) at (x, y); returns which, or raises when all are
        placed already."""
        if self._spares_placed >= len(self._spares):
            raise ValueError(f"all {len(self._spares)} spare obstacles are placed already (reset to take them back)")
        index = self._spares_placed
        self.data.mocap_pos[self._spares[index]] = (x, y, SPARE_OBSTACLE_HALF[2])
        self._spares_placed += 1
        return index

    def _root_of(self, body: int) -> int:
        """The robot's root body (a child of the world): its subtree's centre of mass is the robot's."""
        while self.model.body_parentid[body] != 0:
            body = int(self.model.body_parentid[body])
        return body

    def _sensor_slice(self, name: str) -> slice:
        sensor = self.model.sensor(name)
        return slice(int(sensor.adr[0]), int(sensor.adr[0] + sensor.dim[0]))

    def joint_axes(self) -> dict[str, np.ndarray]:
        """Each joint's axis in its own link frame (for controllers that must get signs right)."""
        return {n: self.model.joint(n).axis.copy() for n in humanoid_v1.JOINT_NAMES}

    @property
    def physics_dt(self) -> float:
        return float(self.model.opt.timestep)

    def reset(self, posture: np.ndarray | None = None) -> None:
        """Robot standing at its start pose in `posture` (default: the model's), soles on the floor; objects where
        the layout puts them."""
        mujoco.mj_resetData(self.model, self.data)
        if getattr(self, "_imu_frozen", None) is not None:  # a lost IMU stays lost; its last sample is from now on
            self._imu_frozen = (0.0, *self._imu_frozen[1:])
        for i, mocap in enumerate(getattr(self, "_spares", [])):
            self.data.mocap_pos[mocap] = (SPARE_PARKING[0] + i, SPARE_PARKING[1], SPARE_OBSTACLE_HALF[2])
        self._spares_placed = 0
        stand = self.stand_targets() if posture is None else np.asarray(posture, dtype=float)
        self.data.qpos[self._joint_qpos] = stand
        self.data.ctrl[self._actuator] = stand
        for grip in humanoid_v1.GRIPPER_JOINTS:  # each gripper's second finger mirrors the first
            value = stand[humanoid_v1.JOINT_NAMES.index(grip)]
            self.data.qpos[self.model.joint(grip + "_mimic").qposadr[0]] = value
        mujoco.mj_kinematics(self.model, self.data)
        sole_z = min(self.data.site(name).xpos[2] for name in humanoid_v1.FOOT_FRAMES.values())
        self.data.qpos[2] -= sole_z - SOLE_CLEARANCE_M
        mujoco.mj_forward(self.model, self.data)

    def stand_targets(self) -> np.ndarray:
        posture = humanoid_v1.stand_posture()
        return np.array([posture[n] for n in humanoid_v1.JOINT_NAMES])

    def lose_imu(self, lost: bool) -> None:
        """Simulate an IMU that stops answering: its last sample is read again and again, with its old stamp."""
        d = self.data
        self._imu_frozen = (
            (
                float(d.time),
                d.sensordata[self._imu_quat].copy(),
                d.sensordata[self._gyro].copy(),
                d.sensordata[self._accel].copy(),
            )
            if lost
            else None
        )

    def read(self) -> Measurements:
        d = self.data
        if self._imu_frozen is None:
            imu_stamp, imu_quat = float(d.time), d.sensordata[self._imu_quat].copy()
            gyro, accel = d.sensordata[self._gyro].copy(), d.sensordata[self._accel].copy()
        else:
            imu_stamp, imu_quat, gyro, accel = (v.copy() if isinstance(v, np.ndarray) else v for v in self._imu_frozen)
        return Measurements(
            sim_time_s=float(d.time),
            joint_positions=d.qpos[self._joint_qpos].copy(),
            joint_velocities=d.qvel[self._joint_dof].copy(),
            base_position=d.qpos[0:3].copy(),
            base_quat=d.qpos[3:7].copy(),
            imu_quat=imu_quat,
            imu_gyro=gyro,
            imu_accel=accel,
            imu_stamp_s=imu_stamp,
            foot_forces=np.array([d.sensordata[s][0] for s in self._fsr]).reshape(2, 4),
            joint_torques=d.actuator_force[self._actuator].copy(),
            com=d.subtree_com[self._robot_root].copy(),
        )

    def write(self, joint_targets: np.ndarray) -> None:
        self.data.ctrl[self._actuator] = joint_targets

    def set_limp(self, limp: np.ndarray) -> None:
        """Joints whose servo has torque off (a bool per joint): their actuators exert nothing until set back."""
        if not hasattr(self, "_gains"):
            self._gains = self.model.actuator_gainprm[self._actuator, 0].copy()
            self._biases = self.model.actuator_biasprm[self._actuator, 1:3].copy()
        limp = np.asarray(limp, dtype=bool)
        self.model.actuator_gainprm[self._actuator, 0] = np.where(limp, 0.0, self._gains)
        self.model.actuator_biasprm[self._actuator, 1:3] = np.where(limp[:, None], 0.0, self._biases)

    def step(self, duration_s: float) -> None:
        """Advance physics by `duration_s` (a whole number of physics steps). Raises `SimulationDiverged` when
        MuJoCo found a NaN, infinite or huge position, velocity or acceleration: it then resets the whole model to
        its default pose by itself, so the caller must put the robot back on its feet."""
        n = max(1, round(duration_s / self.physics_dt))
        before = [int(self.data.warning[w].number) for w in _DIVERGENCE_WARNINGS]
        mujoco.mj_step(self.model, self.data, nstep=n)
        for warning, count in zip(_DIVERGENCE_WARNINGS, before, strict=True):
            if int(self.data.warning[warning].number) > count:
                raise SimulationDiverged(
                    f"physics diverged at t={self.data.time:.3f} s ({_DIVERGENCE_WARNINGS[warning]}, in dof "
                    f"{self.model.joint(self.model.dof_jntid[self.data.warning[warning].lastinfo]).name or 'free'})"
                    if 0 <= self.data.warning[warning].lastinfo < self.model.nv
                    else f"physics diverged at t={self.data.time:.3f} s ({_DIVERGENCE_WARNINGS[warning]})"
                )

    def kick(self, speed: float = 1e12) -> None:
        """Injected fault: a velocity no physics survives on the robot's first joint (MuJoCo will find it)."""
        self.data.qvel[self._joint_dof[0]] = speed

    def qpos(self) -> np.ndarray:
        return self.data.qpos.copy()

    def qpos_with_joints(self, joint_positions: np.ndarray) -> np.ndarray:
        """The scene's qpos as it stands, with the robot's joints at `joint_positions` (what a viewer needs to draw
        a real robot's measured pose in this model)."""
        qpos = self.data.qpos.copy()
        qpos[self._joint_qpos] = joint_positions
        return qpos

    def mocap_positions(self) -> np.ndarray:
        """(n, 3) positions of the kinematic bodies (the spare obstacles): part of the scene beside qpos."""
        return self.data.mocap_pos.copy()

    def object_positions(self) -> dict[str, tuple[float, float, float]]:
        return {name: tuple(float(v) for v in self.data.xpos[b]) for name, b in self._object_bodies.items()}
