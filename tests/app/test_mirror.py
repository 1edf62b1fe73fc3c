"""The 3D mirror follows the robot, and stays quiet when nothing visibly moved (viewers render on demand)."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.viz.mirror import VISIBLE_CHANGE, SceneMirror
from robot.interface import KnownObject, OccupancyMap, PerceptionState, ScanView, SensorFeed


class MovablePort:
    """One snapshot of a worker's state, which the test moves by hand."""

    def __init__(self, worker) -> None:
        self.worker = worker
        self.snapshot = worker.state()
        self.offset = np.zeros(len(self.snapshot.qpos))
        self.feed = SensorFeed()

    def state(self):
        return dataclasses.replace(self.snapshot, qpos=tuple(np.asarray(self.snapshot.qpos) + self.offset))

    def describe(self):
        return self.worker.describe()

    def sensor_feed(self):
        return self.feed


def test_mirror_pushes_visible_motion_only(make_worker) -> None:
    port = MovablePort(make_worker(realtime=False))
    mirror = SceneMirror(port)
    try:
        assert mirror.update_once()  # first picture
        port.offset[0] += VISIBLE_CHANGE / 10
        assert not mirror.update_once()  # sub-millimetre jitter is not sent
        port.offset[0] += 0.05
        assert mirror.update_once()
        trunk = mirror.model.body("body_link").id
        assert mirror.data.xpos[trunk][0] == np.asarray(port.state().qpos)[0]
        assert mirror.updates == 2
    finally:
        mirror.stop()


def test_light_profile_is_a_much_lighter_scene_of_the_same_robot(make_worker) -> None:
    import mujoco

    from app.viz.mirror import FULL, LIGHT, mirror_model

    xml = make_worker(realtime=False).describe().mjcf_xml

    def robot_triangles(model: mujoco.MjModel) -> int:
        return sum(
            int(model.mesh_facenum[model.geom_dataid[g]])
            for g in range(model.ngeom)
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH and model.geom_group[g] == 2
        )

    def planes(model: mujoco.MjModel) -> int:
        return int(np.sum(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE))

    full, light = mirror_model(xml, FULL), mirror_model(xml, LIGHT)
    assert robot_triangles(light) * 50 < robot_triangles(full)
    assert planes(full) == 1 and planes(light) == 0  # no infinite grid to shade
    assert light.nbody == full.nbody and light.nq == full.nq  # the same qpos drives both


def test_mirror_draws_the_planned_footsteps_com_and_zmp_and_clears_them(make_worker) -> None:
    from robot.interface import Footprint, LocomotionState

    port = MovablePort(make_worker(realtime=False))
    walking = LocomotionState(
        phase="walking",
        posture="stand",
        command=(0.1, 0.0, 0.0),
        velocity=(0.1, 0.0, 0.0),
        estimated_pose=(0.0, 0.0, 0.0),
        footsteps=(Footprint("left", 0.05, 0.05, 0.0), Footprint("right", 0.1, -0.05, 0.1)),
        com=(0.02, 0.0, 0.23),
        zmp=(0.03, 0.01),
        support="left",
    )
    port.snapshot = dataclasses.replace(port.snapshot, locomotion=walking)
    mirror = SceneMirror(port)
    try:
        assert mirror.update_once()
        steps = [h for h in mirror.gait._steps if h.visible]
        assert [tuple(np.round(h.position, 3)) for h in steps] == [(0.05, 0.05, 0.003), (0.1, -0.05, 0.003)]
        assert tuple(steps[1].color) != tuple(steps[0].color)  # left and right are told apart
        assert mirror.gait._com.visible and tuple(mirror.gait._com.position) == (0.02, 0.0, 0.23)
        assert mirror.gait._zmp.visible
        # the walk ends while the robot stands still: the overlay goes away
        standing = dataclasses.replace(walking, phase="standing", footsteps=(), com=None, zmp=None)
        port.snapshot = dataclasses.replace(port.snapshot, locomotion=standing)
        mirror.update_once()
        assert not any(h.visible for h in mirror.gait._steps) and not mirror.gait._com.visible
    finally:
        mirror.stop()


