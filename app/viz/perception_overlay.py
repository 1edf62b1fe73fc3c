"""What perception believes, drawn in the 3D mirror: the lidar scan, the occupancy map on the floor, and each
object where perception localised it (a box and a label).

Viewers re-render on every update, in software on machines without a GPU, so nothing is sent unless it changed
visibly: the scan when the robot moved or the scene did, the map when what it shows changed (unknown, free,
occupied: an occupancy value that drifts within its class is not a change; the few cells at the edge of the lidar's
reach that flicker while the robot stands still wait up to a minute) and at most once a second, objects when they
moved. Each update a view receives makes it render for a quarter of a second: a map resent twice a second kept
every idle view rendering all the time, 70 % of a core of software WebGL for two views (`humanoid bench core`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np
import viser

from robot.interface import KnownObject, NavigationState, OccupancyMap, PerceptionState, ScanView

SCAN_COLOUR = (230, 30, 30)
OBJECT_COLOUR = (255, 200, 0)
MAP_Z = 0.002
# A scan is redrawn when the sensor moved this much (m, rad), or when this share of its beams changed by > 5 cm.
SCAN_MOVE_M = 0.01
SCAN_TURN_RAD = math.radians(1.0)
SCAN_CHANGED_SHARE = 0.02
OBJECT_MOVE_M = 0.005
# Occupancy colours (RGBA): unknown is transparent, free a pale wash, occupied dark.
FREE_RGBA = (110, 160, 255, 60)  # a pale blue wash: visible on a light floor
OCCUPIED_RGBA = (30, 30, 60, 210)
OCCUPIED_FROM = 67  # occupancy (0-100) from which a cell is drawn occupied; -1 is unknown
MAP_REDRAW_MIN_S = 1.0  # a map growing while the robot explores is redrawn at most this often
MAP_CHANGED_SHARE = 0.01  # a redraw needs this share of the known cells changed (or MAP_CHANGED_CELLS) ...
MAP_CHANGED_CELLS = 20
MAP_REFRESH_S = 60.0  # ... or this long since the last one: a flickering cell or two can wait (each resend
# made every idle view draw ~6 frames in software WebGL, more than viser's own idle redraw: `app.viz.idle_redraw`)
UNKNOWN, FREE, OCCUPIED = 0, 1, 2


def map_classes(grid: OccupancyMap) -> np.ndarray:
    """What each cell shows (UNKNOWN, FREE or OCCUPIED); rows along y from the grid's origin, columns along x."""
    data = np.frombuffer(grid.data, dtype=np.int8).reshape(grid.height, grid.width)
    return (data >= 0).astype(np.uint8) + (data >= OCCUPIED_FROM).astype(np.uint8)


def map_rgba(classes: np.ndarray) -> np.ndarray:
    """Rows along y from the grid's origin, columns along x: the orientation viser's image plane shows at
    identity rotation (its first row lies at local -y)."""
    image = np.zeros((*classes.shape, 4), dtype=np.uint8)
    image[classes == FREE] = FREE_RGBA
    image[classes == OCCUPIED] = OCCUPIED_RGBA
    return image


