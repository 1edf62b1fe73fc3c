"""The state publisher: one immutable `RobotState` per tick, from the body's snapshot and what the core knows (the
latch, the plan, teleop, the posture, the legs, perception), on a board any thread reads without locks."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from robot.control.locomotion import LocomotionController
from robot.core.body import BodySnapshot
from robot.core.measurements import Measurements
from robot.core.safety import SafetyLatch
from robot.interface import (
    BehaviourStatus,
    ControlStats,
    Footprint,
    LocomotionState,
    Mode,
    NavigationState,
    PerceptionState,
    PlanStatus,
    RobotState,
)
from robot.perception.geometry import matrix_to_quat_wxyz
from robot.state_board import StateBoard


class PlanView(Protocol):
    @property
    def running(self) -> bool: ...

    @property
    def approval_required(self) -> bool: ...

    def shown(self) -> PlanStatus | None:
        """The plan to show: the running one, else one held (awaiting approval, paused), else the last one."""


class TeleopView(Protocol):
    @property
    def teleop_active(self) -> bool: ...


class NavigationView(Protocol):
    @property
    def navigation(self) -> NavigationState | None:
        """The walk under way, if any."""


class HandView(Protocol):
    @property
    def held(self) -> str | None: ...


@dataclass(frozen=True)
class MissionParts:
    """The parts of the state a robot with legs, plans and perception adds (read every tick: objects and bound
    methods, no lambdas in between)."""

    plans: PlanView
    teleop: TeleopView
    navigation: NavigationView
    hand: HandView
    locomotion: LocomotionController
    trunk: Callable[[], tuple[np.ndarray, np.ndarray]]  # the trunk's estimated position and rotation
    perception: Callable[[], PerceptionState | None]
    behaviour: Callable[[], BehaviourStatus | None] | None = None  # the behaviour running, paused or last run


class StatePublisher:
    """`lock`: the robot's state lock (the mode is read in one piece); `snapshot`: the body's part."""

    def __init__(
        self,
        lock: threading.RLock,
        latch: SafetyLatch,
        snapshot: Callable[[Measurements], BodySnapshot],
        control: Callable[[], ControlStats],
        posture_label: Callable[[], str],
        mission: MissionParts | None = None,
    ) -> None:
        self.board = StateBoard()
        self._lock = lock
        self._latch = latch
        self._snapshot = snapshot
        self._control = control
        self._posture_label = posture_label
        self._mission = mission

    def latest(self) -> RobotState:
        return self.board.latest()

    def wait_for(self, predicate: Callable[[RobotState], bool], timeout_s: float) -> bool:
        """Block until `predicate(state)` holds or the wall-clock timeout passes."""
        return self.board.wait_for(predicate, timeout_s)

    def publish(self, measured: Measurements, body: BodySnapshot | None = None) -> None:
        body = body if body is not None else self._snapshot(measured)
        mission = self._mission
        with self._lock:
            latched = self._latch.latched
            running = mission is not None and mission.plans.running
            if self._latch.fallen:
                mode = Mode.FALLEN
            elif latched:
                mode = Mode.ESTOP
            elif running:
                mode = Mode.EXECUTING
            elif mission is not None and mission.teleop.teleop_active:
                mode = Mode.TELEOP
            else:
                mode = Mode.IDLE
            posture = self._posture_label()
            plan = mission.plans.shown() if mission is not None else None
            approval = mission is not None and mission.plans.approval_required
            behaviour = mission.behaviour() if mission is not None and mission.behaviour is not None else None
        self.board.publish(
            RobotState(
                sim_time_s=measured.sim_time_s,
                wall_time_s=time.time(),
                mode=mode,
                estop_latched=latched,
                base_position=body.base_position,
                base_yaw_rad=body.base_yaw_rad,
                tilt_deg=body.tilt_deg,
                fallen=body.fallen,
                qpos=body.qpos,
                mocap_positions=body.mocap_positions,
                navigation=mission.navigation.navigation if mission is not None else None,
                approval_required=approval,
                power=body.power,
                objects=body.objects,
                held_object=mission.hand.held if mission is not None else None,
                plan=plan,
                control=self._control(),
                locomotion=legs_state(mission.locomotion, *mission.trunk(), posture) if mission is not None else None,
                perception=mission.perception() if mission is not None else None,
                proprioception=body.proprioception,
                torque_enabled=body.torque_enabled,
                behaviour=behaviour,
            )
        )


def legs_state(
    locomotion: LocomotionController, trunk_position: np.ndarray, trunk_rotation: np.ndarray, posture: str
) -> LocomotionState:
    """What the legs do, for the state: the walk's phase and velocities, the pose estimate, and while walking the
    planned footsteps, centre of mass and ZMP in the world frame."""
    loco = locomotion
    target, current, pose = loco.velocity.target, loco.velocity.current, loco.odometry.pose
    overlay = loco.overlay()
    state = LocomotionState(
        phase=loco.phase.value,
        posture=posture,
        command=(target.vx, target.vy, target.yaw_rate),
        velocity=(current.vx, current.vy, current.yaw_rate),
        estimated_pose=(pose.x, pose.y, pose.yaw),
        estimated_trunk=(*(float(v) for v in trunk_position), *matrix_to_quat_wxyz(trunk_rotation)),
        late_plans=loco.plan_lateness.late_plans,
        late_plans_s=loco.plan_lateness.late_s_total,
    )
    if overlay is None:
        return state
    return replace(
        state,
        footsteps=tuple(Footprint(side, x, y, yaw) for side, x, y, yaw in overlay.footsteps),
        com=overlay.com,
        zmp=overlay.zmp,
        support=overlay.support,
    )
