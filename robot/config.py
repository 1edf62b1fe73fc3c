"""How a robot is run, in one frozen object instead of loose keyword arguments copied through every constructor."""

from __future__ import annotations

from dataclasses import dataclass, field

from robot.diagnostics.thresholds import Thresholds
from robot.planning.config import PlannerConfig
from robot.speech.robot_voice import VoiceConfig


@dataclass(frozen=True)
class RobotConfig:
    """`realtime`: the loop keeps wall-clock time (False: headless, as fast as the machine goes, in simulated
    time); `perception`: the camera, lidar and map; `planning`: which planner turns text into plans;
    `max_auto_replans`: per command, after a failed step; `approve_plans`: plans wait for the operator;
    `voice`: the microphone and speaker (None: no voice); `diagnostics`: the thresholds health is judged by;
    `disk_path`: where the robot's data is kept (its free space is watched)."""

    realtime: bool = True
    control_hz: float = 100.0
    perception: bool = True
    planning: PlannerConfig | None = None
    max_auto_replans: int = 2
    approve_plans: bool = False
    voice: VoiceConfig | None = None
    diagnostics: Thresholds = field(default_factory=Thresholds)
    disk_path: str = "."

    @property
    def dt(self) -> float:
        return 1.0 / self.control_hz
