"""`place_object`: stand where the spot is in the holding hand's reach, carry the held object over it, lower it, let go,
and check it stands where it was put.

Failures name their cause: "unreachable", "not found" (the object is not where it was let go), "fell".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from robot.manipulation.arm_motion import Move
from robot.manipulation.grasp_plan import (
    REACH_MARGIN_M,
    REACH_X,
    Hand,
    Stance,
    grasp_offset,
    grasp_stance,
    place_moves,
    reach_problem,
    reach_window_y,
)
from robot.manipulation.pick import STANCE_ATTEMPTS
from robot.model.world import Box

# Where the object must be seen after letting go: near the spot (the robot's pose estimate may have been
# corrected by a few cm between choosing the spot and looking again), and standing on the surface: a mug lying on
# its side shows its base centre 1.75 cm higher; lower than the surface only by the camera's error (seen 1.3 cm
# low once, standing upright on the table), unless it fell off.
PLACED_WITHIN_M = 0.10
PLACED_HEIGHT_TOLERANCE_M = 0.012
PLACED_BELOW_TOLERANCE_M = 0.03


class PlaceFailed(RuntimeError):
    pass


class PlaceBody(Protocol):
    """What placing needs of the robot (the worker implements it; tests may fake it)."""

    def locate(self, name: str, near: np.ndarray | None = None) -> np.ndarray | None:
        """The object's base centre in the map from a fresh sighting (looking at `near` if given), or None."""

    def to_feet(self, point_in_map: np.ndarray) -> np.ndarray: ...

    def go_to(self, stance: Stance, reach: np.ndarray | None = None) -> None:
        """Walk to the stance (raises PickFailed or PlaceFailed with the navigation's reason); a stop short of it
        with the map point `reach` comfortably in the arm's reach will do."""

    def arm(self, moves: list[Move], hand: Hand | None = None) -> None: ...

    def stow_arm(self, finish_in_background: bool = False) -> None:
        """Arm back down, gripper closed, standing. `finish_in_background`: return once the hand is clear of the
        camera's view and let the arm finish on its own (the robot's next body step waits for it)."""


@dataclass(frozen=True)
class PlaceReport:
    name: str
    position: tuple[float, float, float]  # where the object was seen after letting go (map, m)
    error_m: float  # from the spot it was meant for
    stance_corrections: int


def place(
    name: str,
    height: float,
    spot: np.ndarray,
    facing_yaw: float,
    body: PlaceBody,
    round_object: bool = False,
    hand: Hand = "right",
) -> PlaceReport:
    """Put the object `name` held in `hand` (`height` tall, a ball if `round_object`) down with its base centre at
    `spot` (map, on a surface)."""
    spot = np.asarray(spot, dtype=float)
    corrections = 0
    for attempt in range(STANCE_ATTEMPTS + 1):
        in_feet = body.to_feet(spot)
        problem = reach_problem(in_feet, hand)
        if problem is None:
            break
        if attempt == STANCE_ATTEMPTS:
            raise PlaceFailed(f"unreachable: the spot is {problem} after {corrections} stance corrections")
        body.go_to(grasp_stance((float(spot[0]), float(spot[1])), facing_yaw, hand=hand), spot)
        corrections += 1
    moves, _ = place_moves(in_feet, height, round_object, hand)
    body.arm(moves, hand)
    body.stow_arm(finish_in_background=True)  # a spoken confirmation that follows need not wait for the arm
    seen = body.locate(name, near=spot)
    if seen is None:
        raise PlaceFailed(f"not found: the {name} is not where it was let go")
    error = math.dist(seen[:2], spot[:2])
    rise = float(seen[2] - spot[2])
    if error > PLACED_WITHIN_M or not -PLACED_BELOW_TOLERANCE_M <= rise <= PLACED_HEIGHT_TOLERANCE_M:
        raise PlaceFailed(
            f"the {name} did not stay where it was put: seen {error * 100:.0f} cm away, "
            f"{(seen[2] - spot[2]) * 100:+.0f} cm above the surface"
        )
    return PlaceReport(name, (float(seen[0]), float(seen[1]), float(seen[2])), error, corrections)


# Where on a surface to put something down, unless a spot in reach of where the robot stopped is free: this far in
# from its front edge, this far from anything else on it and from its sides. 10 cm in, the stance for it stands
# 21 cm from the edge, and a stop up to 7 cm nearer or further still has a spot in reach (7 cm in: 5 cm further only;
# a carrying robot's stops land up to 8 cm off).
PLACE_DEPTH_M = 0.10
SPACING_M = 0.08
EDGE_MARGIN_M = 0.05
# Spacing of the candidate spots tried in the reach window of a robot that has stopped (m).
SPOT_GRID_M = 0.01


def choose_spot(
    surface: Box, approach: tuple[float, float, float], occupied: list[tuple[float, float]]
) -> np.ndarray | None:
    """A free spot on `surface` in front of the `approach` pose, nearest the robot's line of approach, clear of the
    `occupied` points; None if the surface is full there."""
    x, y, yaw = approach
    edge = surface.distance_along(x, y, yaw)
    if not math.isfinite(edge):
        return None
    ahead = np.array([math.cos(yaw), math.sin(yaw)])
    left = np.array([-ahead[1], ahead[0]])
    base = np.array([x, y]) + (edge + PLACE_DEPTH_M) * ahead
    for k in (0, 1, -1, 2, -2, 3, -3):
        p = base + k * SPACING_M * left
        if not surface.contains(float(p[0]), float(p[1]), -EDGE_MARGIN_M):
            continue
        if any(math.dist(p, o) < SPACING_M for o in occupied):
            continue
        return np.array([p[0], p[1], surface.height])
    return None


def spots_in_reach(
    surface: Box, pose: tuple[float, float, float], occupied: list[tuple[float, float]], hand: Hand = "right"
) -> list[np.ndarray]:
    """Free spots on `surface` in `hand`'s comfortable reach of a robot standing at `pose` (x, y, heading; its feet
    roughly there), nearest the middle of the reach window first: wherever the robot came to rest by the surface,
    it can put the object down there without walking again. The caller checks the exact reach from the feet."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    low_y, high_y = reach_window_y(hand)
    middle_x, middle_y = grasp_offset(hand)
    ahead = np.arange(REACH_X[0] + REACH_MARGIN_M, REACH_X[1] - REACH_MARGIN_M + 1e-9, SPOT_GRID_M)
    left = np.arange(low_y + REACH_MARGIN_M, high_y - REACH_MARGIN_M + 1e-9, SPOT_GRID_M)
    grid = np.array([(a, b) for a in ahead for b in left])
    order = np.argsort(np.hypot(grid[:, 0] - middle_x, grid[:, 1] - middle_y), kind="stable")
    spots = []
    for a, b in grid[order]:
        px, py = x + c * a - s * b, y + s * a + c * b
        if not surface.contains(px, py, -EDGE_MARGIN_M):
            continue
        if any(math.dist((px, py), o) < SPACING_M for o in occupied):
            continue
        spots.append(np.array([px, py, surface.height]))
    return spots
