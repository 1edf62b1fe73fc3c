"""Perception on rendered images and ray-cast scans: what is found, where, and what the map says."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from robot.model.scene import object_body_name
from robot.model.world import Box, WorldLayout, generate_world
from robot.perception.lidar import LaserScan
from robot.perception.localisation import ScanMatcher
from robot.perception.map_quality import agreement, true_occupancy
from robot.perception.occupancy import GridSpec, OccupancyMapper
from robot.perception.suite import SensorSnapshot, SensorSuite
from robot.sim.backend import MujocoSimBackend


def _qpos(suite: SensorSuite, x: float, y: float, yaw: float, tilt: float = -0.3, pan: float = 0.0) -> np.ndarray:
    """The robot standing at (x, y, yaw), head at (pan, tilt); everything else where the layout puts it."""
    qpos = MujocoSimBackend(suite.layout, suite.model).qpos()
    qpos[0:2] = (x, y)
    qpos[3:7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
    qpos[suite.model.joint("head_tilt").qposadr[0]] = tilt
    qpos[suite.model.joint("head_pan").qposadr[0]] = pan
    return qpos


def _sense(suite: SensorSuite, qpos: np.ndarray, believed_offset: tuple[float, float] = (0.0, 0.0), lidar: bool = True):
    trunk = qpos[0:3].copy()
    trunk[:2] += believed_offset
    return suite.process(SensorSnapshot(0.0, qpos, trunk, qpos[3:7].copy(), lidar=lidar))


def _truth(suite: SensorSuite, name: str) -> np.ndarray:
    import mujoco

    data = suite.data
    mujoco.mj_kinematics(suite.model, data)
    return data.xpos[suite.model.body(object_body_name(name)).id].copy()


@pytest.fixture(scope="module")
def suite() -> SensorSuite:
    s = SensorSuite(generate_world(0))
    yield s
    s.close()


def test_camera_is_a_d435_class_rgbd_sensor(suite: SensorSuite) -> None:
    out = _sense(suite, _qpos(suite, 1.0, 0.5, 0.0))
    image = suite.camera.capture(suite.data)
    assert image.rgb.shape == (480, 640, 3) and image.depth.shape == (480, 640)
    assert suite.camera.intrinsics.hfov_deg == pytest.approx(87.0, abs=0.1)
    valid = image.depth[image.depth > 0]
    assert valid.size > 0.5 * image.depth.size and valid.min() > 0.1 and valid.max() < 6.0
    assert out.camera is not None and out.camera.jpeg[:2] == b"\xff\xd8"  # a JPEG for the browser


def test_one_render_gives_the_colour_and_depth_mujocos_renderer_draws_in_two(suite: SensorSuite) -> None:
    """The camera reads colour and depth from one render (half the cost): they must be MuJoCo's own images."""
    import mujoco

    _sense(suite, _qpos(suite, 0.4, 0.3, 0.2, tilt=-0.4), lidar=False)
    camera_id = suite.camera.camera_id
    rgb, depth = suite.camera.renderer.render(suite.data, camera_id)
    reference = mujoco.Renderer(suite.model, rgb.shape[0], rgb.shape[1])
    try:
        reference.update_scene(suite.data, camera=camera_id, scene_option=suite.camera.option)
        for flag in (
            mujoco.mjtRndFlag.mjRND_SHADOW,
            mujoco.mjtRndFlag.mjRND_REFLECTION,
            mujoco.mjtRndFlag.mjRND_SKYBOX,
        ):
            reference.scene.flags[flag] = 0
        expected_rgb = reference.render().copy()
        reference.enable_depth_rendering()
        expected_depth = reference.render().copy()
    finally:
        reference.close()
    assert np.array_equal(rgb, expected_rgb)
    assert np.allclose(depth, expected_depth, rtol=1e-6, atol=1e-6)
    assert 0.2 < float(np.median(depth)) < 6.0  # a real scene, not an empty frame


def test_depth_noise_grows_with_the_square_of_the_distance_and_differs_frame_to_frame(suite: SensorSuite) -> None:
    _sense(suite, _qpos(suite, 0.4, 0.3, 0.2, tilt=-0.4), lidar=False)
    _, truth = suite.camera.renderer.render(suite.data, suite.camera.camera_id)
    frames = [suite.camera.capture(suite.data).depth for _ in range(3)]
    valid = (truth > 0.3) & (truth < 5.0) & np.all([f > 0 for f in frames], axis=0)
    normalised = [(f[valid] - truth[valid]) / truth[valid] ** 2 for f in frames]
    for errors in normalised:
        assert float(np.std(errors)) == pytest.approx(suite.camera.depth_noise_per_m2, rel=0.1)
        assert abs(float(np.mean(errors))) < 0.1 * suite.camera.depth_noise_per_m2
    assert abs(float(np.corrcoef(normalised[0], normalised[1])[0, 1])) < 0.05  # a fresh draw each frame


