"""Whole-body inverse kinematics with placo: feet, centre of mass and trunk orientation from the gait, arms and head
held by a soft joint task. Outputs joint position targets, as a servo would take them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import placo

from robot.control.gait import (
    COM_HEIGHT_M,
    FEET_SPACING_M,
    GaitSegment,
    load_placo_robot,
    put_at_walk_start,
    reach_initial_pose,
)
from robot.model import humanoid_v1

_SIDE_NAMES = {1: "left", 2: "right"}
# Upper-body joints the soft joint task holds while walking (legs are solved from the feet and CoM tasks).
UPPER_BODY_JOINTS = tuple(n for n in humanoid_v1.JOINT_NAMES if n not in humanoid_v1.LEG_JOINTS)
ARM_JOINTS = tuple(n for n in UPPER_BODY_JOINTS if not n.startswith("head") and n not in humanoid_v1.GRIPPER_JOINTS)
# The arms count as at rest (the standing posture's, which the stance-leg levelling was tuned with) within this of
# it (rad).
ARMS_AT_REST_TOLERANCE_RAD = 0.05


class WholeBodyIK:
    """placo's kinematics solver on humanoid_v1; one `track()` per control tick."""

    def __init__(self, model_path: Path, dt: float) -> None:
        self.robot = load_placo_robot(model_path)
        self.solver = placo.KinematicsSolver(self.robot)
        self.solver.enable_velocity_limits(True)
        self.solver.dt = dt
        for name in humanoid_v1.JOINT_NAMES:
            if name not in humanoid_v1.GRIPPER_JOINTS:
                self.robot.set_velocity_limit(name, humanoid_v1.SERVO_NO_LOAD_SPEED_RAD_S)
        self.tasks = placo.WalkTasks()
        self.tasks.initialize_tasks(self.solver, self.robot)
        self.upper_body = self.solver.add_joints_task()
        self.upper_body.configure("upper_body", "soft", 1.0)
        self.set_upper_body(humanoid_v1.stand_posture())
        self._joint_names = humanoid_v1.JOINT_NAMES
        self.reset_standing()

    def set_upper_body(self, posture: dict[str, float]) -> None:
        """Arms, wrists, grippers and head to hold while walking (at rest, or carrying something)."""
        self._upper = {n: float(posture[n]) for n in UPPER_BODY_JOINTS}
        self.upper_body.set_joints(self._upper)
        stand = humanoid_v1.stand_posture()
        self.arms_at_rest = all(abs(self._upper[n] - stand[n]) <= ARMS_AT_REST_TOLERANCE_RAD for n in ARM_JOINTS)

    def reset_standing(self) -> np.ndarray:
        """Standing pose at the origin of the planner's frame (where every walk starts); returns its targets."""
        put_at_walk_start(self.robot)
        for name, value in self._upper.items():  # a walk starts with the arms where they are held
            self.robot.set_joint(name, value)
        self.robot.update_kinematics()
        reach_initial_pose(self.tasks, FEET_SPACING_M, COM_HEIGHT_M)
        return self.joint_targets()

    def track(self, segment: GaitSegment, index: int) -> np.ndarray:
        """Solve one tick towards the gait sample `index` of `segment`; returns joint targets in JOINT_NAMES order."""
        self.tasks.update_tasks(segment.left[index], segment.right[index], segment.com[index], segment.trunk[index])
        self.robot.update_kinematics()
        self.solver.solve(True)
        support = int(segment.support[index])
        if support:
            # keep the kinematic model on the floor on its support foot, as placo's examples do, against drift
            self.robot.update_support_side(_SIDE_NAMES[support])
            self.robot.ensure_on_floor()
        return self.joint_targets()

    def joint_targets(self) -> np.ndarray:
        return np.array([self.robot.get_joint(n) for n in self._joint_names])
