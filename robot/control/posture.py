"""Posture control: hold a joint-space posture, moving to a new one with a capped joint speed.

The controlled stop of the e-stop is `freeze()`: the joint references stop where they are, so the biped holds
itself in place instead of going limp (falling) or finishing its motion. Holding the references, not the measured
positions, keeps the servos' holding torque: a position servo told to stay where gravity has pushed it gives way.
"""

from __future__ import annotations

import numpy as np

# Joint speed cap when moving between postures (rad/s); well under the XM430's ~4.8 rad/s no-load speed.
MAX_POSTURE_SPEED_RAD_S = 1.5


class PostureController:
    def __init__(self, initial_targets: np.ndarray, max_speed_rad_s: float = MAX_POSTURE_SPEED_RAD_S) -> None:
        self._targets = np.array(initial_targets, dtype=float)
        self._goal = self._targets.copy()
        self._max_speed = max_speed_rad_s
        self._speed = max_speed_rad_s
        self._settled: bool | None = True  # None: not known since the targets or the goal last changed

    def move_to(self, goal: np.ndarray, max_speed_rad_s: float | None = None) -> None:
        """Start a capped-speed move from the current targets to `goal` (at `max_speed_rad_s` if given, for this
        move only)."""
        self._goal = np.array(goal, dtype=float)
        self._speed = self._max_speed if max_speed_rad_s is None else max_speed_rad_s
        self._settled = None

    def freeze(self) -> np.ndarray:
        """Controlled stop: no further motion from now on; returns the targets to hold."""
        self._goal = self._targets.copy()
        self._speed = self._max_speed
        self._settled = True
        return self._targets.copy()

    def hold(self, targets: np.ndarray) -> None:
        """Take over from another controller: hold `targets` (what it last commanded) from now on."""
        self._targets = np.array(targets, dtype=float)
        self._goal = self._targets.copy()
        self._speed = self._max_speed
        self._settled = True

    @property
    def goal(self) -> np.ndarray:
        return self._goal.copy()

    def update(self, dt: float) -> np.ndarray:
        """Targets for this tick."""
        step = np.clip(self._goal - self._targets, -self._speed * dt, self._speed * dt)
        self._targets = self._targets + step
        if not self._settled:  # once there, a step is the last rounding error: it stays there
            self._settled = None
        return self._targets.copy()

    @property
    def settled(self) -> bool:
        """At the goal (to 1e-6 rad). Known once per change: the control tick asks several times and
        `np.allclose` cost ~4% of a walking tick."""
        if self._settled is None:
            self._settled = bool(np.all(np.abs(self._targets - self._goal) <= 1e-6 + 1e-5 * np.abs(self._goal)))
        return self._settled
