"""Who owns the joints this tick: the arm (reaching, grasping, standing up from a reach), the posture controller
(crouching, moving between postures, after a fall, during a controlled stop) or locomotion (standing balanced in
the walk-ready stance, or walking); the head (the camera's gimbal) goes on top of whichever it is.

A body without legs that balance (no IMU) has no locomotion: its posture controller always owns the joints.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from robot.control.head import HeadController
from robot.control.locomotion import LocomotionController, Velocity
from robot.control.posture import PostureController
from robot.control.stack import sensors
from robot.control.whole_body import UPPER_BODY_JOINTS
from robot.core.inbox import TELEOP_TIMEOUT_S, MotionInbox
from robot.core.measurements import Measurements
from robot.core.safety import SafetyLatch
from robot.interface import Level, Posture
from robot.manipulation.arm_motion import ArmMotion, Move
from robot.manipulation.grasp_plan import HANDS, Hand, carry_moves, grasping
from robot.manipulation.stand_up import arm_back_moves, letting_go_out_in_front, standing_up_with

# How fast the legs go from the walk's last posture to the standing one (rad/s): 0.34 rad in ~0.85 s when carrying.
WALK_TO_STAND_SPEED_RAD_S = 0.4
# How fast the joints go between the standing and crouching postures (rad/s, the fastest joint: the knees, 0.8 rad).
# At the posture controller's 1.5 rad/s the robot rising from the crouch pitched 15 degrees and fell a second after
# standing (the knees straightening in 0.5 s); at 0.8 it pitched 15 and stood; at 0.5, 12, and stood in 1.6 s.
POSTURE_CHANGE_SPEED_RAD_S = 0.5


class JointArbiter:
    """Joint targets each tick (`targets`), and the hand-overs between their owners.

    `stand`: the standing posture (the walk-ready stance when there are legs); `stop_posture`: where a
    controlled stop goes, and how fast (None: every joint holds its current reference); `arm`: builds the arm's
    motion on first use (placo loads a model); `plan_running`: whether a plan step, not the operator, drives."""

    def __init__(
        self,
        lock: threading.RLock,
        dt: float,
        joint_names: Sequence[str],
        stand: np.ndarray,
        latch: SafetyLatch,
        publish: Callable[..., Any],
        *,
        locomotion: LocomotionController | None = None,
        inbox: MotionInbox | None = None,
        plan_running: Callable[[], bool] = lambda: False,
        head: HeadController | None = None,
        arm: Callable[[], ArmMotion] | None = None,
        stop_posture: tuple[np.ndarray, float] | None = None,
    ) -> None:
        self._lock = lock
        self.dt = dt
        self.joint_names = tuple(joint_names)
        self._latch = latch
        self._publish = publish
        self._loco = locomotion
        self._inbox = inbox
        self._plan_running = plan_running
        self.head = head
        self._head_joints = (self.joint_names.index("head_pan"), self.joint_names.index("head_tilt"))
        self._make_arm = arm
        self._stop_posture = stop_posture
        self._default_stand = stand.copy()
        self._stand = stand.copy()
        self._posture = PostureController(self._stand)
        # None: holding a pose that is none of the postures (where an e-stop found the arm and the body bent for
        # it, or the body's stop posture): no standing balance until a posture, a plan or a reset moves it
        self._posture_name: Posture | None = Posture.STAND
        self._held_reach = False  # that pose is where a reach was stopped: standing up is the arm's to do
        self._targets = self._stand.copy()  # what was commanded last
        self._arm: ArmMotion | None = None
        self._arm_active = False  # the arm motion owns the joints (reaching, grasping, standing up)
        # The arm finishes its queued moves on its own (stowing after a place), then the control thread hands the
        # joints back: the robot's next body step waits for that.
        self._arm_finishing = False
        self._finish_keeps_upper_body = False  # the arm finishes carrying: walk with the upper body as it ends
        self._grips = {h: self.joint_names.index(f"{h[0]}_grip") for h in HANDS if f"{h[0]}_grip" in self.joint_names}
        self._measured: np.ndarray | None = None  # the joints as last measured

    # ---------------------------------------------------------------------------------------------------------
    # the control thread

    def targets(self, measured: Measurements) -> np.ndarray:
        """This tick's joint targets (the head's included)."""
        fallen = self._latch.fallen
        self._measured = measured.joint_positions
        targets = self._owner_targets(measured, fallen)
        if not fallen and self.head is not None:  # the head is the camera's gimbal, whoever drives the other joints
            pan, tilt = self.head.update(self.dt)
            targets[self._head_joints[0]] = pan
            targets[self._head_joints[1]] = tilt
        self._targets = targets
        return targets

    def _owner_targets(self, measured: Measurements, fallen: bool) -> np.ndarray:
        loco = self._loco
        if self._inbox is not None:
            velocity, promptly, deadman = self._inbox.take(self._plan_running(), self._latch.latched)
            if deadman:
                quiet_ms = TELEOP_TIMEOUT_S * 1e3
                self._publish("teleop/deadman", f"no teleop input for {quiet_ms:.0f} ms: stopping", Level.WARN)
        else:
            velocity, promptly = Velocity(), False
        with self._lock:
            in_stance = self._posture_name == Posture.STAND and self._posture.settled
            arm = self._arm if self._arm_active else None
        if arm is not None and not fallen:  # reaching: feet planted, the estimate follows
            self._follow_feet(measured)
            targets = arm.update(measured.joint_positions)
            with self._lock:
                finished = self._arm_finishing and arm.done.is_set() and self._arm_active
            if finished:
                self.release_arm(arm.targets if self._finish_keeps_upper_body else None)
                with self._lock:
                    self._arm_finishing = False
            return targets
        if fallen or not in_stance or loco is None:
            if not fallen:  # crouching or moving between postures: the feet stay put, the estimate follows
                self._follow_feet(measured)
            return self._posture.update(self.dt)
        loco.set_velocity(velocity)
        if promptly:
            loco.stop(promptly=True)
        was_walking = loco.moving
        targets = loco.update(sensors(measured), self._posture.goal)
        if not loco.moving:
            with self._lock:  # a posture command may have just arrived: holding the stance must not undo it
                if self._posture_name == Posture.STAND and was_walking:
                    # The walk ends in its own posture, which is not the standing one when the arms carry something
                    # (knees 0.34 rad deeper): moving there in one tick made the robot hop and pitch 8-10 deg just
                    # as placing began (a fall on world seed 13), and at posture speed (0.2 s) it still pitched 9.
                    self._posture.hold(targets)
                    self._posture.move_to(self._stand, WALK_TO_STAND_SPEED_RAD_S)
                elif self._posture_name == Posture.STAND:
                    self._posture.hold(self._stand)
            if self._inbox is not None and self._inbox.teleop_ended():
                self._publish("teleop/ended", "teleop ended: standing")
        return targets

    def _follow_feet(self, measured: Measurements) -> None:
        if self._loco is not None:
            s = sensors(measured)
            self._loco.odometry.update(s.joint_positions, s.imu_quat, s.foot_forces)

    def controlled_stop(self) -> tuple[bool, np.ndarray | None]:
        """Control thread, on an e-stop: whether the legs were walking (a biped mid-stride cannot freeze its
        joints: it finishes the step and puts its feet together), and the targets to hold at once, if any (none
        while walking: the step's next targets are the stop)."""
        if self.head is not None:
            self.head.freeze()
        with self._lock:
            if self._arm_active and self._arm is not None:  # the arm stops where it is commanded now
                self._arm.stop()
                self._posture.hold(self._arm.targets)
                # not the stance: balancing it as one snapped a body bent over a counter upright, and it fell
                self._posture_name = None
                self._held_reach = True
                self._arm_active = False
                self._arm_finishing = False
        if self._loco is not None and self._loco.moving:
            self._loco.stop(promptly=True)
            return True, None
        if self._stop_posture is not None:
            goal, speed = self._stop_posture
            self._posture_name = None  # (the body's stop posture is not the stance to balance)
            self._posture.hold(self._targets)
            self._posture.move_to(goal, speed)
            return False, self._targets.copy()  # held at once; the move to the stop posture starts next tick
        return False, self._posture.freeze()

    def fell(self) -> None:
        """Control thread, on a fall: nothing drives the joints any more; hold the last references (no sudden move
        on the ground)."""
        if self._loco is not None:
            self._loco.halt()
        with self._lock:
            if self._arm_active and self._arm is not None:
                self._arm.stop()
                self._arm_active = False
                self._arm_finishing = False
        self._posture.hold(self._targets)

    def reset(self) -> np.ndarray:
        """Control thread, on a reset: standing in the default posture; returns it."""
        with self._lock:
            self._posture_name = Posture.STAND
            self._held_reach = False
            self._arm_active = False
            self._arm_finishing = False
            self._stand = self._default_stand.copy()
        if self._loco is not None:
            self._loco.walking.ik.set_upper_body(dict(zip(self.joint_names, self._default_stand, strict=True)))
            self._loco.halt()
        if self.head is not None:
            self.head.reset(start=(float(self._stand[self._head_joints[0]]), float(self._stand[self._head_joints[1]])))
        self._posture.hold(self._stand)
        return self._stand

    def hold(self, targets: np.ndarray) -> None:
        """The posture controller holds these targets, commanded from now on (torque just came on, or the robot
        was found holding itself up: hold where it stands)."""
        self._posture.hold(targets)
        self._targets = np.array(targets, dtype=float)

    # ---------------------------------------------------------------------------------------------------------
    # postures

    @property
    def stand(self) -> np.ndarray:
        return self._stand

    @property
    def default_stand(self) -> np.ndarray:
        return self._default_stand

    @property
    def commanded(self) -> np.ndarray:
        """The joint targets of the last tick."""
        return self._targets

    @property
    def posture_settled(self) -> bool:
        return self._posture.settled

    def posture_label(self) -> str:
        """The posture for the state: its name once there, "moving" on the way, "held" where a stop left it."""
        if not self._posture.settled:
            return "moving"
        return self._posture_name.value if self._posture_name is not None else "held"

    def set_posture(
        self, posture: Posture, goal: np.ndarray, speed_rad_s: float | None = POSTURE_CHANGE_SPEED_RAD_S
    ) -> None:
        with self._lock:
            if posture == Posture.STAND and self._stand_up_from_reach():
                return
            self._held_reach = False
            self._posture_name = posture
            self._posture.move_to(goal, speed_rad_s)

    def to_standing(self) -> None:
        """Back to the standing posture unless it is there or on the way (the operator starts to drive)."""
        with self._lock:
            if self._posture_name != Posture.STAND and not self._stand_up_from_reach():
                self._posture_name = Posture.STAND
                self._posture.move_to(self._stand, POSTURE_CHANGE_SPEED_RAD_S)

    def begin_plan(self) -> None:
        """A new plan starts from the standing posture (a move, so only after an explicit command)."""
        with self._lock:
            if self._stand_up_from_reach():
                return  # (the plan's first body step waits for the arm to finish)
            self._posture_name = Posture.STAND
            self._posture.move_to(self._stand, POSTURE_CHANGE_SPEED_RAD_S)

    def _stand_up_from_reach(self) -> bool:
        """From a reach that was stopped (an e-stop, or a pick or place cancelled midway: its arm holds where it
        was), stand up as a pick does, the arm swinging back as the legs straighten. Straight to the standing
        posture, joint by joint, the robot fell forward with its arm still out; left to the arm, the next walk got
        no legs ("stuck: no progress"). With something in the hand it stands up carrying it, as after a pick (swung
        back, a mug went flying). False when there is no such reach."""
        left_reaching = self._arm_active and not self._arm_finishing
        if not (self._held_reach or left_reaching) or self._latch.fallen:
            return False
        self._held_reach = False
        holding = self.grasping()
        side = self.hand
        if holding:
            moves = standing_up_with(carry_moves(side), self._default_stand)
        else:
            hand = self.arm_motion().placed_hand()
            let_go = letting_go_out_in_front(hand) if hand is not None else []
            moves = [*let_go, *standing_up_with(arm_back_moves(side), self._default_stand)]
        self.finish_arm_in_background(moves, keep_upper_body=holding)
        return True

    @property
    def hand(self) -> Hand:
        """The hand the arm motion last reached with (the right one before any reach): the one that may hold
        something."""
        return "left" if self._arm is not None and self._arm.side == "left" else "right"

    def grasping(self) -> bool:
        """Whether the reaching hand holds something, by its fingers (held apart while commanded tighter)."""
        measured = self._measured
        grip = self._grips.get(self.hand)
        if measured is None or grip is None:
            return False
        return grasping(float(self._targets[grip]), float(measured[grip]))

    def stand_with_upper_body(self, stand: np.ndarray) -> None:
        """Stand (and walk) with the upper body as in `stand` (carrying): the walk keeps the arms there."""
        if self._loco is not None:
            self._loco.walking.ik.set_upper_body(dict(zip(self.joint_names, stand, strict=True)))
        with self._lock:
            self._stand = stand
            self._posture_name = Posture.STAND
            self._posture.move_to(stand)

    # ---------------------------------------------------------------------------------------------------------
    # the arm

    @property
    def arm_active(self) -> bool:
        return self._arm_active

    @property
    def arm_finishing(self) -> bool:
        return self._arm_finishing

    def arm_motion(self) -> ArmMotion:
        if self._arm is None:
            if self._make_arm is None:
                raise RuntimeError("this body has no arm motion")
            self._arm = self._make_arm()
        return self._arm

    def take_arm(self, hand: Hand | None = None) -> ArmMotion:
        """Give the joints to the arm motion, starting from what is commanded now (the robot standing still),
        reaching with `hand` (None: the hand it last reached with, which may hold something)."""
        arm = self.arm_motion()
        with self._lock:
            if not self._arm_active:
                arm.start(self._targets.copy(), hand or self.hand)
                self._arm_active = True
        return arm

    def finish_arm_in_background(self, moves: list[Move], keep_upper_body: bool = False) -> None:
        """Play `moves` on the arm without waiting, then stand with the arms in the default posture, or with the
        upper body as the moves end (`keep_upper_body`: carrying)."""
        arm = self.take_arm()
        with self._lock:
            arm.queue(*moves)
            self._arm_finishing = True
            self._finish_keeps_upper_body = keep_upper_body

    def release_arm(self, upper_body: np.ndarray | None) -> None:
        """Hand the joints back to the posture controller and walking: with the upper body held as in
        `upper_body` (carrying), or in the default standing posture."""
        arm = self.arm_motion()
        stand = self._default_stand.copy()
        upper = [self.joint_names.index(n) for n in UPPER_BODY_JOINTS]
        if upper_body is not None:
            stand[upper] = upper_body[upper]
        if self._loco is not None:
            self._loco.walking.ik.set_upper_body(dict(zip(self.joint_names, stand, strict=True)))
        with self._lock:
            self._stand = stand
            self._posture_name = Posture.STAND
            self._posture.hold(arm.targets)
            self._posture.move_to(stand)
            self._arm_active = False

    def wait_arm_finished(self, wait: Callable[[float], None]) -> None:
        """Block (`wait`: simulated seconds) until an arm left finishing in the background has handed the joints
        back and the robot stands."""
        waited = False
        while True:
            with self._lock:
                if self._latch.fallen or not (self._arm_finishing or waited):
                    return  # a step sees a fall itself
                if not self._arm_finishing and self._posture.settled:
                    return
            waited = True
            wait(0.02)
