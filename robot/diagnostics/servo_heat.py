"""The servos' temperatures for the robot's own decisions (a behaviour rests before a walk while one is hot), read
from the same readings the diagnostics judge."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot.diagnostics.robot_sources import RobotReadings


class ServoHeatGauge:
    """`ServoHeat` (robot.skills.body) over the robot's readings; `readings` is asked at each read (the
    diagnostics' readings are built after the skills)."""

    def __init__(self, readings: Callable[[], RobotReadings], hot_c: float) -> None:
        self._readings = readings
        self._hot_c = hot_c

    @property
    def hot_c(self) -> float:
        return self._hot_c

    def hottest(self) -> tuple[str, float]:
        readings = self._readings()
        temperatures = np.asarray(readings.servos().temperature_c, dtype=float)
        k = int(np.argmax(temperatures))
        return str(readings.joint_names[k]), float(temperatures[k])
