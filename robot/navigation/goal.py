"""Navigation goals given as a pose instead of a place name: "1.2, 0.5" (metres, map frame) or "1.2, 0.5, 90"
(facing 90 degrees), as typed in a command or sent by a click in the 3D view.

A pose goal travels through plans as text (a plan step's arguments are strings), in one canonical form.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

_NUMBER = r"(-?\d+(?:\.\d+)?)"
_POSE = re.compile(
    rf"^\(?\s*(?:x\s*=?\s*)?{_NUMBER}\s*m?\s*[, ]\s*(?:y\s*=?\s*)?{_NUMBER}\s*m?"
    rf"(?:\s*[, ]\s*(?:facing\s+|yaw\s*=?\s*|heading\s+)?{_NUMBER}\s*(?:deg|degrees|°)?)?\s*\)?$",
    re.IGNORECASE,
)
# Goals further out than this are typing errors, not places in an apartment.
MAX_COORDINATE_M = 50.0


@dataclass(frozen=True)
class PoseGoal:
    x: float
    y: float
    yaw_deg: float | None = None  # None: arrive facing whichever way the walk ends

    def text(self) -> str:
        """The canonical form a plan step carries."""
        position = f"{self.x:.2f}, {self.y:.2f}"
        return position if self.yaw_deg is None else f"{position}, {self.yaw_deg:.0f} deg"

    @property
    def yaw(self) -> float | None:
        return None if self.yaw_deg is None else math.radians(self.yaw_deg)


def parse_pose_goal(text: str) -> PoseGoal | None:
    """The pose in `text` ("1.2, 0.5", "(1.2, 0.5, 90)", "x=1.2 y=0.5 yaw=90 deg"), or None if it is not one."""
    m = _POSE.match(text.strip())
    if m is None:
        return None
    x, y = float(m.group(1)), float(m.group(2))
    if abs(x) > MAX_COORDINATE_M or abs(y) > MAX_COORDINATE_M:
        return None
    yaw = None if m.group(3) is None else math.degrees(math.remainder(math.radians(float(m.group(3))), math.tau))
    return PoseGoal(x, y, yaw)
