"""The robot's parts as the skills see them (the protocols of `robot.skills.body`), over the core's units: the legs
are the motion inbox and locomotion, the arm is the joint arbiter's, the localiser is leg odometry corrected by the
map. Built by `robot.robot` only."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from robot.control.locomotion import LocomotionController, Velocity, VelocityLimits
from robot.control.odometry import LegOdometry
from robot.core.arbiter import JointArbiter
from robot.core.inbox import MotionInbox
from robot.core.safety import SafetyLatch
from robot.manipulation.arm_motion import ArmMotion, Move
from robot.manipulation.grasp_plan import Hand
from robot.perception.geometry import yaw_of
from robot.perception.service import PerceptionService


class SimClock:
    """Simulated time, as the control loop last published it."""

    def __init__(self, now: Callable[[], float]) -> None:
        self.now = now


class RobotLegs:
    def __init__(self, inbox: MotionInbox, locomotion: LocomotionController, latch: SafetyLatch) -> None:
        self._inbox = inbox
        self._loco = locomotion
        self._latch = latch

    @property
    def limits(self) -> VelocityLimits:
        return self._loco.velocity.limits

    @property
    def moving(self) -> bool:
        return self._loco.moving

    def drive(self, velocity: Velocity) -> None:
        self._inbox.drive(velocity)

    def halt_here(self) -> None:
        self._inbox.halt_promptly()

    def fallen(self) -> bool:
        return self._latch.fallen


class RobotArm:
    """The arms through the joint arbiter, and what the reaching hand holds."""

    def __init__(self, arbiter: JointArbiter, joint_positions: Callable[[], np.ndarray]) -> None:
        self._arbiter = arbiter
        self._joint_positions = joint_positions
        self._held: str | None = None

    @property
    def active(self) -> bool:
        return self._arbiter.arm_active

    @property
    def standing(self) -> bool:
        return self._arbiter.posture_settled

    @property
    def default_stand(self) -> np.ndarray:
        return self._arbiter.default_stand

    @property
    def held(self) -> str | None:
        return self._held

    def hold_object(self, name: str | None) -> None:
        self._held = name

    def grasping(self) -> bool:
        return self._arbiter.grasping()

    def motion(self) -> ArmMotion:
        return self._arbiter.arm_motion()

    @property
    def hand(self) -> Hand:
        return self._arbiter.hand

    def take(self, hand: Hand | None = None) -> ArmMotion:
        return self._arbiter.take_arm(hand)

    def release(self, upper_body: np.ndarray | None) -> None:
        self._arbiter.release_arm(upper_body)

    def finish_in_background(self, moves: list[Move]) -> None:
        self._arbiter.finish_arm_in_background(moves)

    def joint_positions(self) -> np.ndarray:
        return self._joint_positions()


class MapLocaliser:
    """The trunk's pose by leg odometry and the IMU, corrected into the map by scan matching when there is one."""

    def __init__(self, odometry: LegOdometry, perception: PerceptionService | None) -> None:
        self._odometry = odometry
        self._perception = perception

    def estimated_trunk(self) -> tuple[np.ndarray, np.ndarray]:
        """The trunk's pose by leg odometry and the IMU (the frame perception is given)."""
        return self._odometry.position.copy(), self._odometry.rotation.copy()

    def map_trunk(self) -> tuple[np.ndarray, np.ndarray]:
        """The trunk's pose in the map (odometry corrected by scan matching): the frame of detected objects."""
        position, rotation = self.estimated_trunk()
        if self._perception is None:
            return position, rotation
        x, y, yaw = self._perception.localise(float(position[0]), float(position[1]), yaw_of(rotation))
        turn = yaw - yaw_of(rotation)
        c, s = math.cos(turn), math.sin(turn)
        about_z = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return np.array([x, y, position[2]]), about_z @ rotation
