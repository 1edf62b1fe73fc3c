"""The real robot's camera and lidar behind the same `SensorRunner` as the simulated suite, so the perception
service (detections, the world memory, the scan, the map and scan-matching localisation) runs on their frames as
on rendered ones. Each period it takes the drivers' newest image and scan (each at most once), places them with
the robot's kinematics at its estimated trunk pose, detects and maps. A missing or silent sensor gives nothing,
which the perception service and diagnostics see as they see a silent simulated one.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Protocol

import cv2
import mujoco
import numpy as np

from robot.model import humanoid_v1
from robot.model.scene import build_scene
from robot.model.world import WorldLayout
from robot.perception.detector import ObjectDetector, catalogue
from robot.perception.geometry import MUJOCO_TO_OPTICAL, invert, quat_wxyz_to_matrix, transform, yaw_of
from robot.perception.lidar import LaserScan
from robot.perception.occupancy import GridSpec, OccupancyGrid
from robot.perception.pose_history import PoseHistory
from robot.perception.scan_mapping import ScanMapping
from robot.perception.suite import JPEG_QUALITY, MAP_SIZE_M, CameraFrame, SensorOutput, SensorSnapshot
from robot.sensors.camera import CameraImage

LIDAR_SWEEP_S = 0.1  # an LD06 turns at 10 Hz: a scan is stamped when its sweep ends


class ImageSource(Protocol):
    def latest(self) -> CameraImage | None: ...


class ScanSource(Protocol):
    def latest(self) -> LaserScan | None: ...


class DriverSensors:
    def __init__(
        self,
        layout: WorldLayout,
        camera: ImageSource | None,
        lidar: ScanSource | None,
        map_every: int = 5,
    ) -> None:
        self.camera = camera
        self.lidar = lidar
        self.model = build_scene(layout)  # kinematics only: where the head camera and the lidar are
        self.data = mujoco.MjData(self.model)
        self._trunk = self.model.body(humanoid_v1.TRUNK_BODY).id
        self._camera = self.model.camera(humanoid_v1.HEAD_CAMERA).id
        self._lidar_site = self.model.site(humanoid_v1.LIDAR_SITE).id
        self.detector = ObjectDetector(catalogue(layout))
        x, y, _ = layout.robot_start
        self.mapping = ScanMapping(GridSpec.around(round(x, 1), round(y, 1), *MAP_SIZE_M))
        self._map_every = map_every
        self._last_image = -1
        self._last_scan: LaserScan | None = None
        self._lidar_poses = PoseHistory()

    def process(self, snapshot: SensorSnapshot) -> SensorOutput:
        data = self.data
        data.qpos[:] = snapshot.qpos
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_camlight(self.model, data)  # the camera's pose
        believed = transform(quat_wxyz_to_matrix(snapshot.trunk_quat), snapshot.trunk_position)
        trunk = transform(data.xmat[self._trunk].reshape(3, 3), data.xpos[self._trunk])
        to_odom = believed @ invert(trunk)  # the kinematics' world -> where odometry believes things are
        timings: dict[str, float] = {}
        scan_frame = grid = None
        site = to_odom @ transform(data.site_xmat[self._lidar_site].reshape(3, 3), data.site_xpos[self._lidar_site])
        now_pose = (float(site[0, 3]), float(site[1, 3]), yaw_of(site[:3, :3]), float(site[2, 3]))
        self._lidar_poses.add(snapshot.sim_time_s, now_pose)
        scan = self.lidar.latest() if self.lidar is not None and snapshot.lidar else None
        if scan is not None and scan is not self._last_scan:
            self._last_scan = scan
            started = time.perf_counter()
            # where the lidar was mid-sweep (its stamp is the sweep's end), not where it is now
            x, y, yaw, height = self._lidar_poses.at(scan.sim_time_s - LIDAR_SWEEP_S / 2) or now_pose
            scan_frame = self.mapping.add(replace(scan, height_m=height), (x, y, yaw))
            if self.mapping.mapper.scans % self._map_every == 1 or self._map_every == 1:
                grid = self.mapping.mapper.snapshot()
            timings["lidar_map_ms"] = (time.perf_counter() - started) * 1e3
        camera = None
        image = self.camera.latest() if self.camera is not None and snapshot.camera else None
        if image is not None and image.seq != self._last_image:
            self._last_image = image.seq
            pose = transform(data.cam_xmat[self._camera].reshape(3, 3) @ MUJOCO_TO_OPTICAL, data.cam_xpos[self._camera])
            camera = self._frame(image, self.mapping.matcher.correction.matrix() @ to_odom @ pose, timings)
        return SensorOutput(camera, scan_frame, grid, self.mapping.matcher.correction, timings)

    def _frame(self, image: CameraImage, world_from_camera: np.ndarray, timings: dict[str, float]) -> CameraFrame:
        """Detections in 3D need depth: a colour-only camera's frame goes to the page without them."""
        started = time.perf_counter()
        detections = []
        if image.depth is not None:
            detections = self.detector.detect(image.rgb, image.depth, image.intrinsics, world_from_camera)
        detected = time.perf_counter()
        ok, jpeg = cv2.imencode(".jpg", image.rgb[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        timings.update(
            render_ms=0.0, detect_ms=(detected - started) * 1e3, encode_ms=(time.perf_counter() - detected) * 1e3
        )
        return CameraFrame(
            image.stamp_s,
            image.seq,
            image.intrinsics.width,
            image.intrinsics.height,
            jpeg.tobytes() if ok else b"",
            tuple(detections),
            world_from_camera,
            0.0,
            timings["detect_ms"],
        )

    def clear_map(self) -> OccupancyGrid:
        self.mapping.mapper.clear()
        self.mapping.matcher.reset()
        return self.mapping.mapper.snapshot()

    def close(self) -> None:
        """The drivers belong to the body, which stops them."""
