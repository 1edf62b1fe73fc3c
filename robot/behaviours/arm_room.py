"""Room for an arm gesture: the floor under what the right arm sweeps, checked on the lidar's map before it moves.

Why: waved beside a plant, the arm came down on it and pushed until the shoulder servo overloaded and the e-stop
latched (demo, world 0). The sweeps are boxes in the trunk's frame (x ahead, y to the left) round every arm part
the gesture moves through, measured by playing the gesture's joint moves through the model's kinematics, from the
arm at rest (held back: its parts' centres up to 0.18 m behind the trunk) and back to it (the wave: the parts'
centres from 0.05 to 0.41 m to the right, 0.18 m behind to 0.01 m ahead; the point: 0.18 m behind to 0.31 m ahead,
0.05-0.21 m to the right), with a map cell and a part's radius added. The lidar (0.15 m up) sees what the arm could
touch: anything lower than its plane is below the arm's lowest reach out to the side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robot.interface import OccupancyMap
from robot.perception.occupancy import OCCUPIED_PERCENT


@dataclass(frozen=True)
class Sweep:
    """A box in the trunk's frame (m): x ahead, y to the left."""

    x: tuple[float, float]
    y: tuple[float, float]


# Wider than the parts' centres by 0.1-0.2 m: the lidar maps only the faces it sees (a box's corner turned toward the
# arm is not on the map), and a turn in place ends a few degrees off. With 0.1 m ahead and behind, a turn chosen on
# the map left a plant's corner 3 cm in the way of the arm coming down. Behind: with the arm at rest held back, the
# sweep reaching only 0.2 m behind let the wave, rising from behind the trunk, hit a chair there (demo, world 4).
REST_BEHIND_M = 0.18  # the arm's parts' centres behind the trunk with the arm at rest
WAVE_SWEEP = Sweep(x=(-REST_BEHIND_M - 0.15, 0.20), y=(-0.55, -0.05))
POINT_REACH_M = 0.31  # the parts' centres ahead of the trunk with the arm level; times cos(the angle below level)
MARGIN_M = 0.09  # a map cell (0.05) and a part's radius


def point_sweep(pitch_down_rad: float) -> Sweep:
    """What the arm sweeps pointing `pitch_down_rad` below the horizontal (less far ahead the lower it points),
    from its rest behind the trunk."""
    reach = POINT_REACH_M * math.cos(max(0.0, min(1.0, pitch_down_rad)))
    return Sweep(x=(-REST_BEHIND_M - MARGIN_M, reach + MARGIN_M), y=(-0.21 - MARGIN_M, -0.05 + MARGIN_M))


TURN_STEP_RAD = math.radians(15.0)


def occupied_cells(grid: OccupancyMap, pose: tuple[float, float, float], sweep: Sweep) -> int:
    """How many occupied map cells lie in the sweep with the trunk at `pose` (x, y, heading on the map)."""
    data = np.frombuffer(grid.data, dtype=np.int8).reshape(grid.height, grid.width)
    rows, cols = np.nonzero(data >= OCCUPIED_PERCENT)
    if len(rows) == 0:
        return 0
    x = grid.origin[0] + (cols + 0.5) * grid.resolution - pose[0]
    y = grid.origin[1] + (rows + 0.5) * grid.resolution - pose[1]
    cos, sin = math.cos(pose[2]), math.sin(pose[2])
    ahead, left = cos * x + sin * y, -sin * x + cos * y
    inside = (ahead >= sweep.x[0]) & (ahead <= sweep.x[1]) & (left >= sweep.y[0]) & (left <= sweep.y[1])
    return int(np.count_nonzero(inside))


def turn_for_room(grid: OccupancyMap, pose: tuple[float, float, float], sweep: Sweep) -> float | None:
    """The smallest turn in place (rad, left positive) after which the sweep is clear on the map: 0.0 when it is
    clear already, None when no heading is (the robot is boxed in)."""
    steps = round(math.pi / TURN_STEP_RAD)
    for k in range(steps + 1):
        for turn in dict.fromkeys((k * TURN_STEP_RAD, -k * TURN_STEP_RAD)):
            if occupied_cells(grid, (pose[0], pose[1], pose[2] + turn), sweep) == 0:
                return turn
    return None
