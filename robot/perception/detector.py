"""Finds the world's known objects in an RGB-D image and localises them in 3D.

How: colour segmentation in HSV (OpenCV) gives candidate blobs; each blob's pixels are back-projected with the
depth image into the world through the camera pose; a known object model of that colour (a cylinder of known
radius, a sphere, ...) is fitted to those points. The label is given only when the fit and the measured size agree
with the model, so a green plant is never a green apple; the object's position is the fitted model's base centre,
which is where a grasp is planned from.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from robot.model.world import WorldLayout, WorldObject
from robot.perception.geometry import PinholeIntrinsics

# Hue ranges (OpenCV's 0-180 scale) of the colours objects come in; saturation and value floors reject greys,
# wood and walls. Orange (the gripper's fingers) and cyan (the dock) fall between these ranges.
HUE_RANGES: dict[str, tuple[tuple[int, int], ...]] = {
    "red": ((0, 6), (172, 180)),
    "yellow": ((22, 34),),
    "green": ((36, 85),),
    "blue": ((104, 130),),
}
MIN_SATURATION = 110
MIN_VALUE = 40
# An object's pixels must have the hue of its model to within this (OpenCV's 0-180 scale): apple green (55) is
# not plant green (67). Shading changes brightness and saturation, hardly hue.
HUE_TOLERANCE = 8
# Blobs that touch the image border are cut off: their shape cannot be checked, so they are not labelled (the
# head moves on and the next view, which overlaps, sees the whole object).
BORDER_PX = 2
MIN_BLOB_PIXELS = 12  # a fragment (e.g. a handle split off by shading) still joins its object
MIN_OBJECT_PIXELS = 40  # about a mug at 2 m with the D435's field of view
MERGE_DISTANCE_M = 0.06  # fragments of one colour closer than this are one object
# A model fits when the points lie on its surface to within this (m), plus the depth noise at that distance.
MAX_FIT_RMS_M = 0.004
DETECTION_RANGE_M = 3.0


@dataclass(frozen=True)
class ObjectModel:
    """What the detector knows about an object: its colour and the solid it is (sizes in m)."""

    name: str
    colour: str
    shape: str  # "mug" | "bottle" | "apple"
    radius: float
    height: float
    hue: float  # OpenCV scale, 0-180

    @staticmethod
    def of(obj: WorldObject) -> ObjectModel:
        rgb = np.array([[[round(255 * c) for c in obj.rgba[:3]]]], dtype=np.uint8)
        hue = float(cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)[0, 0, 0])
        return ObjectModel(obj.name, obj.color, obj.shape, obj.radius, obj.height, hue)


def catalogue(layout: WorldLayout) -> tuple[ObjectModel, ...]:
    return tuple(ObjectModel.of(o) for o in layout.objects)


@dataclass(frozen=True)
class Detection:
    label: str
    confidence: float  # 0-1, from how well the model fits and how much of it is seen
    box: tuple[int, int, int, int]  # pixels: x0, y0, x1, y1 (inclusive)
    position: tuple[float, float, float]  # world frame: the centre of the object's base
    distance_m: float  # from the camera
    pixels: int

    def to_dict(self) -> dict[str, object]:
        return {
            "label": self.label,
            "confidence": round(self.confidence, 3),
            "box": list(self.box),
            "position": [round(v, 4) for v in self.position],
            "distance_m": round(self.distance_m, 3),
            "pixels": self.pixels,
        }


@dataclass(frozen=True)
class _Fit:
    base: np.ndarray  # (3,)
    rms: float
    height_seen: float
    spread: float  # largest horizontal distance of a point from the axis (or centre)


class ObjectDetector:
    def __init__(self, models: Iterable[ObjectModel], depth_noise_per_m2: float = 0.0) -> None:
        self.models = tuple(models)
        self._depth_noise = depth_noise_per_m2

    def detect(
        self, rgb: np.ndarray, depth: np.ndarray, intrinsics: PinholeIntrinsics, world_from_camera: np.ndarray
    ) -> list[Detection]:
        """Every known object found in the image, best first."""
        hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
        has_depth = (depth > 0).view(np.uint8)
        camera_position = world_from_camera[:3, 3]
        detections: list[Detection] = []
        height, width = depth.shape
        for colour in sorted({m.colour for m in self.models}):
            mask = _colour_mask(hsv, HUE_RANGES.get(colour, ())) & has_depth
            for pixels in _blobs(mask, depth, intrinsics, world_from_camera):
                vs, us = pixels
                if (
                    vs.min() < BORDER_PX
                    or us.min() < BORDER_PX
                    or vs.max() >= height - BORDER_PX
                    or us.max() >= width - BORDER_PX
                ):
                    continue
                hue = _median_hue(hsv[vs, us, 0])
                detection = self._identify(colour, hue, pixels, depth, intrinsics, world_from_camera, camera_position)
                if detection is not None:
                    detections.append(detection)
        detections.sort(key=lambda d: -d.confidence)
        return _one_per_label(detections)

    def _identify(
        self,
        colour: str,
        hue: float,
        pixels: tuple[np.ndarray, np.ndarray],
        depth: np.ndarray,
        intrinsics: PinholeIntrinsics,
        world_from_camera: np.ndarray,
        camera_position: np.ndarray,
    ) -> Detection | None:
        vs, us = pixels
        camera_points = intrinsics.back_project(us.astype(float), vs.astype(float), depth[vs, us])
        points = _to_world(camera_points, world_from_camera)
        distance = float(np.median(np.linalg.norm(points - camera_position, axis=1)))
        if len(us) < MIN_OBJECT_PIXELS or distance > DETECTION_RANGE_M:
            return None
        best: tuple[float, ObjectModel, _Fit] | None = None
        for model in self.models:
            if model.colour != colour or _hue_distance(hue, model.hue) > HUE_TOLERANCE:
                continue
            fit = _fit(model, points, camera_position)
            if fit is None:
                continue
            tolerance = MAX_FIT_RMS_M + 2.0 * self._depth_noise * distance**2
            score = _agreement(model, fit, tolerance)
            if score > 0 and (best is None or score > best[0]):
                best = (score, model, fit)
        if best is None:
            return None
        score, model, fit = best
        seen = min(1.0, len(us) / (2.0 * MIN_OBJECT_PIXELS))
        box = (int(us.min()), int(vs.min()), int(us.max()), int(vs.max()))
        position = (float(fit.base[0]), float(fit.base[1]), float(fit.base[2]))
        return Detection(model.name, round(score * (0.5 + 0.5 * seen), 3), box, position, distance, len(us))


def _median_hue(hues: np.ndarray) -> float:
    """Median of hues on OpenCV's circular 0-180 scale (reds straddle 0)."""
    angles = hues.astype(float) * (2.0 * math.pi / 180.0)
    mean = math.atan2(float(np.mean(np.sin(angles))), float(np.mean(np.cos(angles))))
    offsets = np.angle(np.exp(1j * (angles - mean)))
    return (math.degrees(mean + float(np.median(offsets))) / 2.0) % 180.0


