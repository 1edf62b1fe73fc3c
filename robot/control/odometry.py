"""Leg odometry: where the trunk is in the world, from joint encoders, the IMU and the foot force pads.

A walking robot has no ground-truth pose, on hardware or in a fair simulation. The stance foot (the one carrying
more weight) is assumed not to slip: while it supports, the trunk's position follows from the measured joint
angles (forward kinematics on the controller's model) and the IMU's orientation. When the weight moves to the
other foot, that foot is anchored where the kinematics put it at that moment. Heading comes from the IMU, so
foot rotation slip does not accumulate in yaw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import placo

from robot.control.gait import native_stdout_silenced
from robot.model import humanoid_v1

# The other foot becomes the stance foot when it carries this much more force (N) than the current one and lies
# flat (a foot landing on its toe or heel still rolls, so it is no anchor yet), or when the current one has lifted.
STANCE_SWITCH_MARGIN_N = 3.0
FLAT_FOOT_TILT_RAD = math.radians(3.0)
LIFTED_FORCE_N = 2.0
_FEET = ("left", "right")


@dataclass(frozen=True)
class Pose2D:
    x: float
    y: float
    yaw: float


def quat_to_matrix(quat_wxyz: np.ndarray) -> np.ndarray:
    w, x, y, z = (float(v) for v in quat_wxyz)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


class LegOdometry:
    def __init__(self, model_path: Path) -> None:
        with native_stdout_silenced():
            self._robot = placo.RobotWrapper(str(model_path), placo.Flags.mjcf)
        self._names = humanoid_v1.JOINT_NAMES
        # where each joint sits in placo's configuration vector: the legs' angles go in with one assignment
        self._joint_offsets = np.array([self._robot.get_joint_offset(name) for name in self._names])
        self._stance: str | None = None
        self._anchor = np.zeros(3)  # world position of the stance foot
        self.position = np.zeros(3)  # trunk (model root) in the world
        self.rotation = np.eye(3)
        self._yaw_offset = 0.0  # world heading minus the IMU's (the IMU's yaw reference is arbitrary)

    def reset(self, pose: Pose2D, joint_positions: np.ndarray, imu_quat: np.ndarray) -> None:
        """Start from a known trunk pose (x, y, yaw); height comes from the legs, feet on the floor."""
        self._stance = None
        feet, _ = self._feet_in_trunk(joint_positions)
        rotation = _with_yaw(quat_to_matrix(imu_quat), pose.yaw)
        lowest = min(float((rotation @ p)[2]) for p in feet.values())
        self.position = np.array([pose.x, pose.y, -lowest])
        self.rotation = rotation
        self._yaw_offset = pose.yaw - _yaw(quat_to_matrix(imu_quat))

    def update(self, joint_positions: np.ndarray, imu_quat: np.ndarray, foot_forces: np.ndarray) -> Pose2D:
        """One estimate per control tick; `foot_forces` is (2, pads) for left and right. A tick without an IMU or
        joint reading (NaN: a real robot's sensor missed it) leaves the estimate where it was: a gap, not a NaN pose
        the map and the navigation would keep."""
        if not (np.isfinite(imu_quat).all() and np.isfinite(joint_positions).all()):
            return self.pose
        imu = quat_to_matrix(imu_quat)
        rotation = _with_yaw(imu, _yaw(imu) + self._yaw_offset)
        feet, feet_rotation = self._feet_in_trunk(joint_positions)
        load = {side: float(np.sum(foot_forces[i])) for i, side in enumerate(_FEET)}
        if self._stance is None:
            self._stance = max(_FEET, key=lambda s: load[s])
            self._anchor = self.position + rotation @ feet[self._stance]
            self._anchor[2] = 0.0
        # where the trunk is now, from the stance foot; a new stance foot is anchored from this same instant
        # (anchoring it from the previous tick's trunk cost a few mm per step, 16 cm over 18 s sideways)
        position = self._anchor - rotation @ feet[self._stance]
        other = "right" if self._stance == "left" else "left"
        takes_weight = load[other] > load[self._stance] + STANCE_SWITCH_MARGIN_N
        flat = _tilt(rotation @ feet_rotation[other]) < FLAT_FOOT_TILT_RAD
        lifted = load[self._stance] < LIFTED_FORCE_N and load[other] > LIFTED_FORCE_N
        if (takes_weight and flat) or lifted:
            self._stance = other
            self._anchor = position + rotation @ feet[other]
            self._anchor[2] = 0.0  # a foot that takes the weight is on the floor (flat floors): height cannot drift
        self.rotation = rotation
        self.position = position
        return self.pose

    @property
    def pose(self) -> Pose2D:
        return Pose2D(float(self.position[0]), float(self.position[1]), _yaw(self.rotation))

    @property
    def stance(self) -> str | None:
        return self._stance

    def _feet_in_trunk(self, joint_positions: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Sole positions and orientations in the trunk frame, from the measured joint angles."""
        robot = self._robot
        if len(joint_positions) != len(self._joint_offsets):
            raise ValueError(f"{len(joint_positions)} joint positions for {len(self._joint_offsets)} joints")
        q = robot.state.q
        q[self._joint_offsets] = joint_positions
        robot.state.q = q
        robot.set_T_world_fbase(np.eye(4))
        robot.update_kinematics()
        frames = {side: robot.get_T_world_frame(humanoid_v1.FOOT_FRAMES[side]) for side in _FEET}
        return {s: frames[s][:3, 3].copy() for s in _FEET}, {s: frames[s][:3, :3].copy() for s in _FEET}


def _yaw(rotation: np.ndarray) -> float:
    return math.atan2(rotation[1, 0], rotation[0, 0])


def _tilt(rotation: np.ndarray) -> float:
    return math.acos(max(-1.0, min(1.0, float(rotation[2, 2]))))


def _with_yaw(rotation: np.ndarray, yaw: float) -> np.ndarray:
    """`rotation` with its heading replaced by `yaw` (tilt kept)."""
    delta = yaw - _yaw(rotation)
    c, s = math.cos(delta), math.sin(delta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ rotation
