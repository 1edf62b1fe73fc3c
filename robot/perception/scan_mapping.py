"""Scans to a map, the same for every lidar (the simulated one, or a real LD06 through its driver): each scan is
matched against the map so far to correct the odometry's drift, then added to the occupancy grid at the
corrected pose."""

from __future__ import annotations

from dataclasses import dataclass

from robot.perception.lidar import LaserScan
from robot.perception.localisation import ScanMatcher
from robot.perception.occupancy import GridSpec, OccupancyMapper


@dataclass(frozen=True)
class ScanFrame:
    scan: LaserScan
    pose: tuple[float, float, float]  # the sensor pose (x, y, yaw) the scan was mapped from: odometry, corrected
    odom_pose: tuple[float, float, float]  # the same by odometry alone


class ScanMapping:
    def __init__(self, spec: GridSpec) -> None:
        self.mapper = OccupancyMapper(spec)
        self.matcher = ScanMatcher(spec)

    def add(self, scan: LaserScan, odom_pose: tuple[float, float, float]) -> ScanFrame:
        """One scan taken with the sensor at `odom_pose` (x, y, yaw by odometry): localised, then mapped."""
        correction = self.matcher.update(scan, odom_pose)
        pose = correction.apply(*odom_pose)
        self.mapper.integrate(scan, *pose)
        return ScanFrame(scan, pose, odom_pose)
