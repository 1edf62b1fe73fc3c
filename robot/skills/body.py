"""The robot's parts as the skills use them: small protocols, so a skill knows nothing of the core or the body
behind them (the simulation or the real robot), and a test can stand any of them in."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from robot.control.locomotion import Velocity, VelocityLimits
from robot.interface import DetectedObject, KnownObject, SensorFeed
from robot.manipulation.arm_motion import ArmMotion, Move
from robot.manipulation.grasp_plan import Hand


class Clock(Protocol):
    def now(self) -> float:
        """Simulated time (s): what steps wait in."""


class Legs(Protocol):
    @property
    def limits(self) -> VelocityLimits: ...

    @property
    def moving(self) -> bool:
        """Walking, or asked to walk."""

    def drive(self, velocity: Velocity) -> None:
        """Velocity for the legs, in the robot's frame (a deadman: repeat it while motion is wanted)."""

    def halt_here(self) -> None:
        """Stop where the robot is, without first walking off the lag of the pose loop."""

    def fallen(self) -> bool: ...


class Head(Protocol):
    @property
    def target(self) -> tuple[float, float]: ...

    @property
    def at_target(self) -> bool: ...

    def point(self, pan: float, tilt: float) -> tuple[float, float]: ...

    def angles_to_look_at(
        self, trunk_position: np.ndarray, trunk_rotation: np.ndarray, target: np.ndarray
    ) -> tuple[float, float, bool]: ...


class Localiser(Protocol):
    def map_trunk(self) -> tuple[np.ndarray, np.ndarray]:
        """The trunk's position and rotation in the map frame (odometry corrected by scan matching)."""


class ObjectMemory(Protocol):
    def get(self, name: str) -> KnownObject | None: ...

    def snapshot(self) -> tuple[KnownObject, ...]: ...

    def place_of(self, position: tuple[float, float, float]) -> str | None: ...


class PerceptionView(Protocol):
    @property
    def memory(self) -> ObjectMemory: ...

    def feed(self) -> SensorFeed: ...

    def detections_after(self, sim_time_s: float) -> tuple[DetectedObject, ...]:
        """The detections of the first camera frame taken at or after this time (blocks)."""


class Arm(Protocol):
    @property
    def active(self) -> bool:
        """The arm owns the joints."""

    @property
    def standing(self) -> bool:
        """The posture controller has the robot where it should stand."""

    @property
    def default_stand(self) -> np.ndarray: ...

    @property
    def held(self) -> str | None:
        """The object in the hand."""

    def hold_object(self, name: str | None) -> None: ...

    def grasping(self) -> bool:
        """The fingers hold something (whatever the bookkeeping says): a stopped pick or place asks."""

    def motion(self) -> ArmMotion: ...

    @property
    def hand(self) -> Hand:
        """The hand that last reached (the one that may hold something)."""

    def take(self, hand: Hand | None = None) -> ArmMotion:
        """Give the arm the joints (from what is commanded now), reaching with `hand` (None: the last one), and
        return its motion."""

    def release(self, upper_body: np.ndarray | None) -> None:
        """Hand the joints back to standing and walking, the upper body as in `upper_body` (None: default)."""

    def finish_in_background(self, moves: list[Move]) -> None: ...

    def joint_positions(self) -> np.ndarray:
        """The measured joint positions."""


class ServoHeat(Protocol):
    """The servos' temperatures as their diagnostics read them."""

    @property
    def hot_c(self) -> float:
        """At or above this a servo is hot (the diagnostics warn; some degrees more and they stop the robot)."""

    def hottest(self) -> tuple[str, float]:
        """The joint of the hottest servo, and its temperature (C)."""


@dataclass(frozen=True)
class BodyParts:
    """Everything a skill may use of the robot (`perception` None: the robot has no camera or map;
    `servo_heat` None: no servo reports its temperature)."""

    head: Head
    legs: Legs
    arm: Arm
    localiser: Localiser
    perception: PerceptionView | None
    clock: Clock
    servo_heat: ServoHeat | None = None
