"""Assembles the locomotion stack for a backend: gait planner, whole-body IK, balance and leg odometry."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np

from robot.control.balance import AnkleBalance
from robot.control.gait import write_placo_model
from robot.control.gait_process import InlineGaitPlanner, ProcessGaitPlanner
from robot.control.locomotion import LegSensors, LocomotionController
from robot.control.odometry import LegOdometry, Pose2D
from robot.control.whole_body import WholeBodyIK

CONTROL_DT = 0.01


class SensingBackend(Protocol):
    def joint_axes(self) -> dict[str, np.ndarray]: ...


class HasLegSensors(Protocol):
    joint_positions: np.ndarray
    imu_quat: np.ndarray
    imu_gyro: np.ndarray
    foot_forces: np.ndarray
    base_position: np.ndarray

    @property
    def yaw_rad(self) -> float: ...


def build_locomotion(
    backend: SensingBackend,
    model_dir: Path | None = None,
    planner_process: bool = True,
    pose_loop: bool = True,
    realtime: bool = False,
) -> LocomotionController:
    """The locomotion stack: gait planner (own process, or inline for tests and tools), IK, balance, odometry.
    `model_dir`: where the placo model goes (default: the per-user cache, see `write_placo_model`); `realtime`: a
    late plan does not stall the control loop (headless, the walk waits for each plan: the same on every run)."""
    model = write_placo_model(model_dir)
    planner = ProcessGaitPlanner(model, CONTROL_DT) if planner_process else InlineGaitPlanner(model, CONTROL_DT)
    return LocomotionController(
        planner,
        WholeBodyIK(model, CONTROL_DT),
        AnkleBalance(backend.joint_axes()),
        CONTROL_DT,
        LegOdometry(model),
        pose_loop=pose_loop,
        wait_for_plans=not realtime,
    )


def sensors(m: HasLegSensors) -> LegSensors:
    return LegSensors(m.joint_positions, m.imu_quat, m.imu_gyro, m.foot_forces)


def measured_pose(m: HasLegSensors) -> Pose2D:
    """The simulator's trunk pose: where a reset put the robot (a known start), or ground truth for benchmarks."""
    return Pose2D(float(m.base_position[0]), float(m.base_position[1]), m.yaw_rad)
