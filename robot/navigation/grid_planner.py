"""A* on a 2D grid of blocked cells, 8-connected, with no corner cutting; for a robot whose footprint has been
inflated into the obstacles already (so the path is for the robot's centre)."""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable

import numpy as np

_MOVES = [(di, dj, math.hypot(di, dj)) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj]


def inflate(blocked: np.ndarray, radius_cells: float) -> np.ndarray:
    """Every cell within `radius_cells` of a blocked cell becomes blocked (a disc, not a square)."""
    r = math.ceil(radius_cells)
    out = blocked.copy()
    for di in range(-r, r + 1):
        for dj in range(-r, r + 1):
            if di * di + dj * dj > radius_cells * radius_cells or (di == 0 and dj == 0):
                continue
            shifted = np.zeros_like(blocked)
            src = blocked[max(0, -di) : blocked.shape[0] - max(0, di), max(0, -dj) : blocked.shape[1] - max(0, dj)]
            shifted[max(0, di) : max(0, di) + src.shape[0], max(0, dj) : max(0, dj) + src.shape[1]] = src
            out |= shifted
    return out


def nearest_free(blocked: np.ndarray, cell: tuple[int, int], max_cells: int = 20) -> tuple[int, int] | None:
    """The free cell closest to `cell` (itself when free), within `max_cells`; None if there is none."""
    i0, j0 = cell
    best: tuple[float, tuple[int, int]] | None = None
    for r in range(max_cells + 1):
        for i in range(i0 - r, i0 + r + 1):
            for j in range(j0 - r, j0 + r + 1):
                if max(abs(i - i0), abs(j - j0)) != r:
                    continue
                if 0 <= i < blocked.shape[0] and 0 <= j < blocked.shape[1] and not blocked[i, j]:
                    d = math.hypot(i - i0, j - j0)
                    if best is None or d < best[0]:
                        best = (d, (i, j))
        if best is not None and best[0] <= r:
            return best[1]
    return best[1] if best else None


def astar(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> list[tuple[int, int]] | None:
    """Shortest 8-connected path of cells from start to goal (both included), or None when there is none."""
    ni, nj = blocked.shape
    for name, (i, j) in (("start", start), ("goal", goal)):
        if not (0 <= i < ni and 0 <= j < nj):
            raise ValueError(f"{name} cell {(i, j)} is outside the grid {blocked.shape}")
    if blocked[start] or blocked[goal]:
        return None
    gi, gj = goal

    def h(i: int, j: int) -> float:
        di, dj = abs(i - gi), abs(j - gj)
        return max(di, dj) + (math.sqrt(2) - 1) * min(di, dj)

    cost = np.full(blocked.shape, np.inf)
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    cost[start] = 0.0
    frontier = [(h(*start), 0.0, start)]
    while frontier:
        _, g, cell = heapq.heappop(frontier)
        if cell == goal:
            path = [cell]
            while cell in parent:
                cell = parent[cell]
                path.append(cell)
            return path[::-1]
        if g > cost[cell]:
            continue
        i, j = cell
        for di, dj, step in _MOVES:
            a, b = i + di, j + dj
            if not (0 <= a < ni and 0 <= b < nj) or blocked[a, b]:
                continue
            if di and dj and (blocked[i + di, j] or blocked[i, j + dj]):
                continue  # no squeezing diagonally between two blocked cells
            new = g + step
            if new < cost[a, b]:
                cost[a, b] = new
                parent[(a, b)] = cell
                heapq.heappush(frontier, (new + h(a, b), new, (a, b)))
    return None


def simplify(
    path: list[tuple[float, float]], blocked_at: Callable[[float, float], bool], step: float
) -> list[tuple[float, float]]:
    """Drop waypoints that a straight line can skip without crossing a blocked point (checked every `step` m)."""
    if len(path) <= 2:
        return path
    out = [path[0]]
    anchor = 0
    for k in range(2, len(path)):
        if not line_free(path[anchor], path[k], blocked_at, step):
            out.append(path[k - 1])
            anchor = k - 1
    out.append(path[-1])
    return out


def line_free(
    a: tuple[float, float], b: tuple[float, float], blocked_at: Callable[[float, float], bool], step: float
) -> bool:
    """Whether the straight line from a to b crosses no blocked point (checked every `step` m)."""
    n = max(1, math.ceil(math.dist(a, b) / step))
    return not any(blocked_at(a[0] + (b[0] - a[0]) * t / n, a[1] + (b[1] - a[1]) * t / n) for t in range(n + 1))
