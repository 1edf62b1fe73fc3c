"""Whole-body reaching with placo: one hand to a point, both feet planted, the centre of mass over the feet.

The OP3's shoulder roll, elbow and humanoid_v1's wrist turn about one axis, so each arm moves in a plane that the
shoulder pitch tilts; the gripper closes across the forearm in that plane. Keeping the closing axis horizontal and
sideways (the fingers either side of an upright mug) then fixes how the arm plane tilts, and the legs take up the
rest: the solver lowers the trunk (a crouch) so the shoulder comes down towards the hand. Everything is expressed
in the *feet frame*: midway between the soles, on the floor, x forward.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import placo

from robot.control.gait import load_placo_robot
from robot.model import humanoid_v1

# Joint speed cap while reaching (rad/s): FINDINGS' 3 rad/s, well under the XM430's no-load speed.
REACH_JOINT_SPEED_RAD_S = 3.0
# Lowest and highest trunk above the feet the solver is steered to (m); standing is about 0.27.
MIN_TRUNK_HEIGHT_M = 0.17
MAX_TRUNK_HEIGHT_M = 0.27
# The shoulder sits this far above the trunk frame (m), from the model.
SHOULDER_ABOVE_TRUNK_M = 0.111

# The reaching arm is drawn weakly towards this posture (right arm; the left mirrors it), so that the solver keeps
# the elbow below and outside the hand instead of folding the arm back through the trunk.
REACH_POSTURE_RIGHT = {"r_sho_pitch": -1.8, "r_sho_roll": 0.5, "r_el": -1.5, "r_wrist": 0.5}

_WEIGHTS = {
    "com": 10000.0,
    "reach_posture": 0.05,
    "hand": 1000.0,
    "closing_axis": 5.0,
    "trunk_height": 10.0,
    "trunk_orientation": 10.0,
}


def _feet_frame(robot: placo.HumanoidRobot) -> np.ndarray:
    """The feet frame in placo's world: midway between the soles, on the floor, yawed as the feet are on average."""
    left, right = robot.get_T_world_frame("left_foot"), robot.get_T_world_frame("right_foot")
    yaw = np.arctan2(left[1, 0] + right[1, 0], left[0, 0] + right[0, 0])
    frame = np.eye(4)
    frame[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    frame[:3, 3] = (left[:3, 3] + right[:3, 3]) / 2
    return frame


class ReachIK:
    """Whole-body IK for one hand; `start()` from the joints as they are, then one `solve()` per control tick."""

    def __init__(self, model_path: Path, dt: float) -> None:
        self.robot = load_placo_robot(model_path)
        self.dt = dt
        self._names = humanoid_v1.JOINT_NAMES
        self._side = "right"
        self._solver: placo.KinematicsSolver | None = None
        self._tasks: dict[str, object] = {}

    @property
    def side(self) -> str:
        return self._side

    def start(self, joints: np.ndarray, side: str, hold_legs: bool = False) -> None:
        """Take the posture `joints` (JOINT_NAMES order) as the current one, feet flat, the feet frame as origin,
        and build the tasks for reaching with `side`'s hand (the other arm and the head hold still; with
        `hold_legs` the legs too, for arm moves while standing, where only the arm may move)."""
        if side not in humanoid_v1.HAND_FRAMES:
            raise ValueError(f"side must be 'left' or 'right', got {side!r}")
        self._side = side
        self._set_joints(joints)
        robot = self.robot
        robot.set_T_world_fbase(np.eye(4))
        robot.update_kinematics()
        robot.set_T_world_fbase(np.linalg.inv(_feet_frame(robot)))
        robot.update_kinematics()

        solver = placo.KinematicsSolver(robot)
        solver.mask_fbase(hold_legs)
        solver.enable_joint_limits(True)
        solver.enable_velocity_limits(True)
        solver.dt = self.dt
        for name in self._names:
            robot.set_velocity_limit(name, REACH_JOINT_SPEED_RAD_S)
        self._tasks = {}
        if hold_legs:
            for name in humanoid_v1.LEG_JOINTS:
                solver.mask_dof(name)
        else:
            for foot in humanoid_v1.FOOT_FRAMES.values():
                solver.add_frame_task(foot, robot.get_T_world_frame(foot)).configure(foot, "hard", 1.0)
            com = solver.add_com_task(np.zeros(3))
            com.mask.set_axises("xy")
            com.configure("com", "soft", _WEIGHTS["com"])  # soft: a hard CoM task can make the QP infeasible
            trunk_orientation = solver.add_orientation_task(humanoid_v1.TRUNK_FRAME, np.eye(3))
            trunk_orientation.configure("trunk_orientation", "soft", _WEIGHTS["trunk_orientation"])
            trunk = robot.get_T_world_frame(humanoid_v1.TRUNK_FRAME)[:3, 3]
            trunk_height = solver.add_position_task(humanoid_v1.TRUNK_FRAME, trunk)
            trunk_height.mask.set_axises("z")
            trunk_height.configure("trunk_height", "soft", _WEIGHTS["trunk_height"])
            self._tasks["trunk_height"] = trunk_height
        hand_frame = humanoid_v1.HAND_FRAMES[side]
        hand = solver.add_position_task(hand_frame, robot.get_T_world_frame(hand_frame)[:3, 3])
        hand.configure("hand", "soft", _WEIGHTS["hand"])
        # the gripper's closing axis (the hand frame's z) across the body, horizontal
        closing = solver.add_axisalign_task(hand_frame, np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0]))
        closing.configure("closing_axis", "soft", 0.0)
        # The other arm and the head are not the solver's to move: as a soft task, the centre of mass task rolled the
        # other arm 0.3 rad in while setting a mug down, pressing its forearm into the trunk (the shoulder servo
        # overloaded and the robot stopped); the legs balance the reach.
        prefix = side[0] + "_"
        for name in self._names:
            if name not in humanoid_v1.LEG_JOINTS and not name.startswith(prefix):
                solver.mask_dof(name)
        preferred = solver.add_joints_task()
        preferred.set_joints(reach_posture(side))
        preferred.configure("reach_posture", "soft", _WEIGHTS["reach_posture"])
        solver.add_regularization_task(1e-4)
        self._solver = solver
        self._tasks.update({"hand": hand, "closing": closing})

    def _set_joints(self, joints: np.ndarray) -> None:
        for name, value in zip(self._names, joints, strict=True):
            self.robot.set_joint(name, float(value))

    def solve(
        self, hand_target: np.ndarray, trunk_height: float, orientation_weight: float, gripper: float
    ) -> np.ndarray:
        """One tick towards the hand at `hand_target` (feet frame) with the trunk at `trunk_height`; the
        closing-axis task at `orientation_weight` (ramped in by the caller: switching it on at once saturates the
        servos). Returns joint targets in JOINT_NAMES order, with the hand's gripper at `gripper` (m open)."""
        assert self._solver is not None, "start() first"
        self._tasks["hand"].target_world = np.asarray(hand_target, dtype=float)
        height = float(np.clip(trunk_height, MIN_TRUNK_HEIGHT_M, MAX_TRUNK_HEIGHT_M))
        if "trunk_height" in self._tasks:  # not when the legs are held
            self._tasks["trunk_height"].target_world = np.array([0.0, 0.0, height])
        # the fingers are symmetric: align the closing axis with +y or -y, whichever is nearer
        closing_now = self.robot.get_T_world_frame(humanoid_v1.HAND_FRAMES[self._side])[:3, 2]
        self._tasks["closing"].targetAxis_world = np.array([0.0, 1.0 if closing_now[1] >= 0 else -1.0, 0.0])
        self._tasks["closing"].configure("closing_axis", "soft", float(orientation_weight) * _WEIGHTS["closing_axis"])
        self.robot.update_kinematics()
        self._solver.solve(True)
        self.robot.update_kinematics()
        targets = np.array([self.robot.get_joint(n) for n in self._names])
        targets[self._names.index(f"{self._side[0]}_grip")] = gripper
        return targets

    def trunk_height(self) -> float:
        return float(self.robot.get_T_world_frame(humanoid_v1.TRUNK_FRAME)[2, 3])

    def hand_position(self, joints: np.ndarray | None = None, side: str | None = None) -> np.ndarray:
        """Where a hand is in the feet frame: for the solver's own state, or for `joints` (forward kinematics of
        measured positions, with the feet flat; the solver's state is left as it was)."""
        robot = self.robot
        frame = humanoid_v1.HAND_FRAMES[side or self._side]
        if joints is None:
            return robot.get_T_world_frame(frame)[:3, 3].copy()
        saved_q = robot.state.q.copy()
        self._set_joints(joints)
        robot.update_kinematics()
        feet = _feet_frame(robot)
        hand = np.linalg.inv(feet) @ robot.get_T_world_frame(frame)
        robot.state.q = saved_q
        robot.update_kinematics()
        return hand[:3, 3].copy()

    def trunk_in_feet(self, joints: np.ndarray) -> np.ndarray:
        """The trunk's pose (4x4) in the feet frame for `joints` with the feet flat (to place things seen from the
        trunk into the feet frame)."""
        robot = self.robot
        saved_q = robot.state.q.copy()
        self._set_joints(joints)
        robot.update_kinematics()
        trunk = np.linalg.inv(_feet_frame(robot)) @ robot.get_T_world_frame(humanoid_v1.TRUNK_FRAME)
        robot.state.q = saved_q
        robot.update_kinematics()
        return trunk

    def trunk_ahead_of_com(self, joints: np.ndarray) -> np.ndarray:
        """How far (x ahead, y to the left, m; feet frame) the trunk is from the centre of mass for `joints`: the
        walk ends with the centre of mass over the feet, so this is where the trunk stands over them, which depends
        on the arms (hanging, 1 cm; held back, 3.5 cm ahead)."""
        robot = self.robot
        saved_q = robot.state.q.copy()
        self._set_joints(joints)
        robot.update_kinematics()
        to_feet = np.linalg.inv(_feet_frame(robot))
        trunk = robot.get_T_world_frame(humanoid_v1.TRUNK_FRAME)[:3, 3]
        offset = to_feet[:2, :3] @ (trunk - robot.com_world())
        robot.state.q = saved_q
        robot.update_kinematics()
        return offset


def reach_posture(side: str) -> dict[str, float]:
    if side == "right":
        return dict(REACH_POSTURE_RIGHT)
    return humanoid_v1.mirror_arm_joints(REACH_POSTURE_RIGHT)


def trunk_height_for(hand_z: float) -> float:
    """The trunk height that brings the shoulder a little above a hand at `hand_z` (feet frame), within limits."""
    return float(np.clip(hand_z - SHOULDER_ABOVE_TRUNK_M + 0.03, MIN_TRUNK_HEIGHT_M, MAX_TRUNK_HEIGHT_M))
