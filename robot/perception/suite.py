"""The simulated robot's exteroceptive sensors and what is computed from them, in one place.

`SensorSuite.process(snapshot)` takes the simulation's state at one instant (to render and ray-cast the world as
it is) and the robot's *estimated* trunk pose (leg odometry + IMU), and returns a camera frame with its detections
and a lidar scan, and updates the occupancy map. Images and scans are made from the true state, as real sensors
are; where things are in the world is computed from the estimate, as it must be on the real robot.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import cv2
import mujoco
import numpy as np

from robot.model import humanoid_v1
from robot.model.scene import build_scene
from robot.model.world import WorldLayout
from robot.perception.camera import SimRGBDCamera
from robot.perception.detector import Detection, ObjectDetector, catalogue
from robot.perception.geometry import invert, quat_wxyz_to_matrix, transform, yaw_of
from robot.perception.lidar import SimLidar
from robot.perception.localisation import Correction
from robot.perception.occupancy import GridSpec, OccupancyGrid
from robot.perception.scan_mapping import ScanFrame, ScanMapping

JPEG_QUALITY = 80
# A camera frame is drawn again once anything it depends on moved by more than this (m or rad) since the last one
# drawn: a robot standing still sways ~1e-5 per tenth of a second and sees the same picture.
STILL_TOLERANCE = 1e-4
MAP_SIZE_M = (8.0, 8.0)  # a map larger than the apartment, centred where the robot starts


@dataclass(frozen=True)
class SensorSnapshot:
    """The instant to sense: the simulation's full qpos, and the trunk pose the robot believes it has."""

    sim_time_s: float
    qpos: np.ndarray
    trunk_position: np.ndarray  # (3,) estimated, world frame
    trunk_quat: np.ndarray  # (4,) wxyz, estimated
    camera: bool = True
    lidar: bool = True
    mocap_positions: np.ndarray | None = None  # (n, 3) kinematic bodies (dropped obstacles)


@dataclass(frozen=True)
class CameraFrame:
    sim_time_s: float
    seq: int
    width: int
    height: int
    jpeg: bytes
    detections: tuple[Detection, ...]
    world_from_camera: np.ndarray  # 4x4, estimated
    render_ms: float
    detect_ms: float


@dataclass(frozen=True)
class SensorOutput:
    camera: CameraFrame | None = None
    scan: ScanFrame | None = None
    grid: OccupancyGrid | None = None
    correction: Correction = field(default_factory=Correction)  # odometry -> map, from scan matching
    timings_ms: dict[str, float] = field(default_factory=dict)


class SensorSuite:
    def __init__(self, layout: WorldLayout, map_every: int = 5) -> None:
        self.layout = layout
        # the camera sees the world, the gripper and the robot's convex shapes, never its drawn meshes
        # (CAMERA_GEOM_GROUPS): a model without them renders the same pixels, and costs ~0.7 s and ~340 MB less
        self.model = build_scene(layout, drawn=False)
        self.data = mujoco.MjData(self.model)
        self._trunk = self.model.body(humanoid_v1.TRUNK_BODY).id
        self._lidar_site = self.model.site(humanoid_v1.LIDAR_SITE).id
        self.camera = SimRGBDCamera(self.model, seed=layout.seed)
        self.lidar = SimLidar(self.model, seed=layout.seed)
        self.detector = ObjectDetector(catalogue(layout), self.camera.depth_noise_per_m2)
        x, y, _ = layout.robot_start
        self.mapping = ScanMapping(GridSpec.around(round(x, 1), round(y, 1), *MAP_SIZE_M))
        self.mapper = self.mapping.mapper
        self.matcher = self.mapping.matcher
        self._map_every = map_every
        self._seq = 0
        self._last_drawn: tuple[np.ndarray, CameraFrame] | None = None

    def process(self, snapshot: SensorSnapshot) -> SensorOutput:
        data = self.data
        data.qpos[:] = snapshot.qpos
        if snapshot.mocap_positions is not None and snapshot.mocap_positions.size == data.mocap_pos.size:
            data.mocap_pos[:] = snapshot.mocap_positions.reshape(data.mocap_pos.shape)
        data.time = snapshot.sim_time_s
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_camlight(self.model, data)
        # estimated world-from-trunk times the true (encoder) kinematics from the trunk to each sensor
        believed = transform(quat_wxyz_to_matrix(snapshot.trunk_quat), snapshot.trunk_position)
        trunk_true = transform(data.xmat[self._trunk].reshape(3, 3), data.xpos[self._trunk])
        to_odom = believed @ invert(trunk_true)  # true world -> where odometry believes things are
        timings: dict[str, float] = {}
        camera = scan = grid = None
        if snapshot.lidar:
            started = time.perf_counter()
            raw = self.lidar.scan(data)
            mount = transform(data.site_xmat[self._lidar_site].reshape(3, 3), data.site_xpos[self._lidar_site])
            site = to_odom @ mount
            odom_pose = (float(site[0, 3]), float(site[1, 3]), yaw_of(site[:3, :3]))
            scan = self.mapping.add(raw, odom_pose)
            if self.mapper.scans % self._map_every == 1 or self._map_every == 1:
                grid = self.mapper.snapshot()
            timings["lidar_map_ms"] = (time.perf_counter() - started) * 1e3
        if snapshot.camera:
            camera = self._capture_unless_still(self.matcher.correction.matrix() @ to_odom, timings)
        return SensorOutput(camera, scan, grid, self.matcher.correction, timings)

    def _capture_unless_still(self, correction: np.ndarray, timings: dict[str, float]) -> CameraFrame:
        """A new frame, or the last one again when nothing it shows or where it is believed to be has moved (see
        STILL_TOLERANCE): drawing, detecting and encoding an unchanged picture took ~2/3 of the sensor process's
        ~40 % of a core while the robot stood still, CPU the browsers and the e-stop's path need on small
        machines."""
        key = np.concatenate([self.data.qpos, self.data.mocap_pos.ravel(), correction.ravel()])
        last = self._last_drawn
        if last is not None and last[0].shape == key.shape and np.abs(key - last[0]).max() <= STILL_TOLERANCE:
            self._seq += 1
            timings.update(render_ms=0.0, detect_ms=0.0, encode_ms=0.0)
            return replace(last[1], sim_time_s=float(self.data.time), seq=self._seq, render_ms=0.0, detect_ms=0.0)
        frame = self._capture(correction, timings)
        self._last_drawn = (key, frame)
        return frame

    def _capture(self, correction: np.ndarray, timings: dict[str, float]) -> CameraFrame:
        started = time.perf_counter()
        image = self.camera.capture(self.data)
        rendered = time.perf_counter()
        believed_camera = correction @ image.world_from_camera
        detections = self.detector.detect(image.rgb, image.depth, image.intrinsics, believed_camera)
        detected = time.perf_counter()
        ok, jpeg = cv2.imencode(".jpg", image.rgb[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        encoded = time.perf_counter()
        timings.update(
            render_ms=(rendered - started) * 1e3,
            detect_ms=(detected - rendered) * 1e3,
            encode_ms=(encoded - detected) * 1e3,
        )
        self._seq += 1
        return CameraFrame(
            sim_time_s=float(self.data.time),
            seq=self._seq,
            width=image.intrinsics.width,
            height=image.intrinsics.height,
            jpeg=jpeg.tobytes() if ok else b"",
            detections=tuple(detections),
            world_from_camera=believed_camera,
            render_ms=timings["render_ms"],
            detect_ms=timings["detect_ms"],
        )

    def map(self) -> OccupancyGrid:
        return self.mapper.snapshot()

    def close(self) -> None:
        self.camera.close()