@pytest.mark.parametrize(("distance", "y"), [(0.5, 0.35), (0.9, 0.35), (1.4, 0.05)])
def test_every_object_on_the_counter_is_found_and_localised_to_a_centimetre(
    suite: SensorSuite, distance: float, y: float
) -> None:
    """From near and far (the far view looks through the doorway in the partition)."""
    counter_front = 1.55
    tilt = -math.atan2(0.43 - 0.25, distance + 0.08)
    out = _sense(suite, _qpos(suite, counter_front - distance, y, 0.0, tilt=tilt))
    found = {d.label: d for d in out.camera.detections}
    assert set(found) == {"red mug", "blue bottle", "green apple"}
    for name, detection in found.items():
        error = np.linalg.norm(np.asarray(detection.position) - _truth(suite, name))
        assert error < 0.01, f"{name} off by {error * 100:.1f} cm at {distance} m"
        assert detection.confidence > 0.5


def test_positions_come_from_the_robots_estimate_of_where_it_is(suite: SensorSuite) -> None:
    """On the real robot there is no true pose: a pose estimate 10 cm off moves the detections by 10 cm (when no
    lidar scan corrects it: see the scan matching test)."""
    suite.matcher.reset()
    qpos = _qpos(suite, 0.75, 0.35, 0.0, tilt=-0.2)
    honest = {d.label: np.asarray(d.position) for d in _sense(suite, qpos, lidar=False).camera.detections}
    shifted = {d.label: np.asarray(d.position) for d in _sense(suite, qpos, (0.1, 0.0), lidar=False).camera.detections}
    assert honest.keys() == shifted.keys() and honest
    for name in honest:
        np.testing.assert_allclose(shifted[name] - honest[name], [0.1, 0.0, 0.0], atol=0.004)


def test_a_still_scene_is_not_drawn_again_and_anything_that_moves_is(suite: SensorSuite) -> None:
    """A robot standing still sees the same picture (its sway is ~1e-5 rad a tenth of a second): the frame is sent
    again, as a new frame; a mug moved by 3 cm is drawn, found and placed where it now is."""
    suite.matcher.reset()
    qpos = _qpos(suite, 0.75, 0.35, 0.0, tilt=-0.2)
    first = _sense(suite, qpos, lidar=False).camera
    swayed = qpos.copy()
    swayed[suite.model.joint("l_knee").qposadr[0]] += 2e-5
    again = _sense(suite, swayed, lidar=False).camera
    assert again.seq == first.seq + 1 and first.render_ms > 0 and again.render_ms == 0.0  # not drawn again
    assert again.jpeg == first.jpeg and again.detections == first.detections
    mug = suite.model.body(object_body_name("red mug"))
    moved = swayed.copy()
    moved[suite.model.jnt_qposadr[mug.jntadr[0]] + 1] += 0.03  # its free joint's y
    after = _sense(suite, moved, lidar=False).camera
    assert after.seq == again.seq + 1 and after.render_ms > 0 and after.jpeg != first.jpeg
    before_at = {d.label: np.asarray(d.position) for d in first.detections}["red mug"]
    now_at = {d.label: np.asarray(d.position) for d in after.detections}["red mug"]
    np.testing.assert_allclose(now_at - before_at, [0.0, 0.03, 0.0], atol=0.005)


def test_look_alikes_are_not_labelled_as_objects() -> None:
    """A green plant and a red box in view, and no objects: nothing is reported."""
    base = generate_world(0)
    decoys = (
        Box("plant", 1.0, 0.3, 0.08, 0.08, 0.3, (0.2, 0.5, 0.25, 1.0)),
        Box("red_box", 1.0, 0.75, 0.1, 0.06, 0.22, (0.85, 0.1, 0.1, 1.0)),
        Box("green_block", 1.65, 0.2, 0.02, 0.02, 0.3, (0.2, 0.75, 0.15, 1.0)),  # apple-green, the wrong shape
    )
    layout = dataclasses.replace(base, objects=(), obstacles=decoys)
    decoy_suite = SensorSuite(layout)
    decoy_suite.detector = type(decoy_suite.detector)(
        __import__("robot.perception.detector", fromlist=["catalogue"]).catalogue(base)
    )
    try:
        for x, tilt in ((0.3, -0.35), (0.55, -0.3)):
            out = _sense(decoy_suite, _qpos(decoy_suite, x, 0.45, 0.0, tilt=tilt))
            assert out.camera.detections == ()
    finally:
        decoy_suite.close()


