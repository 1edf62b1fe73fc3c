"""How well an occupancy map agrees with the true scene: for benchmarks and tests (it reads the world's layout,
which the robot itself never does)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot.model.world import WorldLayout
from robot.perception.occupancy import GridSpec, OccupancyGrid

EPS = 1e-4


def true_occupancy(layout: WorldLayout, spec: GridSpec, plane_height: float) -> np.ndarray:
    """Cells overlapped by any geometry that crosses the lidar's plane (walls, furniture, obstacles)."""
    x_lo = spec.x0 + spec.resolution * np.arange(spec.nx)
    y_lo = spec.y0 + spec.resolution * np.arange(spec.ny)
    gx, gy = np.meshgrid(x_lo, y_lo, indexing="ij")
    res = spec.resolution
    occupied = np.zeros((spec.nx, spec.ny), dtype=bool)
    for box in (*layout.walls, *layout.furniture, *layout.obstacles):
        if box.height <= plane_height:
            continue
        # overlaps of less than a tenth of a millimetre (a face on a cell's edge) do not count
        overlap_x = (gx < box.x + box.half_x - EPS) & (gx + res > box.x - box.half_x + EPS)
        overlap_y = (gy < box.y + box.half_y - EPS) & (gy + res > box.y - box.half_y + EPS)
        occupied |= overlap_x & overlap_y
    return occupied


@dataclass(frozen=True)
class MapAgreement:
    iou: float  # occupied cells, over the cells the map has observed
    precision: float  # of the map's occupied cells, the share that is truly occupied
    recall: float  # of the truly occupied cells the map observed, the share it marks occupied
    coverage: float  # of the truly occupied cells facing free space, the share the map has observed
    occupied_cells: int

    def to_dict(self) -> dict[str, float]:
        return {k: round(float(v), 4) for k, v in self.__dict__.items()}


def agreement(grid: OccupancyGrid, truth: np.ndarray) -> MapAgreement:
    """IoU of occupied cells where the map has observed (a box's hidden inside is never seen, so not scored)."""
    known = grid.known()
    mapped = grid.occupied() & known
    true_known = truth & known
    union = int((mapped | true_known).sum())
    inter = int((mapped & true_known).sum())
    # truly occupied cells with a free neighbour: the surfaces a lidar could see
    free = ~truth
    surface = truth & (np.roll(free, 1, 0) | np.roll(free, -1, 0) | np.roll(free, 1, 1) | np.roll(free, -1, 1))
    return MapAgreement(
        iou=inter / union if union else 0.0,
        precision=inter / int(mapped.sum()) if mapped.any() else 0.0,
        recall=inter / int(true_known.sum()) if true_known.any() else 0.0,
        coverage=float((surface & known).sum() / max(1, int(surface.sum()))),
        occupied_cells=int(mapped.sum()),
    )