def test_mirror_draws_scan_map_and_seen_objects_and_only_resends_changes(make_worker) -> None:
    port = MovablePort(make_worker(realtime=False))
    mirror = SceneMirror(port)
    try:
        mirror.update_once()
        ranges = tuple([1.0] * 64)
        scan = ScanView(1.0, (0.0, 0.0, 0.0), 0.17, -np.pi, 2 * np.pi / 64, 8.0, ranges)
        grid = OccupancyMap(1.0, 0.05, (-1.0, -1.0), 40, 40, bytes([0] * 1600), 5)
        seen = KnownObject("red mug", (1.6, 0.7, 0.25), "kitchen counter", 1.0, 0.9)
        port.feed = SensorFeed(scan=scan, map=grid)
        port.snapshot = dataclasses.replace(port.snapshot, perception=PerceptionState("ok", known_objects=(seen,)))
        assert mirror.update_once()  # nothing moved, but there is something new to see
        overlay = mirror.perception
        assert overlay._scan is not None and len(overlay._scan.points) == 64
        assert overlay._map is not None and "red mug" in overlay._objects
        assert not mirror.update_once()  # the same again: nothing is resent
        port.feed = SensorFeed(scan=dataclasses.replace(scan, pose=(0.5, 0.0, 0.0)), map=grid)
        assert mirror.update_once()  # the robot moved: the scan is redrawn
        np.testing.assert_allclose(overlay._scan.points[:, 0].max(), 1.5, atol=1e-2)
    finally:
        mirror.stop()


class _RecordingScene:
    """Stands in for viser's scene: counts the map images sent to viewers."""

    def __init__(self) -> None:
        self.images: list[np.ndarray] = []

    def add_image(self, name, image, *args, **kwargs):
        self.images.append(image)
        return _Removable()


class _Removable:
    def remove(self) -> None:
        pass


def test_the_map_is_resent_only_when_what_it_shows_changed_and_at_most_once_a_second() -> None:
    """Each update makes every open 3D view render for a while (in software on machines without a GPU): a map whose
    occupancy values drift within their class (free stays free) is not resent, a growing map at most 1/s, and a
    cell or two flickering at the lidar's reach only now and then."""
    from types import SimpleNamespace

    from app.viz.perception_overlay import (
        FREE_RGBA,
        MAP_CHANGED_CELLS,
        MAP_REDRAW_MIN_S,
        MAP_REFRESH_S,
        OCCUPIED_RGBA,
        PerceptionOverlay,
    )

    scene, now = _RecordingScene(), [100.0]
    overlay = PerceptionOverlay(SimpleNamespace(scene=scene), clock=lambda: now[0])
    side = 20

    def grid(values: np.ndarray) -> OccupancyMap:
        return OccupancyMap(1.0, 0.05, (-1.0, -1.0), side, side, values.astype(np.int8).tobytes(), 5)

    values = np.full((side, side), -1)
    values[:10, :] = 10  # free
    values[0, 0] = 80  # occupied
    assert overlay.update(None, grid(values), None)
    assert len(scene.images) == 1
    image = scene.images[0]
    assert tuple(image[0, 0]) == OCCUPIED_RGBA and tuple(image[0, 1]) == FREE_RGBA and image[15, 0, 3] == 0

    now[0] += MAP_REDRAW_MIN_S / 10
    values[10:12, :] = 10  # the map grows by 40 cells ...
    assert not overlay.update(None, grid(values), None)  # ... but too soon after the last picture
    now[0] += MAP_REDRAW_MIN_S
    assert overlay.update(None, grid(values), None)  # so it comes with the next update after 1 s
    assert len(scene.images) == 2 and scene.images[1][11, 0, 3] > 0

    now[0] += 2 * MAP_REDRAW_MIN_S
    drifted = values.copy()
    drifted[drifted == 10] = 30  # values drift, the picture does not
    assert not overlay.update(None, grid(drifted), None)
    drifted[19, : MAP_CHANGED_CELLS // 4] = 5  # a few cells flicker at the edge of the lidar's reach
    assert not overlay.update(None, grid(drifted), None)
    now[0] += MAP_REFRESH_S
    assert overlay.update(None, grid(drifted), None)  # shown, but only after a while
    assert len(scene.images) == 3 and scene.images[2][19, 0, 3] > 0