def test_lidar_sees_walls_at_their_distance_and_never_the_robot(suite: SensorSuite) -> None:
    qpos = _qpos(suite, -1.0, -0.5, 0.0)
    out = _sense(suite, qpos)
    scan: LaserScan = out.scan.scan
    assert len(scan.ranges) == 512 and 0.12 < scan.height_m < 0.22
    finite = scan.ranges[np.isfinite(scan.ranges)]
    assert finite.min() > 0.1  # the legs are right there: they are not in the scan
    # the beam pointing straight back (-x) ends at the west wall's inner face, 1.0 m away (unless something is in
    # between: then closer)
    back = int(np.argmin(np.abs(np.abs(scan.angles()) - math.pi)))
    assert scan.ranges[back] <= 1.0 + 0.04


def test_occupancy_grid_marks_free_space_and_the_wall_a_beam_ends_in() -> None:
    spec = GridSpec.around(0.0, 0.0, 4.0, 4.0)
    mapper = OccupancyMapper(spec)
    beams = 64
    ranges = np.full(beams, np.inf, dtype=np.float32)
    ranges[0] = 1.0  # one beam along +x hits something 1 m away
    scan = LaserScan(0.0, 0.0, 2 * math.pi / beams, 0.05, 8.0, ranges, 0.17)
    for _ in range(3):
        mapper.integrate(scan, 0.0, 0.0, 0.0)
    grid = mapper.snapshot()
    i_wall, j = spec.cell(np.array([1.0 + 0.01]), np.array([0.0]))
    i_free, _ = spec.cell(np.array([0.5]), np.array([0.0]))
    i_behind, _ = spec.cell(np.array([1.5]), np.array([0.0]))
    assert grid.occupied()[i_wall[0], j[0]]
    assert grid.free()[i_free[0], j[0]]
    assert not grid.known()[i_behind[0], j[0]]  # nothing is known behind what the beam hit


def test_map_from_a_few_places_agrees_with_the_scene(suite: SensorSuite) -> None:
    layout: WorldLayout = suite.layout
    suite.mapper.clear()
    suite.matcher.reset()
    for x, y, yaw in ((layout.robot_start[0], layout.robot_start[1], 0.0), (1.0, 0.0, 1.0), (-1.0, 0.0, 2.0)):
        for _ in range(3):
            out = _sense(suite, _qpos(suite, x, y, yaw))
    truth = true_occupancy(layout, suite.mapper.spec, out.scan.scan.height_m)
    quality = agreement(suite.map(), truth)
    assert quality.iou > 0.85, quality
    assert quality.precision > 0.95, quality


def test_head_look_at_centres_the_target_in_the_image(suite: SensorSuite) -> None:
    from robot.control.head import HeadController
    from robot.perception.geometry import quat_wxyz_to_matrix

    head = HeadController()
    qpos = _qpos(suite, 0.8, 0.0, 0.4)
    mug = _truth(suite, "red mug") + np.array([0.0, 0.0, 0.025])
    pan, tilt, reachable = head.angles_to_look_at(qpos[0:3], quat_wxyz_to_matrix(qpos[3:7]), mug)
    assert reachable
    out = _sense(suite, _qpos(suite, 0.8, 0.0, 0.4, tilt=tilt, pan=pan))
    camera = out.camera.world_from_camera
    u, v = suite.camera.intrinsics.project(((mug - camera[:3, 3]) @ camera[:3, :3])[None, :])[0]
    assert abs(u - 319.5) < 25 and abs(v - 239.5) < 25  # the camera sits a little off the head's axes
    assert "red mug" in {d.label for d in out.camera.detections}
    # out of the head's reach (behind the robot): it says so, so the body turns instead
    assert not head.angles_to_look_at(qpos[0:3], quat_wxyz_to_matrix(qpos[3:7]), np.array([-1.0, 0.0, 0.3]))[2]


def test_scan_matching_takes_out_odometry_drift() -> None:
    """The robot believes it is 5 cm and 3 cm off where it is: matching its scans to the earlier ones corrects the
    pose the map and the objects are placed with."""
    suite = SensorSuite(generate_world(0))
    try:
        qpos = _qpos(suite, -0.5, -0.45, 0.3)
        for _ in range(12):
            _sense(suite, qpos)
        for _ in range(30):
            out = suite.process(SensorSnapshot(0.0, qpos, qpos[0:3] + np.array([0.05, -0.03, 0.0]), qpos[3:7].copy()))
        correction = out.correction
        assert abs(correction.x + 0.05) < 0.01 and abs(correction.y - 0.03) < 0.01
        truth = _truth(suite, "red mug")
        mug = next(d for d in out.camera.detections if d.label == "red mug")
        assert np.linalg.norm(np.asarray(mug.position) - truth) < 0.015  # placed with the corrected pose
        for _ in range(20):  # and a robot that is where it believes stays put
            out = _sense(suite, qpos)
        assert abs(out.correction.x) < 0.01 and abs(out.correction.y) < 0.01
    finally:
        suite.close()


