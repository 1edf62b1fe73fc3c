"""Where a sensor was at a given time, from the poses it was seen at: a real lidar's scan is taken over its sweep
and reaches perception later (the driver's thread, the perception's period, a busy machine), so it is mapped where
the sensor was when the scan was taken, not where it is when the scan is processed."""

from __future__ import annotations

import math
from collections import deque

Pose = tuple[float, float, float, float]  # x, y, yaw, height


class PoseHistory:
    """The last poses of a sensor by time (the body's clock); `keep_s`: how far back it answers."""

    def __init__(self, keep_s: float = 1.0) -> None:
        self.keep_s = keep_s
        self._poses: deque[tuple[float, Pose]] = deque()

    def add(self, t: float, pose: Pose) -> None:
        """A pose at time `t` (times must not go back: an older one clears the history, as after a restart)."""
        if self._poses and t < self._poses[-1][0]:
            self._poses.clear()
        self._poses.append((t, pose))
        while self._poses and self._poses[0][0] < t - self.keep_s:
            self._poses.popleft()

    def at(self, t: float) -> Pose | None:
        """The pose at `t`, between the two poses around it (the newest after them); None before the oldest (a
        time from another clock, or older than `keep_s`: the caller knows better) or when empty."""
        poses = self._poses
        if not poses or t < poses[0][0]:
            return None
        for (t0, p0), (t1, p1) in zip(poses, list(poses)[1:], strict=False):
            if t <= t1:
                f = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
                yaw = p0[2] + f * math.remainder(p1[2] - p0[2], math.tau)
                return (p0[0] + f * (p1[0] - p0[0]), p0[1] + f * (p1[1] - p0[1]), yaw, p0[3] + f * (p1[3] - p0[3]))
        return poses[-1][1]
