"""The apartment the humanoid lives in, scaled to the OP3 (about 0.5 m tall), with seeded randomisation.

`generate_world(seed)` returns a `WorldLayout`: plain data (places, objects, obstacles, start pose) that the
planner, the validator and the scene builder all read. A layout is only returned when every place is reachable
from the start on a grid with the robot's footprint inflated, so every seed is solvable.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

# Apartment interior: x in [-ROOM_X, ROOM_X], y in [-ROOM_Y, ROOM_Y] (m).
ROOM_X = 2.0
ROOM_Y = 1.5
WALL_THICKNESS = 0.05
WALL_HEIGHT = 0.6
# Partition between living room (x < 0) and kitchen (x > 0), with a doorway.
PARTITION_X = 0.4
DOORWAY_WIDTH = 0.8
# Robot footprint radius used to inflate obstacles when checking reachability (m).
ROBOT_RADIUS = 0.16
# What navigation keeps clear beyond the footprint: a walking robot sways, and its arms reach past its feet (m).
NAV_CLEARANCE_M = 0.08
GRID_RESOLUTION = 0.05
# Obstacles are at least this tall, so the lidar's plane (about 0.17 m up) crosses them (m).
OBSTACLE_MIN_HEIGHT = 0.2
# Distance from a surface's front edge to the open-floor staging point in front of it (m).
STAGING_DISTANCE = ROBOT_RADIUS + 0.1


@dataclass(frozen=True)
class Box:
    """An axis-aligned box resting on the floor: centre (x, y), half sizes, height, colour."""

    name: str
    x: float
    y: float
    half_x: float
    half_y: float
    height: float
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        return abs(x - self.x) <= self.half_x + margin and abs(y - self.y) <= self.half_y + margin

    def distance_along(self, x: float, y: float, yaw: float) -> float:
        """How far from (x, y), looking along `yaw`, the box begins in plan view (0 inside it, inf if missed)."""
        enter, leave = 0.0, math.inf
        axes = ((x, math.cos(yaw), self.x, self.half_x), (y, math.sin(yaw), self.y, self.half_y))
        for start, d, centre, half in axes:
            if abs(d) < 1e-9:
                if abs(start - centre) > half:
                    return math.inf
                continue
            t1, t2 = sorted(((centre - half - start) / d, (centre + half - start) / d))
            enter, leave = max(enter, t1), min(leave, t2)
        return enter if enter <= leave else math.inf


@dataclass(frozen=True)
class Place:
    """A named place the robot can go to.

    `approach` is the pose (x, y, yaw) to stand at, close enough to reach the surface; `staging` is a point in
    open floor in front of it, from which the final approach is a short straight walk.
    """

    name: str
    aliases: tuple[str, ...]
    surface: Box | None
    approach: tuple[float, float, float]
    staging: tuple[float, float]

    @property
    def surface_height(self) -> float:
        return self.surface.height if self.surface else 0.0

    @property
    def room(self) -> str:
        """Which room it is in, as people name it ("the table in the living room")."""
        return room_at(self.approach[0])


def room_at(x: float) -> str:
    """The room a point is in: the partition splits the living room (x < PARTITION_X) from the kitchen."""
    return "kitchen" if x > PARTITION_X else "living room"


@dataclass(frozen=True)
class WorldObject:
    """A movable object: a free body in the simulation."""

    name: str
    aliases: tuple[str, ...]
    color: str
    shape: str  # "mug" | "bottle" | "apple"
    rgba: tuple[float, float, float, float]
    mass: float
    radius: float
    height: float
    place: str
    position: tuple[float, float, float]  # centre of the body's base, world frame
    yaw: float = 0.0  # about the vertical; a mug's handle points along the body's +x

    @property
    def round(self) -> bool:
        """A ball (the apple), not an upright cylinder: grasped at its widest."""
        return self.shape == "apple"


@dataclass(frozen=True)
class WorldLayout:
    """Everything that describes one seeded apartment."""

    seed: int
    places: tuple[Place, ...]
    objects: tuple[WorldObject, ...]
    furniture: tuple[Box, ...]
    obstacles: tuple[Box, ...]
    walls: tuple[Box, ...]
    robot_start: tuple[float, float, float]  # x, y, yaw

    @property
    def place_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.places)

    @property
    def object_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.objects)

    def in_or_beyond_walls(self, x: float, y: float) -> bool:
        """Whether a point is in a wall or outside the apartment: never room to stand, though the lidar cannot see
        the wall behind a counter (at world seed 6 a stance half through it looked free on the map)."""
        if not self.walls:
            return False
        return abs(x) > ROOM_X or abs(y) > ROOM_Y or any(w.contains(x, y) for w in self.walls)


def _walls() -> tuple[Box, ...]:
    t, h = WALL_THICKNESS, WALL_HEIGHT
    colour = (0.85, 0.83, 0.78, 1.0)
    half_gap = DOORWAY_WIDTH / 2
    # The doorway sits in the middle third of the partition.
    upper_len = ROOM_Y - half_gap
    return (
        Box("wall_north", 0.0, ROOM_Y + t, ROOM_X + 2 * t, t, h, colour),
        Box("wall_south", 0.0, -ROOM_Y - t, ROOM_X + 2 * t, t, h, colour),
        Box("wall_east", ROOM_X + t, 0.0, t, ROOM_Y, h, colour),
        Box("wall_west", -ROOM_X - t, 0.0, t, ROOM_Y, h, colour),
        Box("partition_north", PARTITION_X, half_gap + upper_len / 2, t / 2, upper_len / 2, h, colour),
        Box("partition_south", PARTITION_X, -half_gap - upper_len / 2, t / 2, upper_len / 2, h, colour),
    )


KITCHEN_COUNTER = Box("kitchen_counter", 1.75, 0.55, 0.2, 0.7, 0.25, (0.55, 0.42, 0.3, 1.0))
LIVING_TABLE = Box("living_room_table", -1.2, 0.75, 0.3, 0.25, 0.2, (0.45, 0.3, 0.2, 1.0))
# A charging mat flush with the floor (3 mm): the walking controller does not climb steps.
DOCK_PAD = Box("charging_dock", -1.65, -1.15, 0.15, 0.15, 0.003, (0.2, 0.7, 0.9, 1.0))
MAT_HEIGHT_M = 0.01  # a piece of "furniture" no taller than this is a mat the robot walks on
FEET_REACH_M = 0.15  # how far the feet reach from the trunk's centre, standing (half a foot's length, the hips' width)


def is_mat(box: Box) -> bool:
    """A flat piece the robot walks onto (a foot landing on its edge or corner tilts: see `robot.skills.navigate`)."""
    return box.height <= MAT_HEIGHT_M


def near_mat_edges(mats: Iterable[Box], x: np.ndarray, y: np.ndarray, reach_m: float = FEET_REACH_M) -> np.ndarray:
    """Where (element-wise over the coordinate arrays `x`, `y`) a robot standing would have a foot on a mat's edge:
    within `reach_m` of it, on or off the mat."""
    near = np.zeros(np.broadcast_shapes(x.shape, y.shape), dtype=bool)
    for mat in mats:
        dx, dy = np.abs(x - mat.x), np.abs(y - mat.y)
        around = (dx <= mat.half_x + reach_m) & (dy <= mat.half_y + reach_m)
        deep_inside = (dx <= mat.half_x - reach_m) & (dy <= mat.half_y - reach_m)
        near |= around & ~deep_inside
    return near


_OBJECT_SPECS = (
    # name, aliases, colour, shape, rgba, mass (kg), radius, height (m)
    ("red mug", ("mug", "cup", "red cup", "coffee mug"), "red", "mug", (0.85, 0.1, 0.1, 1.0), 0.05, 0.0175, 0.05),
    ("blue bottle", ("bottle", "water bottle"), "blue", "bottle", (0.1, 0.25, 0.9, 1.0), 0.06, 0.015, 0.09),
    ("green apple", ("apple",), "green", "apple", (0.2, 0.75, 0.15, 1.0), 0.04, 0.02, 0.04),
)


def _places(counter_item_y: float) -> tuple[Place, ...]:
    front = KITCHEN_COUNTER.x - KITCHEN_COUNTER.half_x
    table_front = LIVING_TABLE.y - LIVING_TABLE.half_y
    return (
        Place(
            "kitchen counter",
            ("counter", "kitchen", "kitchen counter"),
            KITCHEN_COUNTER,
            (front - 0.12, counter_item_y, 0.0),
            (front - STAGING_DISTANCE, counter_item_y),
        ),
        Place(
            "living-room table",
            ("table", "living room table", "living room", "coffee table"),
            LIVING_TABLE,
            (LIVING_TABLE.x, table_front - 0.12, math.pi / 2),
            (LIVING_TABLE.x, table_front - STAGING_DISTANCE),
        ),
        Place(
            "charging dock",
            ("dock", "charger", "charging station", "charging dock", "base"),
            DOCK_PAD,
            (DOCK_PAD.x, DOCK_PAD.y, 0.0),
            (DOCK_PAD.x, DOCK_PAD.y),
        ),
    )


def _place_counter_objects(rng: np.random.Generator, handles: np.random.Generator) -> list[WorldObject]:
    """Objects along the counter, 6-12 cm from its front edge, at least 12 cm apart.

    Handles point to the back of the counter, give or take 30 deg: a handle beside the mug, where a finger goes,
    foils a side grasp (shared FINDINGS.md: 1 in 10). They are drawn from their own stream (`handles`), so the rest
    of a seed's world does not depend on them."""
    front = KITCHEN_COUNTER.x - KITCHEN_COUNTER.half_x
    y_lo = KITCHEN_COUNTER.y - KITCHEN_COUNTER.half_y + 0.1
    y_hi = KITCHEN_COUNTER.y + KITCHEN_COUNTER.half_y - 0.1
    while True:
        ys = rng.uniform(y_lo, y_hi, size=len(_OBJECT_SPECS))
        if all(abs(a - b) >= 0.12 for i, a in enumerate(ys) for b in ys[i + 1 :]):
            break
    objects = []
    for (name, aliases, colour, shape, rgba, mass, radius, height), y in zip(_OBJECT_SPECS, ys, strict=True):
        x = front + rng.uniform(0.06, 0.12)
        yaw = float(handles.uniform(-math.pi / 6, math.pi / 6))
        objects.append(
            WorldObject(
                name,
                aliases,
                colour,
                shape,
                rgba,
                mass,
                radius,
                height,
                "kitchen counter",
                (float(x), float(y), KITCHEN_COUNTER.height),
                yaw,
            )
        )
    return objects