class PerceptionOverlay:
    def __init__(self, server: viser.ViserServer, clock: Callable[[], float] = time.monotonic) -> None:
        self._scene = server.scene
        self._clock = clock
        self._scan: viser.PointCloudHandle | None = None
        self._scan_drawn: ScanView | None = None
        self._map: viser.ImageHandle | None = None
        self._map_drawn: tuple[tuple[float, float, float, float], np.ndarray] | None = None  # (geometry, classes)
        self._map_drawn_at = -math.inf
        self._objects: dict[str, tuple[viser.BoxHandle, viser.LabelHandle, KnownObject]] = {}

    def update(self, scan: ScanView | None, grid: OccupancyMap | None, state: PerceptionState | None) -> bool:
        """Draw what changed; returns whether anything was sent."""
        changed = False
        if scan is not None and self._scan_changed(scan):
            self._draw_scan(scan)
            changed = True
        if grid is not None and self._clock() - self._map_drawn_at >= MAP_REDRAW_MIN_S:
            changed |= self._draw_map_if_changed(grid)
        if state is not None:
            changed |= self._draw_objects(state.known_objects)
        return changed

    def _scan_changed(self, scan: ScanView) -> bool:
        old = self._scan_drawn
        if old is None or len(old.ranges) != len(scan.ranges):
            return True
        moved = math.hypot(scan.pose[0] - old.pose[0], scan.pose[1] - old.pose[1]) > SCAN_MOVE_M
        turned = abs(math.remainder(scan.pose[2] - old.pose[2], math.tau)) > SCAN_TURN_RAD
        if moved or turned:
            return True
        a = np.nan_to_num(np.asarray(old.ranges), posinf=99.0)
        b = np.nan_to_num(np.asarray(scan.ranges), posinf=99.0)
        return float(np.mean(np.abs(a - b) > 0.05)) > SCAN_CHANGED_SHARE

    def _draw_scan(self, scan: ScanView) -> None:
        ranges = np.asarray(scan.ranges, dtype=float)
        hit = np.isfinite(ranges)
        x, y, yaw = scan.pose
        angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))[hit] + yaw
        r = ranges[hit]
        points = np.stack([x + r * np.cos(angles), y + r * np.sin(angles), np.full(r.shape, scan.height_m)], axis=-1)
        if self._scan is None:
            self._scan = self._scene.add_point_cloud(
                "/perception/scan", points.astype(np.float32), SCAN_COLOUR, point_size=0.02, point_shape="circle"
            )
        else:
            self._scan.points = points.astype(np.float32)
            self._scan.colors = np.tile(np.array(SCAN_COLOUR, dtype=np.uint8), (len(points), 1))
        self._scan_drawn = scan

    def _draw_map_if_changed(self, grid: OccupancyMap) -> bool:
        geometry = (grid.origin[0], grid.origin[1], grid.resolution, float(grid.width))
        classes = map_classes(grid)
        if self._map_drawn is not None:
            drawn_geometry, drawn_classes = self._map_drawn
            if drawn_geometry == geometry and drawn_classes.shape == classes.shape:
                changed = int(np.count_nonzero(drawn_classes != classes))
                enough = max(MAP_CHANGED_CELLS, MAP_CHANGED_SHARE * np.count_nonzero(classes))
                stale = self._clock() - self._map_drawn_at >= MAP_REFRESH_S
                if changed == 0 or (changed < enough and not stale):
                    return False
        width, height = grid.width * grid.resolution, grid.height * grid.resolution
        centre = (grid.origin[0] + width / 2, grid.origin[1] + height / 2, MAP_Z)
        if self._map is not None:
            self._map.remove()
        self._map = self._scene.add_image(
            "/perception/map",
            map_rgba(classes),
            width,
            height,
            format="png",
            position=centre,
            cast_shadow=False,
            receive_shadow=False,
        )
        self._map_drawn = (geometry, classes)
        self._map_drawn_at = self._clock()
        return True

    def _draw_objects(self, known: tuple[KnownObject, ...]) -> bool:
        changed = False
        for obj in known:
            drawn = self._objects.get(obj.name)
            if drawn is not None and math.dist(drawn[2].position, obj.position) < OBJECT_MOVE_M:
                continue
            x, y, z = obj.position
            text = f"{obj.name} (seen)"
            if drawn is None:
                key = obj.name.replace(" ", "_")
                box = self._scene.add_box(
                    f"/perception/objects/{key}",
                    OBJECT_COLOUR,
                    (0.05, 0.05, 0.005),
                    position=(x, y, z + 0.001),
                    opacity=0.8,
                    cast_shadow=False,
                    receive_shadow=False,
                )
                label = self._scene.add_label(
                    f"/perception/objects/{key}_label", text, position=(x, y, z + 0.12), anchor="bottom-center"
                )
            else:
                box, label, _ = drawn
                box.position = (x, y, z + 0.001)
                label.position = (x, y, z + 0.12)
            self._objects[obj.name] = (box, label, obj)
            changed = True
        return changed


PATH_COLOUR = (40, 200, 120)
GOAL_COLOUR = (40, 200, 120)
PATH_Z = 0.01


class NavigationOverlay:
    """The path `navigate_to` follows (a green line on the floor) and its goal pose (an arrow-like box)."""

    def __init__(self, server: viser.ViserServer) -> None:
        self._scene = server.scene
        self._path: viser.LineSegmentsHandle | None = None
        self._goal = self._scene.add_box(
            "/navigation/goal", GOAL_COLOUR, (0.12, 0.03, 0.01), cast_shadow=False, receive_shadow=False, visible=False
        )
        self._drawn: NavigationState | None = None

    def update(self, navigation: NavigationState | None) -> bool:
        if navigation == self._drawn:
            return False
        self._drawn = navigation
        if self._path is not None:
            self._path.remove()
            self._path = None
        if navigation is None:
            self._goal.visible = False
            return True
        points = np.array([(x, y, PATH_Z) for x, y in navigation.path], dtype=np.float32)
        if len(points) >= 2:
            segments = np.stack([points[:-1], points[1:]], axis=1)
            self._path = self._scene.add_line_segments(
                "/navigation/path", segments, PATH_COLOUR, thickness=4.0, thickness_units="screen"
            )
        x, y, heading = navigation.goal
        self._goal.position = (x + 0.06 * math.cos(heading), y + 0.06 * math.sin(heading), PATH_Z)
        self._goal.wxyz = (math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2))
        self._goal.visible = True
        return True
