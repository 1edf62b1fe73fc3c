"""Arm motions the control thread plays: straight hand moves in the feet frame, solved tick by tick by `ReachIK`.

A task (the pick or the place sequence) queues `HandMove`s and waits for them; the control thread calls
`update()` every tick. The hand's measured position (forward kinematics of the servo encoders) feeds a slow
correction of the commanded height: a position servo holding an arm out sags under gravity and a payload, and the
prototype only held heavy mugs once the hand height was corrected this way (shared FINDINGS.md).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from robot.manipulation.reach_ik import ReachIK
from robot.model import humanoid_v1

# Integral gain of the sag correction (1/s) and its bound (m).
SAG_GAIN_PER_S = 2.0
MAX_SAG_CORRECTION_M = 0.04
# Time for the closing-axis orientation task to ramp in or out (s).
ORIENTATION_RAMP_S = 1.0


@dataclass(frozen=True)
class HandMove:
    """Move the hand in a straight line to `target` (feet frame, m) in `duration_s`, with the gripper going to
    `gripper` (m open per finger) and the trunk to `trunk_height` (m above the feet)."""

    target: tuple[float, float, float]
    duration_s: float
    gripper: float
    trunk_height: float
    orient: bool = True  # keep the closing axis across the body, horizontal (off while the arm swings up)
    correct_sag: bool = True
    label: str = ""


@dataclass(frozen=True)
class JointMove:
    """Move some joints (by name) to `positions` in `duration_s`, straight in joint space, every other joint held:
    for the big swings (arm out of the way, round furniture) where a straight hand path would sweep through things."""

    positions: dict[str, float]
    duration_s: float
    label: str = ""


Move = HandMove | JointMove


class ArmMotion:
    """Plays queued moves; holds the last targets when the queue is empty. Moves are queued from any thread."""

    def __init__(self, ik: ReachIK, dt: float) -> None:
        self._ik = ik
        self._dt = dt
        self._names = list(humanoid_v1.JOINT_NAMES)
        self._lock = threading.Lock()
        self._queue: list[Move] = []
        self._current: Move | None = None
        self._elapsed = 0.0
        self._ik_live = False  # the IK's state matches the commanded targets
        self._hand_placed = False  # the last move was a hand move: the hand is where it sent it
        self._side = "right"
        # hand-space state (feet frame)
        self._from = np.zeros(3)
        self._target = np.zeros(3)
        self._from_gripper = self._gripper = 0.0
        self._from_height = self._height = 0.0
        self._orientation = 0.0
        self._correction = np.zeros(3)
        # joint-space state
        self._joint_from = np.zeros(len(self._names))
        self._targets = np.zeros(len(self._names))
        self._done = threading.Event()
        self._done.set()

    def start(self, joints: np.ndarray, side: str) -> None:
        """Take over the joints from their current targets `joints`, reaching with `side`'s hand."""
        with self._lock:
            self._side = side
            self._queue.clear()
            self._current = None
            self._targets = np.asarray(joints, dtype=float).copy()
            self._ik_live = False
            self._hand_placed = False
        self._done.set()

    def queue(self, *moves: Move) -> None:
        with self._lock:
            self._queue.extend(moves)
            self._done.clear()

    def stop(self) -> None:
        """Drop the queued moves and hold the targets commanded now."""
        with self._lock:
            self._queue.clear()
            self._current = None
            self._from = self._target.copy()
        self._done.set()

    @property
    def done(self) -> threading.Event:
        return self._done

    @property
    def side(self) -> str:
        return self._side

    @property
    def targets(self) -> np.ndarray:
        with self._lock:
            return self._targets.copy()

    def commanded_hand(self) -> np.ndarray:
        with self._lock:
            return self._target.copy()

    def placed_hand(self) -> np.ndarray | None:
        """Where the last hand move sent the hand (feet frame), or None when a joint move came after it (or no hand
        move yet): whether the hand may be out at some object, without asking the solver from another thread."""
        with self._lock:
            return self._target.copy() if self._hand_placed else None

    def measured_hand(self, joints: np.ndarray) -> np.ndarray:
        return self._ik.hand_position(joints, self._side)

    def trunk_in_feet(self, joints: np.ndarray) -> np.ndarray:
        return self._ik.trunk_in_feet(joints)

    def trunk_ahead_of_com(self, joints: np.ndarray) -> np.ndarray:
        return self._ik.trunk_ahead_of_com(joints)

    def update(self, measured_joints: np.ndarray) -> np.ndarray:
        """Joint targets for this tick."""
        with self._lock:
            if self._current is None and self._queue:
                self._begin(self._queue.pop(0))
            move = self._current
            s = 1.0
            if move is not None:
                self._elapsed += self._dt
                s = min(1.0, self._elapsed / max(move.duration_s, self._dt))
                s = s * s * (3.0 - 2.0 * s)  # smoothstep: no jerk at either end
                if self._elapsed >= move.duration_s:
                    self._current = None
                    if not self._queue:
                        self._done.set()
            if isinstance(move, JointMove):
                goal = self._joint_from.copy()
                for name, value in move.positions.items():
                    goal[self._names.index(name)] = value
                self._targets = self._joint_from + s * (goal - self._joint_from)
                return self._targets.copy()
            if not self._ik_live:  # holding after joint moves (or before any move)
                return self._targets.copy()
            if isinstance(move, HandMove):
                self._target = self._from + s * (np.asarray(move.target) - self._from)
                self._gripper = self._from_gripper + s * (move.gripper - self._from_gripper)
                self._height = self._from_height + s * (move.trunk_height - self._from_height)
            target, gripper, height = self._target.copy(), self._gripper, self._height
            correct = move.correct_sag if isinstance(move, HandMove) else True
            orient = move.orient if isinstance(move, HandMove) else self._orientation > 0.5
        if correct:  # height only: the sag is vertical, and the target may be out of reach sideways
            error = target[2] - self._ik.hand_position(measured_joints, self._side)[2]
            self._correction[2] = np.clip(
                self._correction[2] + SAG_GAIN_PER_S * self._dt * error, -MAX_SAG_CORRECTION_M, MAX_SAG_CORRECTION_M
            )
        step = self._dt / ORIENTATION_RAMP_S
        self._orientation = min(1.0, self._orientation + step) if orient else max(0.0, self._orientation - step)
        targets = self._ik.solve(target + self._correction, height, self._orientation, gripper)
        with self._lock:
            self._targets = targets
        return targets.copy()

    def _begin(self, move: Move) -> None:
        """Start `move` from where the last one left the joints (lock held)."""
        self._current = move
        self._elapsed = 0.0
        self._hand_placed = isinstance(move, HandMove)
        if isinstance(move, JointMove):
            self._joint_from = self._targets.copy()
            self._ik_live = False
            return
        if not self._ik_live:  # hand moves start from the joints as they are commanded now
            self._ik.start(self._targets, self._side)
            self._target = self._ik.hand_position(side=self._side)
            self._gripper = float(self._targets[self._names.index(f"{self._side[0]}_grip")])
            self._height = self._ik.trunk_height()
            self._orientation = 0.0
            self._correction = np.zeros(3)
            self._ik_live = True
        self._from, self._from_gripper, self._from_height = self._target.copy(), self._gripper, self._height