def _random_obstacles(rng: np.random.Generator, count: int, keep_clear: list[tuple[float, float]]) -> list[Box]:
    names = ("chair", "plant", "box", "stool")
    colours = ((0.35, 0.35, 0.4, 1.0), (0.2, 0.5, 0.25, 1.0), (0.7, 0.6, 0.4, 1.0), (0.5, 0.3, 0.3, 1.0))
    obstacles: list[Box] = []
    attempts = 0
    while len(obstacles) < count and attempts < 500:
        attempts += 1
        hx, hy = rng.uniform(0.06, 0.14, size=2)
        x = rng.uniform(-ROOM_X + hx + 0.05, ROOM_X - hx - 0.05)
        y = rng.uniform(-ROOM_Y + hy + 0.05, ROOM_Y - hy - 0.05)
        height = float(rng.uniform(OBSTACLE_MIN_HEIGHT, 0.35))
        candidate = Box(
            names[len(obstacles) % len(names)] + f"_{len(obstacles)}",
            float(x),
            float(y),
            float(hx),
            float(hy),
            height,
            colours[len(obstacles) % len(colours)],
        )
        blocked = [KITCHEN_COUNTER, LIVING_TABLE, DOCK_PAD, *obstacles, *_walls()]
        if any(_boxes_overlap(candidate, b, 0.1) for b in blocked):
            continue
        if any(candidate.contains(px, py, margin=ROBOT_RADIUS + 0.1) for px, py in keep_clear):
            continue
        obstacles.append(candidate)
    return obstacles


