"""What the core asks of a body (the MuJoCo simulation, or the real robot on its servo bus): sense, actuate, say
what it is and what it lacks. The core never imports a body; `robot.robot` wires one in.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol

import numpy as np

from robot.control.stats import LoopStats
from robot.core.measurements import Measurements
from robot.core.safety import LatchWords, SafetyLatch
from robot.diagnostics.robot_sources import RobotReadings
from robot.interface import (
    CommandReply,
    ObjectPose,
    PerceptionState,
    PowerState,
    Proprioception,
    RobotState,
    SensorFeed,
)
from robot.perception.service import PerceptionService
from robot.telemetry import TelemetrySampler


class Diverged(RuntimeError):
    """The body's state is lost (the physics blew up) and it must be put back on its feet (`Body.reset`)."""


@dataclass(frozen=True)
class Senses:
    """What a body can sense: legs balance and walk only with an IMU and foot sensors."""

    imu: bool
    foot_sensors: bool

    @property
    def can_walk(self) -> bool:
        return self.imu and self.foot_sensors


class BodySnapshot(NamedTuple):
    """The body's part of a published `RobotState`."""

    base_position: tuple[float, float, float]
    base_yaw_rad: float
    tilt_deg: float
    fallen: bool
    qpos: tuple[float, ...]
    mocap_positions: tuple[float, ...] = ()
    objects: tuple[ObjectPose, ...] = ()
    proprioception: Proprioception | None = None
    power: PowerState | None = None
    torque_enabled: bool | None = None


@dataclass(frozen=True)
class BodyLinks:
    """What a body may use of the core, given once it is wired in."""

    publish: Callable[..., Any]
    latch: SafetyLatch
    hold: Callable[[np.ndarray], None]  # the posture controller holds these joint targets
    latest_state: Callable[[], RobotState]
    wait_for: Callable[[Callable[[RobotState], bool], float], bool]
    loop_alive: Callable[[], bool]
    tick_age_s: Callable[[], float]


CommandHandler = Callable[[Any], CommandReply]


class Body(Protocol):
    """A robot's body as the core drives it. Only the control thread calls `before_tick` to `after_tick`."""

    kind: str  # "simulation", "hardware": said where the body is the reason
    resettable: bool  # can be put back on its feet at its start pose (`reset`)
    joint_names: tuple[str, ...]
    senses: Senses
    lacks: str  # why what the body cannot do is refused ("" when it can do everything)
    latch_words: LatchWords
    physics_hz: float
    # its controlled stop reaches the actuators only with a tick (the real robot's goals go out on the bus in the
    # tick): on an e-stop the loop ticks at once instead of at its next deadline
    stop_by_tick: bool
    perception: PerceptionService | None
    telemetry: TelemetrySampler | None

    def bind(self, links: BodyLinks) -> None:
        """Wire the body to the core (before `start`)."""

    def now(self) -> float:
        """The body's time: simulated time, or the real robot's clock since it was made."""

    @property
    def tick_guard(self) -> AbstractContextManager | None:
        """Held around each tick (the real robot's bus lock: a stop from outside the loop takes it)."""

    @property
    def connected(self) -> bool:
        """Whether it can be sensed now (a real robot only once started)."""

    def stand_posture(self) -> np.ndarray: ...

    def crouch_posture(self) -> np.ndarray: ...

    def stop_posture(self) -> tuple[np.ndarray, float] | None:
        """Where a controlled stop goes, and how fast (None: every joint holds where it is)."""

    def stop_action(self, walking: bool) -> str:
        """What the controlled stop does, for the operator."""

    def motion_refusal(self) -> CommandReply | None:
        """Why the body cannot move now, whatever the core allows (torque off)."""

    def commands(self) -> dict[type, CommandHandler]:
        """The commands only this body serves (torque, faults, obstacles, the operator's heartbeat)."""

    def start(self) -> None: ...

    def before_shutdown(self) -> None:
        """Bring the robot down safely before the loop stops (a real robot does not drop where it stands)."""

    def close(self) -> None: ...

    def before_tick(self) -> None:
        """Control thread, first in each tick (injected faults, the servos' watchdog, the deadman)."""

    def apply_requests(self) -> None:
        """Control thread, after a pending stop or reset: what was asked of the body between ticks."""

    def sense(self) -> Measurements:
        """Control thread: this tick's measurements."""

    def latest(self) -> Measurements:
        """The last measurements taken (no I/O)."""

    def actuate(self, targets: np.ndarray) -> Measurements:
        """Control thread: send the joint targets (and step the physics); returns what to publish. Raises
        `Diverged` when the body must be reset."""

    def hold_now(self, targets: np.ndarray) -> None:
        """Control thread, on a stop: send these targets at once, before the next tick."""

    def stop_applied(self) -> None:
        """Control thread: the controlled stop has begun."""

    def after_tick(self, targets: np.ndarray, tick_s: float) -> None:
        """Control thread, after each tick: book-keeping that must not count in the tick."""

    def snapshot(self, measured: Measurements) -> BodySnapshot: ...

    def tick_error(self, exc: Exception) -> bool:
        """Whether the body has dealt with a failing tick itself (said what it was); else the e-stop latches."""

    def after_safe_stop(self) -> None:
        """Diagnostics latched the e-stop: a body whose loop no longer runs must stop by other means."""

    def readings(
        self,
        stats: LoopStats,
        perception: Callable[[], PerceptionState | None],
        sensor_feed: Callable[[], SensorFeed],
        voice: Callable[[], Any],
    ) -> RobotReadings:
        """Where diagnostics read this body's health, beside the loop's statistics and what the core knows."""

    def place(self, stand: np.ndarray) -> Measurements:
        """Put the robot at its start pose in `stand`, before the loop starts (the simulation only)."""

    def reset(self, stand: np.ndarray) -> Measurements:
        """Control thread: back on its feet at its start pose, in `stand`, as after start-up (the simulation
        only)."""