def _hue_distance(a: float, b: float) -> float:
    d = abs(a - b) % 180.0
    return min(d, 180.0 - d)


def _colour_mask(hsv: np.ndarray, hue_ranges: Sequence[tuple[int, int]]) -> np.ndarray:
    """1 where a pixel is saturated and bright enough and its hue is in one of the ranges, else 0 (uint8; OpenCV
    does this ~10x faster than numpy comparisons, and a camera frame is 300k pixels ten times a second)."""
    mask = np.zeros(hsv.shape[:2], dtype=np.uint8)
    for lo, hi in hue_ranges:
        mask |= cv2.inRange(hsv, (lo, MIN_SATURATION, MIN_VALUE), (hi, 255, 255))
    return (mask > 0).view(np.uint8)


def _blobs(
    mask: np.ndarray, depth: np.ndarray, intrinsics: PinholeIntrinsics, world_from_camera: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Pixel index arrays (rows, cols) of each object candidate: connected blobs, fragments merged in 3D.
    Labelling runs on the box around the colour's pixels only: over a whole frame it cost ~2 ms per colour even
    with nothing there, the sensor process's largest single cost."""
    left, top, box_w, box_h = cv2.boundingRect(mask)
    if box_w * box_h < MIN_BLOB_PIXELS:
        return []
    count, labels, stats, _ = cv2.connectedComponentsWithStats(
        mask[top : top + box_h, left : left + box_w], connectivity=8
    )
    fragments: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for label in range(1, count):
        if stats[label, cv2.CC_STAT_AREA] < MIN_BLOB_PIXELS:
            continue
        x, y, w, h = stats[label, :4]
        sub = labels[y : y + h, x : x + w] == label
        vs, us = np.nonzero(sub)
        vs, us = vs + y + top, us + x + left
        centre = _to_world(
            intrinsics.back_project(us.astype(float), vs.astype(float), depth[vs, us]), world_from_camera
        ).mean(axis=0)
        fragments.append((vs, us, centre))
    groups: list[list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = []
    for fragment in sorted(fragments, key=lambda f: -len(f[0])):
        for group in groups:
            if np.linalg.norm(group[0][2] - fragment[2]) < MERGE_DISTANCE_M:
                group.append(fragment)
                break
        else:
            groups.append([fragment])
    return [(np.concatenate([f[0] for f in g]), np.concatenate([f[1] for f in g])) for g in groups]


def _to_world(points_camera: np.ndarray, world_from_camera: np.ndarray) -> np.ndarray:
    return points_camera @ world_from_camera[:3, :3].T + world_from_camera[:3, 3]


def _fit(model: ObjectModel, points: np.ndarray, camera_position: np.ndarray) -> _Fit | None:
    if model.shape == "apple":
        return _fit_sphere(points, model.radius, camera_position)
    return _fit_upright_cylinder(model, points, camera_position)


def _fit_upright_cylinder(model: ObjectModel, points: np.ndarray, camera_position: np.ndarray) -> _Fit | None:
    """An upright cylinder of the model's radius through the points of its side (base height from the lowest
    points); the neck of a bottle, the handle of a mug and the top face are left out of the circle fit."""
    base_z = float(np.percentile(points[:, 2], 1.0))
    h = points[:, 2] - base_z
    body_top = 0.6 if model.shape == "bottle" else 0.9
    side = points[(h > 0.08 * model.height) & (h < body_top * model.height)]
    if len(side) < 10:
        return None
    centre, rms = _fit_circle(side[:, :2], model.radius, camera_position[:2])
    spread = float(np.max(np.linalg.norm(points[:, :2] - centre, axis=1)))
    return _Fit(np.array([centre[0], centre[1], base_z]), rms, float(np.percentile(h, 99.0)), spread)


def _fit_circle(xy: np.ndarray, radius: float, viewpoint: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre of a circle of known radius through 2D points seen from `viewpoint` (Gauss-Newton, trimmed)."""
    away = xy.mean(axis=0) - viewpoint
    centre = xy.mean(axis=0) + (math.pi * radius / 4.0) * away / (np.linalg.norm(away) or 1.0)
    kept = xy
    for iteration in range(12):
        diff = kept - centre
        dist = np.hypot(diff[:, 0], diff[:, 1])
        dist[dist < 1e-9] = 1e-9
        centre = centre + _gauss_newton_step(-diff / dist[:, None], dist - radius)
        if iteration == 4:  # drop what is not on the side (a handle, a stray pixel), then refine
            all_residual = np.abs(np.hypot(xy[:, 0] - centre[0], xy[:, 1] - centre[1]) - radius)
            keep = all_residual < max(0.004, 3.0 * float(np.median(all_residual)))
            kept = xy[keep] if keep.sum() >= 8 else xy
    residual = np.hypot(kept[:, 0] - centre[0], kept[:, 1] - centre[1]) - radius
    return centre, float(np.sqrt(np.mean(residual**2)))


def _gauss_newton_step(jacobian: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """The least-squares step `jacobian @ step = -residual`, by its normal equations (2 or 3 unknowns): `lstsq`'s
    SVD cost ~5x more and ran 10-12 times per fit, per candidate, per frame. Near-degenerate points (all in one
    spot or on one line) fall back to it."""
    normal = jacobian.T @ jacobian
    gradient = -(jacobian.T @ residual)
    if len(normal) == 2:
        a, b, c = float(normal[0, 0]), float(normal[0, 1]), float(normal[1, 1])
        det = a * c - b * b
        if det > 1e-12 * (a + c) ** 2:
            return np.array([(c * gradient[0] - b * gradient[1]) / det, (a * gradient[1] - b * gradient[0]) / det])
    elif abs(np.linalg.det(normal)) > 1e-12 * float(np.trace(normal)) ** 3:
        return np.linalg.solve(normal, gradient)
    step, *_ = np.linalg.lstsq(jacobian, -residual, rcond=None)
    return step


def _fit_sphere(points: np.ndarray, radius: float, camera_position: np.ndarray) -> _Fit | None:
    away = points.mean(axis=0) - camera_position
    centre = points.mean(axis=0) + (math.pi * radius / 4.0) * away / (np.linalg.norm(away) or 1.0)
    for _ in range(10):
        diff = points - centre
        dist = np.linalg.norm(diff, axis=1)
        dist[dist < 1e-9] = 1e-9
        centre = centre + _gauss_newton_step(-diff / dist[:, None], dist - radius)
    residual = np.linalg.norm(points - centre, axis=1) - radius
    base = centre - np.array([0.0, 0.0, radius])
    spread = float(np.max(np.linalg.norm(points[:, :2] - centre[:2], axis=1)))
    height_seen = float(np.percentile(points[:, 2], 99.0) - base[2])
    return _Fit(base, float(np.sqrt(np.mean(residual**2))), height_seen, spread)


def _agreement(model: ObjectModel, fit: _Fit, tolerance: float) -> float:
    """0 when the points cannot be this model; up to 1 for a tight fit of the right size."""
    handle = 0.014 if model.shape == "mug" else 0.0
    if fit.rms > tolerance:
        return 0.0
    if not (0.6 * model.height <= fit.height_seen <= 1.3 * model.height + 0.005):
        return 0.0
    if fit.spread > model.radius + handle + 0.01:
        return 0.0
    return 1.0 - 0.5 * fit.rms / tolerance


def _one_per_label(detections: list[Detection]) -> list[Detection]:
    """Every object is unique in the world: keep the most confident detection of each label."""
    seen: set[str] = set()
    kept = []
    for detection in detections:
        if detection.label not in seen:
            seen.add(detection.label)
            kept.append(detection)
    return kept