def _boxes_overlap(a: Box, b: Box, margin: float) -> bool:
    return abs(a.x - b.x) < a.half_x + b.half_x + margin and abs(a.y - b.y) < a.half_y + b.half_y + margin


def occupancy_grid(layout: WorldLayout, inflate: float = ROBOT_RADIUS) -> tuple[np.ndarray, float, float]:
    """Boolean grid (True = blocked for the robot's centre) over the apartment; returns (grid, x0, y0)."""
    res = GRID_RESOLUTION
    x0, y0 = -ROOM_X, -ROOM_Y
    nx, ny = round(2 * ROOM_X / res) + 1, round(2 * ROOM_Y / res) + 1
    xs = x0 + res * np.arange(nx)
    ys = y0 + res * np.arange(ny)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    blocked = (np.abs(gx) > ROOM_X - inflate) | (np.abs(gy) > ROOM_Y - inflate)
    # The dock pad is flat: the robot stands on it.
    for box in (*layout.walls, *layout.furniture, *layout.obstacles):
        if box.name == DOCK_PAD.name:
            continue
        blocked |= (np.abs(gx - box.x) <= box.half_x + inflate) & (np.abs(gy - box.y) <= box.half_y + inflate)
    return blocked, x0, y0


def reachable(layout: WorldLayout, goals: list[tuple[float, float]], inflate: float = ROBOT_RADIUS) -> bool:
    """True when every goal cell is connected to the start cell (4-connected flood fill), with everything grown by
    `inflate` (the robot's footprint, or more)."""
    grid, x0, y0 = occupancy_grid(layout, inflate)

    def cell(x: float, y: float) -> tuple[int, int]:
        return round((x - x0) / GRID_RESOLUTION), round((y - y0) / GRID_RESOLUTION)

    start = cell(*layout.robot_start[:2])
    if grid[start]:
        return False
    seen = np.zeros_like(grid)
    seen[start] = True
    queue = deque([start])
    while queue:
        i, j = queue.popleft()
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            ni, nj = i + di, j + dj
            if 0 <= ni < grid.shape[0] and 0 <= nj < grid.shape[1] and not grid[ni, nj] and not seen[ni, nj]:
                seen[ni, nj] = True
                queue.append((ni, nj))
    return all(seen[cell(x, y)] for x, y in goals)


