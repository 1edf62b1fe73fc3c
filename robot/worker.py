"""The simulated robot: the robot core (`robot.robot.Robot`) on the MuJoCo body, built from the keyword arguments
the app, the benches and the tests pass."""

from __future__ import annotations

from robot.bodies.sim import SimBody
from robot.config import RobotConfig
from robot.control.locomotion import LocomotionController
from robot.control.stack import build_locomotion
from robot.diagnostics.thresholds import Thresholds
from robot.model.world import WorldLayout
from robot.planning.executor import Capability
from robot.planning.pipeline import PlannerConfig, PlanningPipeline
from robot.planning.planner import Planner
from robot.robot import Robot
from robot.sim.backend import MujocoSimBackend
from robot.speech.robot_voice import VoiceConfig
from robot.tasks.commands import MAX_COMMAND_CHARS

__all__ = ["MAX_COMMAND_CHARS", "RobotWorker"]


class RobotWorker(Robot):
    """The robot in MuJoCo. `backend`: the simulation (default: a new one of `layout`); `planner`: plans alone
    (tests); `planning`: the planners, or their configuration; `locomotion`: the legs' controller (default: the
    gait planner in its own process in real time, its replans hold the interpreter lock); the rest as in
    `RobotConfig`."""

    def __init__(
        self,
        layout: WorldLayout,
        backend: MujocoSimBackend | None = None,
        planner: Planner | None = None,
        planning: PlanningPipeline | PlannerConfig | None = None,
        max_auto_replans: int = 2,
        approve_plans: bool = False,
        capabilities: dict[str, Capability] | None = None,
        realtime: bool = True,
        control_hz: float = 100.0,
        locomotion: LocomotionController | None = None,
        perception: bool = True,
        voice: VoiceConfig | None = None,
        diagnostics: Thresholds | None = None,
        disk_path: str = ".",
    ) -> None:
        config = RobotConfig(
            realtime=realtime,
            control_hz=control_hz,
            perception=perception,
            planning=planning if isinstance(planning, PlannerConfig) else None,
            max_auto_replans=max_auto_replans,
            approve_plans=approve_plans,
            voice=voice,
            diagnostics=diagnostics or Thresholds(),
            disk_path=disk_path,
        )
        body = SimBody(layout, backend, control_hz, perception)
        if locomotion is None:
            locomotion = build_locomotion(body.backend, planner_process=realtime, realtime=realtime)
        pipeline = planning if isinstance(planning, PlanningPipeline) else None
        if planner is not None:  # a given planner plans alone (tests)
            pipeline = PlanningPipeline(planner, planner.name, fallback=None)
        super().__init__(body, layout, config, locomotion=locomotion, planning=pipeline, capabilities=capabilities)
        self.backend = body.backend