def _room_scan(
    x: float,
    y: float,
    yaw: float,
    rng: np.random.Generator,
    half: tuple[float, float] = (2.0, 1.5),
    beams: int = 512,
    noise_m: float = 0.01,
) -> LaserScan:
    """A scan from (x, y, yaw) inside a plain walled room centred on the origin, with the lidar's range noise."""
    angles = -math.pi + 2 * math.pi / beams * np.arange(beams)
    c, s = np.cos(angles + yaw), np.sin(angles + yaw)
    with np.errstate(divide="ignore"):
        to_x = np.where(c > 0, (half[0] - x) / c, (-half[0] - x) / c)
        to_y = np.where(s > 0, (half[1] - y) / s, (-half[1] - y) / s)
    ranges = np.minimum(np.abs(to_x), np.abs(to_y)) + rng.standard_normal(beams) * noise_m
    return LaserScan(0.0, -math.pi, 2 * math.pi / beams, 0.1, 12.0, ranges.astype(np.float32), 0.17)


def test_scan_matching_follows_slowly_drifting_odometry_to_a_few_millimetres() -> None:
    """A walk round a room while the odometry drifts 6 cm: the map must not be smeared by a pose that lags the drift.
    The lidar's range noise spreads each wall's returns over a band several cm wide; a likelihood field flat across
    the band let the correction slide in it (33 mm off on average, 51 mm at worst, on this walk)."""
    rng = np.random.default_rng(0)
    matcher = ScanMatcher(GridSpec.around(0.0, 0.0, 6.0, 5.0))
    errors = []
    for k in range(900):
        t = k / 900
        x, y, yaw = 1.2 * math.cos(2 * math.pi * t) - 0.2, 0.8 * math.sin(4 * math.pi * t), 2 * math.pi * t
        odom = (x + 0.06 * t, y - 0.04 * math.sin(math.pi * t), yaw)
        ex, ey, _ = matcher.update(_room_scan(x, y, yaw, rng), odom).apply(*odom)
        errors.append(math.hypot(ex - x, ey - y))
    settled = np.array(errors[100:])
    assert settled.mean() < 0.004 and settled.max() < 0.008


def test_the_mug_is_found_from_where_the_robot_stands_to_grasp_it(suite: SensorSuite) -> None:
    """At the counter's approach pose the mug is 15-20 cm from the camera: nothing may clip it away (MuJoCo's near
    plane scales with the scene's size, and far-parked spare obstacles once pushed it to 0.3 m)."""
    approach = next(p for p in suite.layout.places if p.name == "kitchen counter").approach
    out = _sense(suite, _qpos(suite, approach[0], approach[1], approach[2], tilt=-0.7), lidar=False)
    mug = next(d for d in out.camera.detections if d.label == "red mug")
    assert mug.distance_m < 0.3
    assert np.linalg.norm(np.asarray(mug.position) - _truth(suite, "red mug")) < 0.015


def test_the_sensor_process_yields_the_cpu_to_everything_interactive() -> None:
    """On two cores sensing (the largest consumer) must not delay the browser's or the server's e-stop work."""
    import os

    from robot.perception.sensor_process import SENSOR_NICE, ProcessSensors

    sensors = ProcessSensors(generate_world(0))
    try:
        assert os.sched_getscheduler(sensors.pid) == os.SCHED_BATCH
        assert os.getpriority(os.PRIO_PROCESS, sensors.pid) == SENSOR_NICE
    finally:
        sensors.close()


def test_the_camera_draws_the_same_pixels_without_the_robots_drawn_meshes() -> None:
    """The sensors build their scene without the detailed meshes (~0.7 s and ~340 MB less): the camera does not
    draw them. Looking down at its own raised arm, it sees the same picture either way."""
    import mujoco

    from robot.model import humanoid_v1
    from robot.model.scene import build_scene
    from robot.perception.camera import SimRGBDCamera

    layout = generate_world(1)
    pictures = {}
    for drawn in (True, False):
        model = build_scene(layout, drawn=drawn)
        data = mujoco.MjData(model)
        data.qpos[model.joint("head_tilt").qposadr[0]] = -0.8
        data.qpos[model.joint("r_sho_pitch").qposadr[0]] = 1.2
        mujoco.mj_forward(model, data)
        camera = SimRGBDCamera(model, seed=1)
        pictures[drawn] = camera.capture(data)
        if drawn:  # the meshes are in view: drawn, they would change the picture
            camera.option.geomgroup[humanoid_v1.DETAILED_MESH_GROUP] = 1
            assert not np.array_equal(camera.capture(data).rgb, pictures[drawn].rgb)
        camera.close()
    assert np.array_equal(pictures[True].rgb, pictures[False].rgb)
    assert np.array_equal(pictures[True].depth, pictures[False].depth)