def generate_world(seed: int = 0, obstacle_count: int = 3) -> WorldLayout:
    """A seeded apartment in which every place is reachable from the robot's start."""
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    rng = np.random.default_rng(seed)
    handles = np.random.default_rng([seed, 1])
    for _ in range(200):
        objects = _place_counter_objects(rng, handles)
        mug_y = next(o.position[1] for o in objects if o.name == "red mug")
        places = _places(mug_y)
        start = (float(rng.uniform(-1.0, -0.2)), float(rng.uniform(-0.9, -0.3)), float(rng.uniform(-math.pi, math.pi)))
        keep_clear = [start[:2], *(p.staging for p in places), (PARTITION_X, 0.0)]
        obstacles = _random_obstacles(rng, obstacle_count, keep_clear)
        layout = WorldLayout(
            seed=seed,
            places=places,
            objects=tuple(objects),
            furniture=(KITCHEN_COUNTER, LIVING_TABLE, DOCK_PAD),
            obstacles=tuple(obstacles),
            walls=_walls(),
            robot_start=start,
        )
        # solvable by the navigator's own rules: a gap the robot's footprint fits through, but its grown map closes
        # (an obstacle just in front of the doorway), would fail every run as "path blocked"
        passable = ROBOT_RADIUS + NAV_CLEARANCE_M
        if len(obstacles) == obstacle_count and reachable(layout, [p.staging for p in places], passable):
            return layout
    raise RuntimeError(f"could not generate a solvable world for seed {seed}")  # pragma: no cover


def open_floor() -> WorldLayout:
    """No walls, furniture or objects: for walking trials, which must not end against a wall."""
    return WorldLayout(seed=0, places=(), objects=(), furniture=(), obstacles=(), walls=(), robot_start=(0.0, 0.0, 0.0))
