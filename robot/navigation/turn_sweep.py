"""Which way round to turn about: turning in place, the hands held back beside the trunk sweep a ring round it, and
over a turn of about half a circle the two ways round sweep different parts of it. A patrol turning about between a
wall and a table, its path replanned the other way, put its fingers on the table turning one way (world seed 18);
the other way round they would have passed clear of it."""

from __future__ import annotations

import math

import numpy as np

# The fingers at rest: 0.2 m behind the trunk's centre and 0.15 m out to each side (see the navigator's TURN_ROOM_M).
FINGER_BEARING_RAD = math.atan2(0.15, -0.2)  # 143 deg from the heading, each side
# A turn about, this wide or wider, may go the long way round where that keeps the fingers farther from things.
TURN_ABOUT_RAD = math.radians(150.0)


def swept(bearings: np.ndarray, turn_rad: float) -> np.ndarray:
    """Which `bearings` (from the heading at the turn's start, anticlockwise) the fingers pass over in a turn in place
    of `turn_rad` (anticlockwise if positive)."""
    hit = np.zeros(np.shape(bearings), dtype=bool)
    direction = 1.0 if turn_rad >= 0.0 else -1.0
    for finger in (FINGER_BEARING_RAD, -FINGER_BEARING_RAD):
        # how far the finger turns before it is over the bearing
        to_bearing = np.mod(direction * (np.asarray(bearings) - finger), math.tau)
        hit |= to_bearing <= abs(turn_rad)
    return hit


def turn_way(obstacles: np.ndarray, heading_error_rad: float) -> float:
    """+1 (anticlockwise) or -1: the way round to turn through `heading_error_rad` (wrapped to +-pi). The shorter
    way, unless the turn is a turn about (`TURN_ABOUT_RAD`) and the fingers would pass `obstacles` (points, n x 2,
    in the robot's frame: x ahead, y to the left) farther away going the long way round."""
    short = math.remainder(heading_error_rad, math.tau)
    short_way = 1.0 if short >= 0.0 else -1.0
    points = np.asarray(obstacles, dtype=float).reshape(-1, 2)
    if abs(short) < TURN_ABOUT_RAD or len(points) == 0:
        return short_way
    bearings = np.arctan2(points[:, 1], points[:, 0])
    distances = np.hypot(points[:, 0], points[:, 1])

    def nearest_swept(turn: float) -> float:
        hit = swept(bearings, turn)
        return float(distances[hit].min()) if hit.any() else math.inf

    long = short - short_way * math.tau
    return -short_way if nearest_swept(long) > nearest_swept(short) else short_way
