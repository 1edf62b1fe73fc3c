"""Orders to visit places in: the shortest-looking round from where the robot is (nearest first, then nearest to
that), on straight-line distances (good enough for a handful of places in one flat)."""

from __future__ import annotations

import math
from collections.abc import Sequence


def nearest_first(start: tuple[float, float], points: Sequence[tuple[str, tuple[float, float]]]) -> list[str]:
    """The names of `points` in a greedy nearest-neighbour order from `start`."""
    left = list(points)
    order: list[str] = []
    here = start
    while left:
        name, point = min(left, key=lambda item: math.dist(here, item[1]))
        order.append(name)
        left.remove((name, point))
        here = point
    return order
