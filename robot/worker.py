"""The robot worker: a fixed-rate control thread and a task thread, behind the `RobotPort` interface.

- The control thread owns the backend (MuJoCo or servos): it reads, computes targets, writes, steps, and
  publishes an immutable `RobotState` every tick. An e-stop wakes it at once, so the controlled stop is applied
  within one tick of the press, not at the next scheduled one.
- The task thread executes plans, one at a time, through the `PlanExecutor`.
- `submit()` is called from any thread (the web server): it plans and validates synchronously, so a bad command
  is refused with reasons and changes nothing.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import queue
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from robot.control.gait import write_placo_model
from robot.control.head import DEFAULT_TILT, HeadController
from robot.control.locomotion import LocomotionController, Velocity, clip_velocity
from robot.control.posture import PostureController
from robot.control.priority import raise_thread_priority
from robot.control.stack import build_locomotion, measured_pose, sensors
from robot.control.stats import LoopStats
from robot.control.whole_body import UPPER_BODY_JOINTS
from robot.diagnostics.robot_sources import RobotDiagnostics, RobotReadings
from robot.diagnostics.thresholds import Thresholds
from robot.events import EventBus, Subscription
from robot.in_process import InProcessPort
from robot.interface import (
    ApprovePlan,
    CancelPlan,
    Command,
    CommandReply,
    DiagnosticArray,
    EStop,
    Event,
    ExecutePlan,
    Fault,
    Footprint,
    InjectFault,
    Level,
    LocomotionState,
    Mode,
    NavigationState,
    ObjectPose,
    OperatorHeartbeat,
    PausePlan,
    PerceptionState,
    PlaceObstacle,
    Plan,
    PlanState,
    PlanStatus,
    Posture,
    PowerState,
    Proprioception,
    Refusal,
    ReleaseEStop,
    Replan,
    ResetRobot,
    ResumePlan,
    RobotDescription,
    RobotState,
    RunCommand,
    SensorFeed,
    SetApproval,
    SetPosture,
    SetTorque,
    StepState,
    StepStatus,
    StopTeleop,
    Teleop,
)
from robot.manipulation.arm_motion import ArmMotion, Move
from robot.manipulation.grasp_plan import grasp_stance
from robot.manipulation.pick import PickFailed, pick
from robot.manipulation.place import PlaceFailed, choose_spot, spots_in_reach
from robot.manipulation.place import place as place_held
from robot.manipulation.reach_ik import ReachIK
from robot.model import humanoid_v1
from robot.model.scene import scene_xml
from robot.model.world import ROBOT_RADIUS, Place, WorldLayout
from robot.navigation.costmap import Costmap
from robot.navigation.follower import MAX_FORWARD_M_S
from robot.navigation.goal import parse_pose_goal
from robot.navigation.navigator import (
    CARRYING_CLEARANCE_M,
    CLEARANCE_M,
    OPEN_M_S,
    NavigationFailed,
    Navigator,
    StopDrift,
)
from robot.perception.geometry import matrix_to_quat_wxyz, yaw_of
from robot.perception.search import ObjectNotFound, find_object
from robot.perception.sensor_process import SensorError
from robot.perception.service import SENSOR_HZ, PerceptionService
from robot.planning.context import ConversationMemory, PlanningContext
from robot.planning.executor import (
    Cancelled,
    Capability,
    ExecutionContext,
    PlanExecutor,
    StepFailed,
    default_capabilities,
)
from robot.planning.pipeline import PlannerConfig, PlanningPipeline, PlanResult, build_pipeline
from robot.planning.planner import Planner, PlanningError
from robot.planning.validator import validate_plan_json
from robot.planning.world_context import WorldContext
from robot.power.battery import Battery, ServoElectrical
from robot.sim.backend import Measurements, MujocoSimBackend, SimulationDiverged
from robot.sim.servo_model import SimulatedServos
from robot.simple_actions import SimpleActions
from robot.speech.robot_voice import RobotVoice, VoiceConfig
from robot.state_board import StateBoard
from robot.task_bodies import ArmBody, NavBodyOfWorker, TaskBody, carry_back_away_m
from robot.telemetry import TelemetryBatch, TelemetryLayout, TelemetrySampler

log = logging.getLogger(__name__)

MAX_COMMAND_CHARS = 500
# When the loop falls this many ticks behind, it stops trying to catch up (sim time would race wall time).
MAX_TICKS_BEHIND = 5
# Deadman: teleop motion stops when no teleop command has arrived for this long (s).
TELEOP_TIMEOUT_S = 0.3
CONVERTER_DROPOUT_V = 1.0  # the 12 V converter needs this much headroom over its output


def _step_summary(steps: tuple[StepStatus, ...]) -> list[dict[str, str]]:
    return [{"action": s.action, "state": s.state.value, "detail": s.detail} for s in steps]


def _failure_of(job: _Job) -> tuple[str | None, tuple[str, ...]]:
    """A failed plan's first failed step and reason, and the steps done before it, for a replanner."""
    steps = job.status.steps
    failed = next((s for s in steps if s.state == StepState.FAILED), None)
    if failed is None:
        return None, ()
    done = tuple(f"{s.action}({', '.join(s.args.values())})" for s in steps if s.state == StepState.SUCCEEDED)
    return f"step {failed.index + 1} {failed.action} failed: {failed.detail}", done


@dataclass
class _Job:
    status: PlanStatus
    plan: Plan
    cancel: threading.Event
    fault: str | None = None  # set with `cancel` when a fault (a fall) stopped the plan
    pausing: bool = False  # set with `cancel` when the operator paused the plan
    start: int = 0  # the step to start from (a resumed plan goes on from its paused step)


# How fast the legs go from the walk's last posture to the standing one (rad/s): 0.34 rad in ~0.85 s when carrying.
WALK_TO_STAND_SPEED_RAD_S = 0.4


class RobotWorker(InProcessPort):
    """Runs the robot. Use `start()`, then talk to it only through the `RobotPort` methods."""

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
        """`diagnostics`: the thresholds the robot's health is judged by; `disk_path`: where its data is kept."""
        self.layout = layout
        self.backend = backend or MujocoSimBackend(layout)
        self._planner_config = planning if isinstance(planning, PlannerConfig) else None
        if isinstance(planning, PlannerConfig) or planning is None:
            planning = build_pipeline(planning or PlannerConfig())
        if planner is not None:  # a given planner plans alone (tests)
            planning = PlanningPipeline(planner, planner.name, fallback=None)
        self.planning = planning
        self.max_auto_replans = max_auto_replans
        self._memory = ConversationMemory()
        self._auto_replans: dict[int, int] = {}  # command id -> automatic replans so far
        self.realtime = realtime
        self.control_hz = control_hz
        self.dt = 1.0 / control_hz
        self._bus = EventBus(sim_clock=lambda: self._sim_time)
        self._stats = LoopStats(control_hz)
        if locomotion is None:
            # the gait planner runs in its own process in real time (its replans hold the interpreter lock)
            locomotion = build_locomotion(self.backend, planner_process=realtime)
        self._loco = locomotion
        self._stand = self._loco.stand_targets  # the walk-ready stance: every walk starts and ends in it
        self.backend.reset(self._stand)
        self._posture = PostureController(self._stand)
        self._posture_name = Posture.STAND
        self._measured = self.backend.read()
        self._targets = self._stand.copy()
        self._loco.reset_odometry(measured_pose(self._measured), sensors(self._measured))

        self._lock = threading.RLock()  # guards the fields below
        self._estop_latched = False
        self._estop_pending: tuple[EStop, float] | None = None
        self._fallen = False
        self._held_object: str | None = None
        self._stop_drift = StopDrift()  # what stopping a walk does to the pose, learnt by every final approach
        self._current_job: _Job | None = None
        self._finished_job: _Job | None = None  # the last plan that ran, shown until the next one starts
        self._held_job: _Job | None = None  # a plan awaiting approval, or a paused one
        self._approval_required = approve_plans
        self._last_command: tuple[int, str] | None = None  # (command_id, text) of the command being served
        self._next_command_id = 1
        self._next_plan_id = 1
        self._revisions: dict[int, int] = {}
        self._teleop_active = False
        self._teleop_velocity = Velocity()
        self._teleop_deadline: float | None = None
        self._stop_promptly = False  # operator let go: stop without first walking off the pose loop's lag
        self._reset_pending = False
        self._obstacles_pending: list[tuple[float, float]] = []
        self._navigation: NavigationState | None = None
        self._head = HeadController(start=(float(self._stand[_HEAD_PAN]), float(self._stand[_HEAD_TILT])))
        self._task_velocity = Velocity()  # what a running plan step asks the legs for (turning to look)
        self._arm: ArmMotion | None = None  # whole-body reaching; built on first use (placo loads a model)
        self._arm_active = False  # the arm motion owns the joints (reaching, grasping, standing up)
        # The arm finishes its queued moves on its own (stowing after a place), then the control thread hands the
        # joints back: the robot's next body step waits for that.
        self._arm_finishing = False
        self._default_stand = self._stand.copy()
        self._perception = PerceptionService(layout, self._board_latest, self._bus.publish) if perception else None
        self._executor = PlanExecutor(capabilities or self._capabilities())

        self._jobs: queue.Queue[_Job | None] = queue.Queue()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._sim_time = 0.0
        self._board = StateBoard()
        self._threads: list[threading.Thread] = []
        self._description: RobotDescription | None = None
        self._voice_config = voice
        self._voice: RobotVoice | None = None  # the robot's microphone and speaker, opened on start
        self._servos = ServoElectrical()
        self._battery = Battery()
        self._servo_model = SimulatedServos(self.backend.joint_names, np.array(humanoid_v1.servo_torque_per_unit()))
        self._stall_s = 0.0  # injected fault: the next tick hangs this long
        self._kick_pending = False  # injected fault: the physics is made to diverge on the next tick
        self._raise_ticks = 0  # injected fault: this many ticks raise, as a controller bug would
        self._last_tick_error: tuple[str, float] = ("", 0.0)  # what the last failing tick said, and when
        self._diagnostics = RobotDiagnostics(
            RobotReadings(
                joint_names=self.backend.joint_names, stats=self._stats, servos=self._servo_model.readings,
                power=lambda: self._board.latest().power, battery_cells=self._battery.spec.cells,
                perception=self._perception_state, sensor_feed=self.sensor_feed, sim_time=lambda: self._sim_time,
                imu_stamp=lambda: self._measured.imu_stamp_s, voice=lambda: self._voice, sensor_hz=SENSOR_HZ,
            ),
            diagnostics or Thresholds(), realtime, disk_path, self._planner_config, self.planning.describe(),
            self._bus.publish, self._safe_stop,
        )  # fmt: skip
        layout_of = TelemetryLayout.for_robot(tuple(self.backend.joint_names), self.backend.qpos().size,
                                              self.backend.mocap_positions().shape[0])  # fmt: skip
        self._telemetry = TelemetrySampler(layout_of, control_hz)
        self._publish_state(self.backend.read())

    # ----------------------------------------------------------------------------------------------------------
    # lifecycle

    def start(self) -> None:
        if self._threads:
            return
        if self.realtime:
            # the control thread must never wait long for the interpreter lock behind another thread (perception,
            # the task thread): the default switch interval is 5 ms, half a control period
            sys.setswitchinterval(min(sys.getswitchinterval(), 0.0005))
        self._stop.clear()
        self._threads = [
            threading.Thread(target=self._control_loop, name="robot-control", daemon=True),
            threading.Thread(target=self._task_loop, name="robot-tasks", daemon=True),
        ]
        for thread in self._threads:
            thread.start()
        if self._perception is not None:
            self._perception.start()
        self._diagnostics.start()
        if self._voice_config is not None:
            world = self._world_context()
            self._voice = RobotVoice(
                self._voice_config,
                world.objects,
                world.places,
                self._bus.publish,
                lambda text: self.submit(RunCommand(text)),
                self._bus.subscribe,
                estop=lambda: self.submit(EStop(source="voice")),
            )
            self._voice.start()
        self._bus.publish("worker/started", f"robot worker started ({'real time' if self.realtime else 'headless'})")

    def is_alive(self) -> bool:
        return bool(self._threads) and all(t.is_alive() for t in self._threads)

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        with self._lock:
            if self._current_job:
                self._current_job.cancel.set()
        self._jobs.put(None)
        for thread in self._threads:
            thread.join(timeout=5.0)
        self._threads = []
        self._diagnostics.stop()
        if self._voice is not None:
            self._voice.stop()
            self._voice = None
        if self._perception is not None:
            self._perception.stop()
        self._loco.walking.planner.close()

    # ----------------------------------------------------------------------------------------------------------
    # RobotPort

    def submit(self, command: Command) -> CommandReply:
        if isinstance(command, EStop):
            return self._latch_estop(command)
        if isinstance(command, ReleaseEStop):
            return self._release_estop(command)
        if isinstance(command, CancelPlan):
            return self._cancel_plan("cancelled by operator")
        if isinstance(command, ApprovePlan):
            return self._approve_plan(command)
        if isinstance(command, PausePlan):
            return self._pause_plan()
        if isinstance(command, ResumePlan):
            return self._resume_plan()
        if isinstance(command, SetApproval):
            return self._set_approval(command.required)
        if isinstance(command, RunCommand):
            return self._run_command(command)
        if isinstance(command, ExecutePlan):
            return self._execute_plan(command)
        if isinstance(command, Replan):
            return self._replan()
        if isinstance(command, Teleop):
            return self._teleop(command)
        if isinstance(command, StopTeleop):
            return self._stop_teleop(command.source, "stopped")
        if isinstance(command, SetPosture):
            return self._set_posture(command.posture)
        if isinstance(command, ResetRobot):
            return self._reset_robot()
        if isinstance(command, PlaceObstacle):
            return self._place_obstacle(command)
        if isinstance(command, InjectFault):
            return self._inject_fault(command)
        if isinstance(command, SetTorque):
            return CommandReply(False, "the simulated servos are always powered: torque is for the real robot",
                                Refusal.UNSUPPORTED)  # fmt: skip
        if isinstance(command, OperatorHeartbeat):
            return CommandReply(True, "operator present (the simulation has no torque to keep on)")
        return CommandReply(False, f"unknown command type {type(command).__name__}", Refusal.INVALID)

    def state(self) -> RobotState:
        return self._board.latest()

    def announce(self, kind: str, message: str, level: Level = Level.OK, **data: Any) -> Event:
        """An event from the server about the robot (e.g. a refused 3D-view click), said like the robot's own."""
        return self._bus.publish(kind, message, level, **data)

    def subscribe(self) -> Subscription:
        return self._bus.subscribe()

    def recent_events(self) -> list[Event]:
        return self._bus.history()

    def sensor_feed(self) -> SensorFeed:
        return self._perception.feed() if self._perception is not None else SensorFeed()

    def telemetry_since(self, seq: int) -> TelemetryBatch | None:
        return self._telemetry.ring.since(seq)

    def diagnostics(self) -> DiagnosticArray | None:
        return self._diagnostics.latest()

    def sample_diagnostics(self) -> DiagnosticArray:
        """Sample every diagnostic now (headless runs and tests; a running worker samples once a second)."""
        return self._diagnostics.monitor.sample()

    def describe(self) -> RobotDescription:
        if self._description is None:
            self._description = RobotDescription(
                model_name=humanoid_v1.MODEL_NAME,
                seed=self.layout.seed,
                mjcf_xml=scene_xml(self.layout),
                joint_names=tuple(self.backend.joint_names),
                places=self.layout.place_names,
                objects=self.layout.object_names,
                control_hz=self.control_hz,
                physics_hz=1.0 / self.backend.physics_dt,
                planner=self.planning.describe(),
                telemetry_layout=self._telemetry.layout.to_json(),
                telemetry_hz=self._telemetry.rate_hz,
            )
        if self._voice is None:
            return self._description
        return replace(self._description, microphone=self._voice.microphone_status, speaker=self._voice.speaker_status)

    # ----------------------------------------------------------------------------------------------------------
    # what plan steps can do

    def _capabilities(self) -> dict[str, Capability]:
        capabilities = default_capabilities()
        capabilities["detect_object"] = self._detect_object
        capabilities["navigate_to"] = self._navigate_to
        capabilities["pick_object"] = self._pick_object
        capabilities["place_object"] = self._place_object
        simple = SimpleActions(
            navigate=self._navigate_to,
            search_body=lambda ctx: TaskBody(self, ctx),
            robot_at_rest=lambda: not self._loco.moving and not self._arm_active,
            known_objects=lambda: self._perception.memory.snapshot() if self._perception is not None else (),
            robot_position=lambda: tuple(self._map_trunk()[0][:2]),
            home=self.layout.robot_start,
            has_camera=self._perception is not None,
        )
        capabilities["wait"] = simple.wait
        capabilities["stop"] = simple.stop
        capabilities["go_home"] = simple.go_home
        capabilities["look_around"] = simple.look_around
        capabilities["describe_scene"] = simple.describe_scene
        for action in ("detect_object", "navigate_to", "pick_object", "place_object", "go_home", "look_around"):
            capabilities[action] = self._after_arm_finished(capabilities[action])
        return capabilities

    def _pick_object(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """Stand where the object is in the right hand's reach, grasp it with contacts only, lift it and check it
        rose with the hand; then stand up holding it, ready to walk."""
        if self._perception is None:
            raise StepFailed("picking needs the camera, and perception is off in this worker")
        name = self._world_context().resolve_object(args["object"]) or args["object"]
        obj = next((o for o in self.layout.objects if o.name == name), None)
        if obj is None:
            raise StepFailed(f"unknown object {args['object']!r}")
        with self._lock:
            held = self._held_object
        if held is not None:
            raise StepFailed(f"already holding the {held}: place it first")
        try:
            report = pick(name, obj.height, ArmBody(self, ctx))
        except PickFailed as exc:
            raise StepFailed(str(exc)) from exc
        finally:
            self._set_task_velocity(Velocity())
            self._set_navigation(None)
        with self._lock:
            self._held_object = name
        self._bus.publish("manipulation/picked", f"holding the {name}", name=name, grip_mm=report.grip_m * 2000,
                          rise_m=report.rise_m, stance_corrections=report.stance_corrections)  # fmt: skip
        return f"holding the {name}: lifted {report.rise_m * 100:.1f} cm, gripper {report.grip_m * 2000:.0f} mm open"

    def _place_object(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """Put the held object down on a named surface, at a free spot in front of the robot, and check it stands
        there."""
        if self._perception is None:
            raise StepFailed("placing needs the camera, and perception is off in this worker")
        with self._lock:
            held = self._held_object
        if held is None:
            raise StepFailed("not holding anything to place")
        name = self._world_context().resolve_place(args["location"])
        place = next((p for p in self.layout.places if p.name == name), None)
        if place is None:
            raise StepFailed(f"unknown place {args['location']!r}")
        obj = next(o for o in self.layout.objects if o.name == held)
        # a free spot in reach from where the robot stopped, else the one in front of the place (walking there)
        spot = self._place_spot_here(place, held, ArmBody(self, ctx))
        if spot is None:
            spot = self._place_spot(place, held)
        if spot is None:
            raise StepFailed(f"unreachable: no free spot on the {place.name} in front of the robot")
        try:
            report = place_held(held, obj.height, spot, place.approach[2], ArmBody(self, ctx))
        except (PlaceFailed, PickFailed) as exc:
            raise StepFailed(str(exc)) from exc
        finally:
            self._set_task_velocity(Velocity())
            self._set_navigation(None)
        with self._lock:
            self._held_object = None
        x, y, _ = report.position
        self._bus.publish("manipulation/placed", f"put the {held} on the {place.name}", name=held, place=place.name,
                          position=list(report.position), error_m=report.error_m,
                          stance_corrections=report.stance_corrections)  # fmt: skip
        return f"put the {held} on the {place.name} at ({x:.2f}, {y:.2f}), {report.error_m * 100:.1f} cm from the spot"

    def _place_spot(self, place: Place, held: str) -> np.ndarray | None:
        """Where on the place's surface to put the held object, seen from the place's approach: free of what the
        robot remembers standing there."""
        if place.surface is None:
            return None
        return choose_spot(place.surface, place.approach, self._occupied_except(held))

    def _place_spot_here(self, place: Place, held: str, arm: ArmBody) -> np.ndarray | None:
        """A free spot on the place's surface comfortably in the hand's reach from where the robot stands, if any."""
        if place.surface is None:
            return None
        position, rotation = self._map_trunk()
        pose = (float(position[0]), float(position[1]), yaw_of(rotation))
        spots = spots_in_reach(place.surface, pose, self._occupied_except(held))
        return next((spot for spot in spots if arm.comfortably_reaches(spot)), None)

    def _occupied_except(self, held: str) -> list[tuple[float, float]]:
        """Where the objects the robot remembers stand (map, m), but the one it holds."""
        assert self._perception is not None
        return [k.position[:2] for k in self._perception.memory.snapshot() if k.name != held]

    def _arm_motion(self) -> ArmMotion:
        if self._arm is None:
            self._arm = ArmMotion(ReachIK(write_placo_model(), self.dt), self.dt)
        return self._arm

    def _take_arm(self) -> ArmMotion:
        """Give the joints to the arm motion, starting from what is commanded now (the robot standing still)."""
        arm = self._arm_motion()
        with self._lock:
            if not self._arm_active:
                arm.start(self._targets.copy(), "right")
                self._arm_active = True
        return arm

    def _finish_arm_in_background(self, moves: list[Move]) -> None:
        """Play `moves` on the arm without waiting, then stand with the arms in the default posture."""
        arm = self._take_arm()
        with self._lock:
            arm.queue(*moves)
            self._arm_finishing = True

    def _wait_arm_finished(self, cancel: threading.Event) -> None:
        """Block until an arm left finishing in the background has handed the joints back and the robot stands."""
        waited = False
        while True:
            with self._lock:
                if self._fallen or not (self._arm_finishing or waited):
                    return  # a step sees a fall itself
                if not self._arm_finishing and self._posture.settled:
                    return
            waited = True
            self._wait_sim(0.02, cancel)

    def _after_arm_finished(self, capability: Capability) -> Capability:
        """The capability, run once the arm has finished what it was left doing (it needs the joints)."""

        def run(args: dict[str, str], ctx: ExecutionContext) -> str:
            self._wait_arm_finished(ctx.cancel)
            return capability(args, ctx)

        return run

    def _release_arm(self, upper_body: np.ndarray | None) -> None:
        """Hand the joints back to the posture controller and walking: with the upper body held as in
        `upper_body` (carrying), or in the default standing posture."""
        arm = self._arm_motion()
        stand = self._default_stand.copy()
        upper = [humanoid_v1.JOINT_NAMES.index(n) for n in UPPER_BODY_JOINTS]
        if upper_body is not None:
            stand[upper] = upper_body[upper]
        self._loco.walking.ik.set_upper_body(dict(zip(humanoid_v1.JOINT_NAMES, stand, strict=True)))
        with self._lock:
            self._stand = stand
            self._posture.hold(arm.targets)
            self._posture.move_to(stand)
            self._arm_active = False

    def _navigate_to(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """Walk to a named place: a planned path to the open floor in front of it, then a short precise approach."""
        if self._perception is None:
            raise StepFailed("navigation needs the lidar's map, and perception is off in this worker")
        name = self._world_context().resolve_place(args["target"])
        place = next((p for p in self.layout.places if p.name == name), None)
        pose = parse_pose_goal(args["target"]) if place is None else None
        if place is None and pose is None:
            raise StepFailed(f"unknown place {args['target']!r}")
        self._head.point(0.0, DEFAULT_TILT)  # look ahead and down while walking
        try:
            navigator = self._navigator(ctx)
            if pose is not None:  # a pose on the map: walk there, then turn to its heading if it has one
                costmap = NavBodyOfWorker(self, ctx).costmap(ROBOT_RADIUS)
                if costmap is not None and costmap.blocked_at(pose.x, pose.y):
                    raise StepFailed(f"unreachable: ({pose.text()}) is in or against an obstacle on the map")
                final = None if pose.yaw is None else (pose.x, pose.y, pose.yaw)
                report = navigator.go((pose.x, pose.y), final, back_away_m=self._back_away_m(ctx))
            else:
                assert place is not None
                # whether a stop will do for the work there, by the latest answer (the navigator asks on the way)
                work: list[Callable[[], bool] | None] = [None]

                def work_pose() -> tuple[float, float, float]:
                    stance, work[0] = self._work_pose(place, ctx)
                    return stance

                def in_reach() -> bool:
                    good_stop = work[0]
                    return good_stop is not None and good_stop()

                report = navigator.go(place.staging, work_pose, in_reach, self._back_away_m(ctx))
        except NavigationFailed as exc:
            raise StepFailed(str(exc)) from exc
        finally:
            self._set_task_velocity(Velocity())
            self._set_navigation(None)
        replans = f", {report.replans} replan{'s' if report.replans != 1 else ''}" if report.replans else ""
        where = f"the {place.name}" if place is not None else f"({pose.text()})" if pose is not None else ""
        self._bus.publish("navigation/arrived", f"at {where}", place=place.name if place else None,
                          goal=pose.text() if pose else None, walked_m=report.walked_m, replans=report.replans,
                          error_m=report.final_error_m, sim_s=report.sim_s,
                          path=[list(p) for p in report.path])  # fmt: skip
        return (
            f"at {where}: walked {report.walked_m:.2f} m in {report.sim_s:.0f} s{replans}, "
            f"{report.final_error_m * 100:.1f} cm and {report.final_heading_error_deg:.0f} deg from the goal"
        )

    def _back_away_m(self, ctx: ExecutionContext) -> float:
        """How far to walk back before setting off: carrying something held out over a surface, the robot would
        sweep it along the surface as it turns away (the walk backs away first, without stopping)."""
        if self._held_object is None:
            return 0.0
        return carry_back_away_m(self.layout, NavBodyOfWorker(self, ctx).pose())

    def _navigator(self, ctx: ExecutionContext) -> Navigator:
        """A navigator on this robot's legs and map, sharing what its stops have taught (`StopDrift`), keeping a wider
        berth from obstacles while it carries something."""
        carrying = self._held_object is not None
        clearance = CARRYING_CLEARANCE_M if carrying else CLEARANCE_M
        speed = MAX_FORWARD_M_S if carrying else OPEN_M_S
        return Navigator(NavBodyOfWorker(self, ctx), lambda: self._sim_time, self._set_navigation, self._stop_drift,
                         clearance, speed)  # fmt: skip

    def _work_pose(self, place: Place, ctx: ExecutionContext,
                   ) -> tuple[tuple[float, float, float], Callable[[], bool] | None]:  # fmt: skip
        """Where to stop at a place, and whether a stop will do for the work there (asked at each stop: the camera
        keeps refining an object's position on the way): if the plan next picks an object seen there, the stance with
        it in reach, and a stop that has it comfortably in reach will do; if it next puts something down there, the
        stance for a free spot, and a stop with any free spot in reach will do (saves correction walks at the
        surface); otherwise the place's own approach pose, and nothing."""
        assert self._perception is not None
        arm = ArmBody(self, ctx)
        for step in ctx.upcoming:
            if step.action == "navigate_to":
                break
            if step.action == "place_object":
                held = self._held_object or ""
                spot = self._place_spot(place, held)
                if spot is not None and self._world_context().resolve_place(step.args["location"]) == place.name:
                    stance = grasp_stance((float(spot[0]), float(spot[1])), place.approach[2])
                    return (stance.x, stance.y, stance.yaw), functools.partial(self._has_spot_here, place, held, arm)
                continue
            if step.action != "pick_object" or place.surface is None:
                continue
            name = self._world_context().resolve_object(step.args["object"]) or step.args["object"]
            remembered = self._perception.memory.get(name)
            if remembered is not None and place.surface.contains(*remembered.position[:2]):
                stance = grasp_stance(remembered.position[:2], place.approach[2], self._map_blocked())
                return (stance.x, stance.y, stance.yaw), functools.partial(self._remembered_in_reach, name, arm)
        return place.approach, None

    def _has_spot_here(self, place: Place, held: str, arm: ArmBody) -> bool:
        return self._place_spot_here(place, held, arm) is not None

    def _remembered_in_reach(self, name: str, arm: ArmBody) -> bool:
        point = self._remembered_position(name)
        return point is not None and arm.comfortably_reaches(point)

    def _remembered_position(self, name: str) -> np.ndarray | None:
        assert self._perception is not None
        known = self._perception.memory.get(name)
        return None if known is None else np.asarray(known.position, dtype=float)

    def _map_blocked(self) -> Callable[[float, float], bool] | None:
        """Whether a map point is taken on the lidar map (obstacles not grown); None before the first map."""
        grid = self._perception.feed().map if self._perception is not None else None
        return None if grid is None else Costmap.from_map(grid, 0.0).blocked_at

    def _detect_object(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """Look for the object (head, then body); found: its 3D position goes into the world memory."""
        if self._perception is None:
            raise StepFailed("perception is off in this worker")
        name = self._world_context().resolve_object(args["object"]) or args["object"]
        remembered = self._perception.memory.get(name)
        believed = remembered.position if remembered else self._expected_position(name)
        try:
            result = find_object(name, TaskBody(self, ctx), believed, ctx.check_cancelled)
        except ObjectNotFound as exc:
            raise StepFailed(str(exc)) from exc
        except SensorError as exc:
            raise StepFailed(f"camera unavailable: {exc}") from exc
        finally:
            self._set_task_velocity(Velocity())
        found = result.detection
        x, y, z = found.position
        place = self._perception.memory.place_of(found.position)
        where = f" on the {place}" if place and place != "floor" else ""
        self._bus.publish("perception/object_found", f"found the {name} at ({x:.3f}, {y:.3f}, {z:.3f}){where}",
                          name=name, position=list(found.position), distance_m=found.distance_m,
                          confidence=found.confidence, views=result.views)  # fmt: skip
        return f"found {name} at ({x:.3f}, {y:.3f}, {z:.3f}) m, {found.distance_m:.2f} m away{where}"

    def _expected_position(self, name: str) -> tuple[float, float, float] | None:
        """Where the world model says an object should be: the middle of the place it is on (not where it is)."""
        place = self._world_context().object_locations.get(name)
        for p in self.layout.places:
            if p.name == place and p.surface is not None:
                return (p.surface.x, p.surface.y, p.surface.height)
        return None

    def _set_navigation(self, navigation: NavigationState | None) -> None:
        with self._lock:
            self._navigation = navigation

    def _set_task_velocity(self, velocity: Velocity) -> None:
        with self._lock:
            self._task_velocity = velocity

    def _estimated_trunk(self) -> tuple[np.ndarray, np.ndarray]:
        """The trunk's pose by leg odometry and the IMU (the frame perception is given)."""
        odometry = self._loco.odometry
        return odometry.position.copy(), odometry.rotation.copy()

    def _map_trunk(self) -> tuple[np.ndarray, np.ndarray]:
        """The trunk's pose in the map (odometry corrected by scan matching): the frame of detected objects."""
        position, rotation = self._estimated_trunk()
        if self._perception is None:
            return position, rotation
        x, y, yaw = self._perception.localise(float(position[0]), float(position[1]), yaw_of(rotation))
        turn = yaw - yaw_of(rotation)
        c, s = math.cos(turn), math.sin(turn)
        about_z = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return np.array([x, y, position[2]]), about_z @ rotation

    # ----------------------------------------------------------------------------------------------------------
    # helpers for headless runs and tests

    def _board_latest(self) -> RobotState:
        return self._board.latest()

    def wait_for(self, predicate: Callable[[RobotState], bool], timeout_s: float) -> bool:
        """Block until `predicate(state)` holds or the wall-clock timeout passes."""
        return self._board.wait_for(predicate, timeout_s)

    # ----------------------------------------------------------------------------------------------------------
    # e-stop

    def _latch_estop(self, command: EStop) -> CommandReply:
        received = time.time()
        with self._lock:
            if self._estop_latched:
                return CommandReply(True, "e-stop already latched")
            self._estop_latched = True
            self._estop_pending = (command, received)
            job = self._current_job
            if job:
                job.cancel.set()
            self._drain_queued_jobs("cancelled by e-stop")
        self._wake.set()  # the control thread applies the stop now, not at its next tick
        return CommandReply(True, "e-stop latched")

    def _apply_pending_estop(self) -> None:
        """Control thread: the controlled stop. Every joint holds its current reference; the plan is cancelled."""
        with self._lock:
            pending, self._estop_pending = self._estop_pending, None
        if pending is None:
            return
        command, received = pending
        self._teleop_velocity, self._teleop_deadline = Velocity(), None
        self._head.freeze()
        with self._lock:
            if self._arm_active and self._arm is not None:  # the arm stops where it is commanded now
                self._arm.stop()
                self._posture.hold(self._arm.targets)
                self._arm_active = False
                self._arm_finishing = False
        walking = self._loco.moving
        if walking:
            # a biped mid-stride cannot freeze its joints: it finishes the step and puts its feet together
            self._loco.stop(promptly=True)
        else:
            self.backend.write(self._posture.freeze())
        applied = time.time()
        data: dict[str, Any] = {"source": command.source, "worker_latency_ms": (applied - received) * 1e3}
        if command.relayed_at_s is not None:
            data["server_latency_ms"] = (applied - command.relayed_at_s) * 1e3
        if command.client_time_s is not None:
            data["latency_ms"] = (applied - command.client_time_s) * 1e3
        action = "stopping the walk, then holding" if walking else "holding position"
        why = f" because {command.reason}" if command.reason else ""
        if command.reason:
            data["reason"] = command.reason
        self._bus.publish("estop/latched", f"E-STOP latched ({command.source}){why}: {action}", Level.ERROR, **data)
        self._publish_state(self.backend.read())

    def _release_estop(self, command: ReleaseEStop) -> CommandReply:
        with self._lock:
            if not self._estop_latched:
                return CommandReply(False, "e-stop is not latched", Refusal.NOT_LATCHED)
            if self._estop_pending is not None:
                return CommandReply(False, "e-stop is still being applied; try again", Refusal.ESTOP_LATCHED)
            unsafe = self._diagnostics.unsafe()
            if unsafe:
                faults = "; ".join(f"{s.name}: {s.message}" for s in unsafe)
                return CommandReply(False, f"motion is unsafe until this is fixed: {faults}", Refusal.ESTOP_LATCHED)
            self._estop_latched = False
        self._bus.publish(
            "estop/released", f"E-STOP released ({command.source}); the robot stays still until the next command"
        )
        return CommandReply(True, "e-stop released; send a command or replan to resume")

    # ----------------------------------------------------------------------------------------------------------
    # commands and plans

    def _refuse_if_unsafe(self) -> CommandReply | None:
        if self._estop_latched:
            return CommandReply(False, "e-stop is latched: release it first", Refusal.ESTOP_LATCHED)
        if self._fallen:
            return CommandReply(False, "the robot has fallen: it must be reset first", Refusal.ESTOP_LATCHED)
        return None

    def _refuse_if_teleop(self) -> CommandReply | None:
        if self._teleop_active:
            return CommandReply(False, "teleop is active: release the controls before running a plan", Refusal.BUSY)
        return None

    def _world_context(self) -> WorldContext:
        known = self._perception.memory.snapshot() if self._perception is not None else ()
        return WorldContext.from_layout(self.layout, held_object=self._held_object, known_objects=known)

    def _planning_context(self, failure: str | None = None, done: tuple[str, ...] = ()) -> PlanningContext:
        return PlanningContext(self._world_context(), self._memory.turns(), failure, done)

    def _plan(self, text: str, context: PlanningContext) -> PlanResult | CommandReply:
        """Plan `text` with the configured planner (falling back to rules); a refusal when no plan could be made."""
        try:
            result = self.planning.plan(text, context)
        except PlanningError as exc:
            self._bus.publish("plan/rejected", f"could not plan {text!r}: {exc}", Level.WARN, text=text,
                              backend=self.planning.backend)  # fmt: skip
            return CommandReply(False, str(exc), Refusal.INVALID, (str(exc),))
        if result.notes:
            kind = "plan/fallback" if result.planner != result.backend else "plan/repaired"
            message = f"{result.planner} planned {text!r}: " + "; ".join(result.notes)
            self._bus.publish(kind, message, Level.WARN, text=text, planner=result.planner, backend=result.backend,
                              notes=list(result.notes))  # fmt: skip
        return result

    def _run_command(self, command: RunCommand) -> CommandReply:
        text = command.text.strip()
        if not text:
            return CommandReply(False, "empty command", Refusal.INVALID, ("command text is empty",))
        if len(text) > MAX_COMMAND_CHARS:
            return CommandReply(
                False, "command too long", Refusal.INVALID, (f"at most {MAX_COMMAND_CHARS} characters",)
            )
        with self._lock:
            if refusal := self._refuse_if_unsafe() or self._refuse_if_teleop():
                return refusal
        result = self._plan(text, self._planning_context())
        if isinstance(result, CommandReply):
            self._memory.add(text)
            self._memory.update_last(outcome=f"refused: {result.message}")
            return result
        return self._enqueue(text, result.plan, new_command=True, planned=result)

    def _execute_plan(self, command: ExecutePlan) -> CommandReply:
        with self._lock:
            if refusal := self._refuse_if_unsafe() or self._refuse_if_teleop():
                return refusal
        checked, errors = validate_plan_json(command.plan_json, self._world_context())
        if checked is None:
            return CommandReply(False, "invalid plan", Refusal.INVALID, tuple(errors))
        if command.command_id is not None:  # the operator's edit of a command's plan: its next revision
            last = self._last_command
            if last is None or last[0] != command.command_id:
                current = f"the current one is {last[0]}" if last else "there is none"
                return CommandReply(False, f"command {command.command_id} is not the current command ({current})",
                                    Refusal.INVALID, ("stale command id",))  # fmt: skip
            return self._enqueue(last[1], checked, new_command=False, command_id=last[0], approved=True)
        return self._enqueue(command.text or "(operator plan)", checked, new_command=True, approved=True)

    def _replan(self) -> CommandReply:
        """The operator's replan: the current command planned again from the robot's state now."""
        with self._lock:
            if refusal := self._refuse_if_unsafe() or self._refuse_if_teleop():
                return refusal
            last = self._last_command
            job = self._current_job or self._finished_job
        if last is None:
            return CommandReply(False, "no command to replan", Refusal.NOTHING_TO_REPLAN)
        command_id, text = last
        failure, done = _failure_of(job) if job is not None and job.status.command_id == command_id else (None, ())
        result = self._plan(text, self._planning_context(failure, done))
        if isinstance(result, CommandReply):
            return result
        return self._enqueue(text, result.plan, new_command=False, command_id=command_id, planned=result)

    def _auto_replan(self, job: _Job) -> bool:
        """After a failed step: plan the command again from where the robot is, up to `max_auto_replans` times per
        command. Not after a fall or an e-stop (the robot must be seen to first), nor for an operator's plan."""
        command_id = job.status.command_id
        with self._lock:
            if self._fallen or self._estop_latched or self._stop.is_set() or job.fault is not None:
                return False
            if self._last_command != (command_id, job.status.command_text) or not self._jobs.empty():
                return False  # a newer command has come in
            used = self._auto_replans.get(command_id, 0)
            if used >= self.max_auto_replans or job.status.command_text == "(operator plan)":
                return False
            self._auto_replans[command_id] = used + 1
        failure, done = _failure_of(job)
        result = self._plan(job.status.command_text, self._planning_context(failure, done))
        if isinstance(result, CommandReply):
            return False
        self._bus.publish("plan/replanning", f"replanning after: {failure} (automatic replan {used + 1} of "
                          f"{self.max_auto_replans})", Level.WARN, command_id=command_id, failure=failure)  # fmt: skip
        reply = self._enqueue(job.status.command_text, result.plan, new_command=False, command_id=command_id,
                              planned=result)  # fmt: skip
        return reply.accepted

    def _enqueue(
        self,
        text: str,
        plan: Plan,
        new_command: bool,
        command_id: int | None = None,
        planned: PlanResult | None = None,
        approved: bool = False,
    ) -> CommandReply:
        """Start a plan (a new command's, or a new revision of the current one), superseding whatever ran or
        waited; with approval required, a planner's plan waits for the operator instead."""
        with self._lock:
            # an e-stop (or teleop) may have come in while planning
            if refusal := self._refuse_if_unsafe() or self._refuse_if_teleop():
                return refusal
            if new_command:
                command_id = self._next_command_id
                self._next_command_id += 1
                self._bus.publish("command/received", f"command: {text}", command_id=command_id, text=text)
                self._memory.add(text)
            self._memory.update_last(plan=plan, outcome="running")
            assert command_id is not None
            revision = self._revisions.get(command_id, 0) + 1
            self._revisions[command_id] = revision
            plan_id = self._next_plan_id
            self._next_plan_id += 1
            self._last_command = (command_id, text)
            if self._current_job:
                self._current_job.cancel.set()  # the newest command or plan revision preempts the running one
            self._drain_queued_jobs("superseded by a newer plan")
            awaits = self._approval_required and not approved
            status = PlanStatus(
                plan_id=plan_id,
                command_id=command_id,
                command_text=text,
                revision=revision,
                state=PlanState.AWAITING_APPROVAL if awaits else PlanState.RUNNING,
                steps=tuple(StepStatus(i, s.action, dict(s.args)) for i, s in enumerate(plan.steps)),
            )
            self._bus.publish(
                "plan/created",
                f"plan {plan_id} (revision {revision}): " + ", ".join(s.action for s in plan.steps),
                plan_id=plan_id,
                command_id=command_id,
                revision=revision,
                text=text,
                plan=plan.to_dict(),
                planner=planned.planner if planned else "operator",
                backend=planned.backend if planned else self.planning.backend,
                notes=list(planned.notes) if planned else [],
                planning_ms=round(planned.latency_s * 1000, 1) if planned else 0.0,
            )
            job = _Job(status, plan, threading.Event())
            if awaits:
                self._held_job = job
            else:
                self._jobs.put(job)
        if awaits:
            self._bus.publish("plan/awaiting_approval", f"plan {plan_id} awaits the operator's approval",
                              plan_id=plan_id, command_id=command_id)  # fmt: skip
        how = f" (planned by {planned.planner}: {'; '.join(planned.notes)})" if planned and planned.notes else ""
        queued = "awaits approval" if awaits else "queued"
        return CommandReply(True, f"plan {plan_id} {queued}{how}", command_id=command_id, plan=plan)

    def _held_in(self, state: PlanState, missing: str) -> _Job | CommandReply:
        """The held plan if it is in `state` and motion is allowed, else the refusal; under the lock."""
        if refusal := self._refuse_if_unsafe() or self._refuse_if_teleop():
            return refusal
        job = self._held_job
        if job is None or job.status.state != state:
            return CommandReply(False, missing, Refusal.NOTHING_TO_DO)
        return job

    def _approve_plan(self, command: ApprovePlan) -> CommandReply:
        with self._lock:
            job = self._held_in(PlanState.AWAITING_APPROVAL, "no plan awaits approval")
            if isinstance(job, CommandReply):
                return job
            if command.plan_id is not None and command.plan_id != job.status.plan_id:
                return CommandReply(False, f"plan {command.plan_id} no longer awaits approval (plan "
                                    f"{job.status.plan_id} does)", Refusal.INVALID, ("stale plan id",))  # fmt: skip
            self._held_job = None
            job.status = replace(job.status, state=PlanState.RUNNING)
            self._jobs.put(job)
        self._bus.publish("plan/approved", f"plan {job.status.plan_id} approved", plan_id=job.status.plan_id)
        return CommandReply(True, f"plan {job.status.plan_id} approved", command_id=job.status.command_id,
                            plan=job.plan)  # fmt: skip

    def _pause_plan(self) -> CommandReply:
        with self._lock:
            job = self._current_job
            if job is None:
                return CommandReply(False, "no plan is running", Refusal.NOTHING_TO_DO)
            job.pausing = True
            job.cancel.set()
        return CommandReply(True, f"pausing plan {job.status.plan_id}")

    def _resume_plan(self) -> CommandReply:
        with self._lock:
            job = self._held_in(PlanState.PAUSED, "no plan is paused")
            if isinstance(job, CommandReply):
                return job
            start = next(s.index for s in job.status.steps if s.state == StepState.PAUSED)
            steps = tuple(replace(s, state=StepState.PENDING, detail="") if s.index == start else s
                          for s in job.status.steps)  # fmt: skip
            resumed = _Job(replace(job.status, state=PlanState.RUNNING, steps=steps), job.plan, threading.Event(),
                           start=start)  # fmt: skip
            self._held_job = None
            self._jobs.put(resumed)
        self._bus.publish("plan/resumed", f"plan {job.status.plan_id} resumed at step {start + 1}",
                          plan_id=job.status.plan_id)  # fmt: skip
        return CommandReply(True, f"plan {job.status.plan_id} resumed at step {start + 1}",
                            command_id=job.status.command_id)  # fmt: skip

    def _set_approval(self, required: bool) -> CommandReply:
        with self._lock:
            self._approval_required = required
        self._bus.publish("plan/approval", "plans wait for approval" if required else "plans run when planned",
                          required=required)  # fmt: skip
        return CommandReply(True, "plans now wait for approval" if required else "plans now run when planned")

    def _cancel_plan(self, reason: str) -> CommandReply:
        with self._lock:
            job = self._current_job
            held = self._held_job
            if job:
                job.cancel.set()
            self._drain_queued_jobs(reason)
        return CommandReply(True, "plan cancelled" if job or held else "no plan running")

    def _drain_queued_jobs(self, reason: str) -> None:
        """Cancel every plan that has not started (queued, awaiting approval, paused); under the lock."""
        held, self._held_job = self._held_job, None
        if held is not None:
            self._end_unstarted(held, reason)
        while True:
            try:
                job = self._jobs.get_nowait()
            except queue.Empty:
                return
            if job is None:
                self._jobs.put(None)
                return
            self._end_unstarted(job, reason)

    def _end_unstarted(self, job: _Job, reason: str) -> None:
        job.cancel.set()
        steps = tuple(
            s if s.state in (StepState.SUCCEEDED, StepState.FAILED) else replace(s, state=StepState.CANCELLED,
                                                                                 detail=reason)
            for s in job.status.steps
        )  # fmt: skip
        job.status = replace(job.status, state=PlanState.CANCELLED, steps=steps)
        self._finished_job = job
        self._bus.publish(
            "plan/finished", f"plan {job.status.plan_id} {reason}", Level.WARN, plan_id=job.status.plan_id,
            state=PlanState.CANCELLED.value, steps=_step_summary(steps),
        )  # fmt: skip

    # ----------------------------------------------------------------------------------------------------------
    # teleop, postures, reset

    def _clock(self) -> float:
        """The deadman's clock: wall time when driving in real time, sim time when running headless."""
        return time.monotonic() if self.realtime else self._sim_time

    def _teleop(self, command: Teleop) -> CommandReply:
        try:
            velocity = clip_velocity(Velocity(command.vx, command.vy, command.yaw_rate), self._loco.velocity.limits)
        except (TypeError, ValueError):
            return CommandReply(False, "teleop velocity must be finite numbers", Refusal.INVALID)
        with self._lock:
            if refusal := self._refuse_if_unsafe():
                return refusal
            if self._current_job is not None or not self._jobs.empty():
                return CommandReply(False, "a plan is running: cancel it to teleoperate", Refusal.BUSY)
            if self._reset_pending:
                return CommandReply(False, "the robot is being reset", Refusal.BUSY)
            self._teleop_velocity = velocity
            self._teleop_deadline = self._clock() + TELEOP_TIMEOUT_S
            started = not self._teleop_active
            self._teleop_active = True
            if self._posture_name != Posture.STAND:
                self._posture_name = Posture.STAND
                self._posture.move_to(self._stand)
        if started:
            self._bus.publish("teleop/started", f"teleop started ({command.source})", source=command.source)
        v = velocity
        return CommandReply(True, f"teleop vx {v.vx:.2f} m/s, vy {v.vy:.2f} m/s, yaw rate {v.yaw_rate:.2f} rad/s")

    def _stop_teleop(self, source: str, how: str) -> CommandReply:
        with self._lock:
            active = self._teleop_active
            self._teleop_velocity, self._teleop_deadline = Velocity(), None
            self._stop_promptly = active
        if active:
            self._bus.publish("teleop/stop", f"teleop {how} ({source}): stopping", source=source)
        return CommandReply(True, "stopping" if active else "teleop is not active")

    def _set_posture(self, posture: Posture) -> CommandReply:
        with self._lock:
            if refusal := self._refuse_if_unsafe() or self._refuse_if_teleop():
                return refusal
            if self._current_job is not None:
                return CommandReply(False, "a plan is running: cancel it first", Refusal.BUSY)
            if self._loco.moving:
                return CommandReply(False, "the robot is walking: stop it first", Refusal.BUSY)
            if self._arm_active:
                return CommandReply(False, "the arm is still moving: try again in a moment", Refusal.BUSY)
            self._posture_name = posture
            goal = self._stand if posture == Posture.STAND else _crouch_targets()
            self._posture.move_to(goal)
        self._bus.publish("posture/set", f"moving to the {posture.value} posture", posture=posture.value)
        return CommandReply(True, f"moving to the {posture.value} posture")

    def _reset_robot(self) -> CommandReply:
        if not hasattr(self.backend, "reset"):
            return CommandReply(False, "reset is only possible in simulation", Refusal.UNSUPPORTED)
        with self._lock:
            self._reset_pending = True
            self._teleop_velocity, self._teleop_deadline = Velocity(), None
            if self._current_job:
                self._current_job.cancel.set()
            self._drain_queued_jobs("cancelled by reset")
        self._wake.set()
        return CommandReply(True, "resetting the robot to standing at its start pose")

    def _place_obstacle(self, command: PlaceObstacle) -> CommandReply:
        if not hasattr(self.backend, "place_obstacle"):
            return CommandReply(False, "obstacles can only be placed in simulation", Refusal.UNSUPPORTED)
        if not all(math.isfinite(v) and abs(v) < 50 for v in (command.x, command.y)):
            return CommandReply(False, "obstacle position must be finite and within 50 m", Refusal.INVALID)
        with self._lock:
            self._obstacles_pending.append((command.x, command.y))
        return CommandReply(True, f"placing an obstacle at ({command.x:.2f}, {command.y:.2f})")

    def _inject_fault(self, command: InjectFault) -> CommandReply:
        """Simulation only: faults for diagnostics to find (and tests to check that they do)."""
        if not isinstance(self.backend, MujocoSimBackend):
            return CommandReply(False, "faults can only be injected in simulation", Refusal.UNSUPPORTED)
        fault, target, value = command.fault, command.target, command.value
        if not math.isfinite(value):
            return CommandReply(False, "the fault's value must be finite", Refusal.INVALID)
        try:
            if fault == Fault.SERVO_HEAT:
                self._servo_model.heat(target, value)
            elif fault == Fault.SERVO_OVERLOAD:
                self._servo_model.jam(target, value or 100.0)
            elif fault == Fault.IMU_LOST:
                self.backend.lose_imu(True)
            elif fault in (Fault.CAMERA_STALE, Fault.LIDAR_STALE):
                if self._perception is None:
                    return CommandReply(False, "perception is off: no camera or lidar", Refusal.INVALID)
                self._perception.silence("camera" if fault == Fault.CAMERA_STALE else "lidar")
            elif fault == Fault.CONTROL_STALL:
                if not 0 < value <= 5:
                    return CommandReply(False, "a control stall lasts 0-5 s", Refusal.INVALID)
                self._stall_s = value
            elif fault == Fault.SIM_DIVERGE:
                self._kick_pending = True
            elif fault == Fault.CONTROL_ERROR:
                if not 1 <= value <= 1000:
                    return CommandReply(False, "a controller fault lasts 1-1000 ticks", Refusal.INVALID)
                self._raise_ticks = int(value)
            elif fault == Fault.BATTERY_SOC:
                if not 0 <= value <= 1:
                    return CommandReply(False, "a state of charge is 0..1", Refusal.INVALID)
                self._battery.soc = value
            elif fault == Fault.CLEAR:
                self._servo_model.clear_faults()
                self.backend.lose_imu(False)
                if self._perception is not None:
                    self._perception.silence("camera", False)
                    self._perception.silence("lidar", False)
            else:
                return CommandReply(False, f"unknown fault {fault!r}", Refusal.INVALID)
        except ValueError as exc:
            return CommandReply(False, str(exc), Refusal.INVALID)
        what = f"{fault.value}" + (f" on {target}" if target else "") + (f" ({value:g})" if value else "")
        self._bus.publish("sim/fault", f"fault injected: {what}", Level.WARN if fault != Fault.CLEAR else Level.OK,
                          fault=fault.value, target=target, value=value)  # fmt: skip
        return CommandReply(True, f"fault injected: {what}")

    def _safe_stop(self, reason: str) -> None:
        """Diagnostics found a fault that makes motion unsafe: the controlled stop, latched."""
        with self._lock:
            if self._fallen:  # already down and refusing to move
                return
        self._bus.publish("diagnostics/safe_stop", f"safe stop: {reason}", Level.ERROR, reason=reason)
        self.submit(EStop(source="diagnostics", reason=reason))

    def _apply_pending_obstacles(self) -> None:
        with self._lock:
            pending, self._obstacles_pending = self._obstacles_pending, []
        for x, y in pending:
            try:
                index = self.backend.place_obstacle(x, y)
            except ValueError as exc:
                self._bus.publish("sim/obstacle", f"no obstacle placed: {exc}", Level.WARN)
                continue
            self._bus.publish("sim/obstacle", f"obstacle {index} dropped at ({x:.2f}, {y:.2f})", x=x, y=y)

    def _apply_pending_reset(self) -> None:
        """Control thread: the robot stands again at its start pose, as after start-up."""
        with self._lock:
            if not self._reset_pending:
                return
            self._reset_pending = False
            self._fallen = False
            self._teleop_active = False
            self._held_object = None
            self._posture_name = Posture.STAND
            self._arm_active = False
            self._arm_finishing = False
            self._stand = self._default_stand.copy()
        self._loco.walking.ik.set_upper_body(dict(zip(humanoid_v1.JOINT_NAMES, self._default_stand, strict=True)))
        self._loco.halt()
        self._head.reset(start=(float(self._stand[_HEAD_PAN]), float(self._stand[_HEAD_TILT])))
        if self._perception is not None:  # objects are back where the world puts them; odometry starts over
            self._perception.forget_objects()
            self._perception.clear_map()
        self.backend.reset(self._stand)
        self._servo_model.reboot()  # a reset power-cycles the servos: latched errors clear, heat stays
        self._posture.hold(self._stand)
        self._measured = self.backend.read()
        self._loco.reset_odometry(measured_pose(self._measured), sensors(self._measured))
        self._bus.publish("robot/reset", "robot reset: standing at its start pose")

    # ----------------------------------------------------------------------------------------------------------
    # task thread

    def _task_loop(self) -> None:
        while not self._stop.is_set():
            job = self._jobs.get()
            if job is None:
                return
            with self._lock:
                if job.cancel.is_set() or self._estop_latched:
                    # an e-stop may have drained the queue just after this job left it: end it here, visibly
                    if job.status.state != PlanState.CANCELLED:
                        self._end_unstarted(job, "cancelled by e-stop" if self._estop_latched else "cancelled")
                    continue
                self._current_job = job
                # A new plan starts from the standing posture (a move, so only after an explicit command).
                self._posture.move_to(self._stand)
            context = ExecutionContext(
                cancel=job.cancel,
                say=lambda text: self._bus.publish("speech/say", text, text=text),
                wait_sim=lambda seconds, cancel=job.cancel: self._wait_sim(seconds, cancel),
                held_object=lambda: self._held_object,
                fault=lambda j=job: j.fault,
                pausing=lambda j=job: j.pausing,
            )
            result = self._executor.run(job.plan, context, lambda i, st, d, j=job: self._on_step(j, i, st, d),
                                        start=job.start)  # fmt: skip
            with contextlib.suppress(Cancelled):  # a plan ends with the robot at rest, its arm included
                self._wait_arm_finished(job.cancel)
            failure, _ = _failure_of(job)
            with self._lock:
                if result == PlanState.PAUSED and (self._estop_latched or self._fallen):
                    # an e-stop or a fall came with the pause: nothing is left to resume
                    result = PlanState.CANCELLED
                    job.status = replace(job.status, steps=tuple(
                        replace(s, state=StepState.CANCELLED, detail="cancelled by e-stop")
                        if s.state in (StepState.PAUSED, StepState.PENDING) else s for s in job.status.steps
                    ))  # fmt: skip
                # the state says a replan is coming, so nobody waiting for the command's end stops here
                replans_left = self._auto_replans.get(job.status.command_id, 0) < self.max_auto_replans
                job.status = replace(job.status, state=result, replanning=result == PlanState.FAILED and replans_left)
                self._current_job = None
                self._finished_job = job
                if result == PlanState.PAUSED:
                    self._held_job = job
            if self._last_command is not None and self._last_command[0] == job.status.command_id:
                self._memory.update_last(outcome=result.value + (f": {failure}" if failure else ""))
            level = Level.OK if result == PlanState.SUCCEEDED else Level.WARN
            failed = [s for s in job.status.steps if s.state == StepState.FAILED]
            message = f"plan {job.status.plan_id} {result.value}" + (f": {failed[0].detail}" if failed else "")
            self._bus.publish(
                "plan/finished", message, level, plan_id=job.status.plan_id, state=result.value,
                steps=_step_summary(job.status.steps),
            )  # fmt: skip
            if job.status.replanning and not self._auto_replan(job):
                with self._lock:
                    job.status = replace(job.status, replanning=False)

    def _on_step(self, job: _Job, index: int, state: StepState, detail: str) -> None:
        now = self._sim_time
        with self._lock:
            old = job.status.steps[index]
            new = replace(
                old,
                state=state,
                detail=detail,
                sim_start_s=now if state == StepState.RUNNING else old.sim_start_s,
                sim_end_s=now if state != StepState.RUNNING else None,
            )
            steps = list(job.status.steps)
            steps[index] = new
            job.status = replace(job.status, steps=tuple(steps))
        level = Level.WARN if state == StepState.FAILED else Level.OK
        self._bus.publish(
            "plan/step", f"step {index + 1} {new.action}: {state.value}" + (f" ({detail})" if detail else ""),
            level, plan_id=job.status.plan_id, index=index, action=new.action, args=new.args, state=state.value,
            detail=detail, sim_start_s=new.sim_start_s, sim_end_s=new.sim_end_s,
        )  # fmt: skip

    def _wait_sim(self, seconds: float, cancel: threading.Event) -> None:
        target = self._sim_time + seconds
        while self._sim_time < target:
            if cancel.is_set():
                raise Cancelled()
            if self._stop.is_set():
                raise Cancelled()
            cancel.wait(0.002)

    # ----------------------------------------------------------------------------------------------------------
    # control thread

    def _control_loop(self) -> None:
        if self.realtime:
            priority = raise_thread_priority()
            self._bus.publish("control/priority", f"control loop at {self.control_hz:.0f} Hz with {priority}",
                              Level.OK if priority.startswith("real-time") else Level.WARN)  # fmt: skip
        next_deadline = time.perf_counter() + self.dt
        self._stats.last_tick_end = time.perf_counter()  # the watchdog counts from the loop's start
        while not self._stop.is_set():
            if self.realtime:
                remaining = next_deadline - time.perf_counter()
                if remaining > 0:
                    if self._wake.wait(remaining):
                        self._wake.clear()
                        self._apply_pending_estop()
                        self._apply_pending_reset()
                    continue
            elif self._perception is not None:  # headless: the sensors keep their rate in simulated time
                self._perception.wait_until_served(self._sim_time)
            started = time.perf_counter()
            try:
                self._tick()
            except Exception as exc:  # the loop must survive a controller bug: stop safely and report it
                self._on_tick_error(exc)
            finished = time.perf_counter()
            missed = self.realtime and finished > next_deadline + self.dt
            self._stats.record_tick(finished - started, missed)
            self._after_tick(finished - started)
            next_deadline += self.dt
            if self.realtime and finished - next_deadline > MAX_TICKS_BEHIND * self.dt:
                next_deadline = finished + self.dt

    def _on_tick_error(self, exc: Exception) -> None:
        """A failing tick latches the e-stop; said once, and again only when it changes or a second later (a bug
        that fails every tick must not flood the events at 100 Hz)."""
        text, at = self._last_tick_error
        now = time.monotonic()
        if repr(exc) != text or now - at > 1.0:
            self._last_tick_error = (repr(exc), now)
            log.error("control tick failed", exc_info=exc)
            self._bus.publish("control/error", f"control tick failed: {exc!r}", Level.ERROR, error=repr(exc))
        with self._lock:
            latched = self._estop_latched
        if not latched:
            self.submit(EStop(source="control-error", reason=f"the control tick failed: {exc!r}"))

    def _on_divergence(self, exc: SimulationDiverged) -> None:
        """MuJoCo reset the scene by itself: the robot is stopped, then stood up again at its start pose."""
        log.error("%s: e-stop latched, robot reset to its start pose", exc)
        self._bus.publish("sim/diverged", f"{exc}: e-stop latched, robot reset to its start pose", Level.ERROR)
        self.submit(EStop(source="sim-diverged", reason=str(exc)))
        self._reset_robot()

    def _tick(self) -> None:
        """One control period: targets out, physics (or the servos) forward, measurements in, state published."""
        if self._stall_s > 0:  # injected fault: a controller that hangs
            stall, self._stall_s = self._stall_s, 0.0
            time.sleep(stall)
        if self._raise_ticks > 0:  # injected fault: a controller bug
            self._raise_ticks -= 1
            raise RuntimeError("injected controller fault")
        self._apply_pending_estop()
        self._apply_pending_reset()
        self._apply_pending_obstacles()
        self._targets = self._control_targets(self._measured)
        with self._lock:
            fallen = self._fallen
        if not fallen:  # the head is the camera's gimbal, whoever drives the other joints
            pan, tilt = self._head.update(self.dt)
            self._targets[_HEAD_PAN] = pan
            self._targets[_HEAD_TILT] = tilt
        self.backend.write(self._targets)
        if self._kick_pending:
            self._kick_pending = False
            self.backend.kick()
        try:
            self.backend.step(self.dt)
        except SimulationDiverged as exc:
            self._on_divergence(exc)
            return
        measured = self.backend.read()
        self._measured = measured
        self._sim_time = measured.sim_time_s
        self._stats.update_rtf(self._sim_time)
        if measured.fallen and not self._fallen:
            self._on_fall(measured)
        self._publish_state(measured)

    def _after_tick(self, tick_s: float) -> None:
        """What the tick cost the battery, and a telemetry sample when one is due."""
        m = self._measured
        if m.joint_torques is not None:
            self._battery.step(self._servos.power_w(m.joint_torques, m.joint_velocities), self.dt)
            bus_v = min(self._servos.supply_v, self._battery.reading.voltage_v - CONVERTER_DROPOUT_V)
            self._servo_model.step(m.joint_torques, self._targets, m.joint_positions, bus_v, self.dt)
        if not self._telemetry.due():
            return
        battery = self._battery.reading
        self._telemetry.record({
            "sim_time_s": m.sim_time_s, "wall_time_s": time.time(), "qpos": self.backend.qpos(),
            "mocap_pos": self.backend.mocap_positions().ravel(), "joint_target": self._targets,
            "joint_position": m.joint_positions, "joint_velocity": m.joint_velocities,
            "joint_torque": m.joint_torques if m.joint_torques is not None else np.nan,
            "com": m.com if m.com is not None else np.nan, "tick_ms": tick_s * 1e3,
            "battery_v": battery.voltage_v, "battery_a": battery.current_a, "battery_soc": battery.soc,
        })  # fmt: skip

    def _control_targets(self, measured: Measurements) -> np.ndarray:
        """Joint targets: locomotion owns the joints in the walk-ready stance (standing balanced, or walking);
        the posture controller otherwise (crouching, moving between postures, after a fall)."""
        with self._lock:
            if self._teleop_deadline is not None and self._clock() > self._teleop_deadline:
                self._teleop_velocity, self._teleop_deadline = Velocity(), None
                deadman = self._stop_promptly = True
            else:
                deadman = False
            promptly, self._stop_promptly = self._stop_promptly, False
            fallen = self._fallen
            velocity = self._task_velocity if self._current_job is not None else self._teleop_velocity
            if self._estop_latched:
                velocity = Velocity()
            in_stance = self._posture_name == Posture.STAND and self._posture.settled
            arm = self._arm if self._arm_active else None
        if deadman:
            self._bus.publish("teleop/deadman", f"no teleop input for {TELEOP_TIMEOUT_S * 1e3:.0f} ms: stopping",
                              Level.WARN)  # fmt: skip
        if arm is not None and not fallen:  # reaching: feet planted, the estimate follows
            s = sensors(measured)
            self._loco.odometry.update(s.joint_positions, s.imu_quat, s.foot_forces)
            targets = arm.update(measured.joint_positions)
            with self._lock:
                finished = self._arm_finishing and arm.done.is_set() and self._arm_active
            if finished:
                self._release_arm(None)
                with self._lock:
                    self._arm_finishing = False
            return targets
        if fallen or not in_stance:
            if not fallen:  # crouching or moving between postures: the feet stay put, the estimate follows
                s = sensors(measured)
                self._loco.odometry.update(s.joint_positions, s.imu_quat, s.foot_forces)
            return self._posture.update(self.dt)
        self._loco.set_velocity(velocity)
        if promptly:
            self._loco.stop(promptly=True)
        was_walking = self._loco.moving
        targets = self._loco.update(sensors(measured), self._posture.goal)
        if not self._loco.moving:
            with self._lock:  # a posture command may have just arrived: holding the stance must not undo it
                if self._posture_name == Posture.STAND and was_walking:
                    # The walk ends in its own posture, which is not the standing one when the arms carry something
                    # (knees 0.34 rad deeper): moving there in one tick made the robot hop and pitch 8-10 deg just
                    # as placing began (a fall on world seed 13), and at posture speed (0.2 s) it still pitched 9.
                    self._posture.hold(targets)
                    self._posture.move_to(self._stand, WALK_TO_STAND_SPEED_RAD_S)
                elif self._posture_name == Posture.STAND:
                    self._posture.hold(self._stand)
                ended = self._teleop_active and self._teleop_deadline is None
                if ended:
                    self._teleop_active = False
            if ended:
                self._bus.publish("teleop/ended", "teleop ended: standing")
        return targets

    def _on_fall(self, measured: Measurements) -> None:
        self._loco.halt()
        if self._arm_active and self._arm is not None:
            self._arm.stop()
            self._arm_active = False
            self._arm_finishing = False
        self._posture.hold(self._targets)  # hold the last references: no sudden move on the ground
        with self._lock:
            self._fallen = True
            self._teleop_active = False
            self._teleop_velocity, self._teleop_deadline = Velocity(), None
            if self._current_job:
                self._current_job.fault = f"fell (tilt {measured.tilt_deg:.0f} deg)"
                self._current_job.cancel.set()
        self._bus.publish("robot/fell", f"the robot fell (tilt {measured.tilt_deg:.0f} deg)", Level.ERROR,
                          tilt_deg=measured.tilt_deg, height_m=float(measured.base_position[2]))  # fmt: skip

    def _publish_state(self, measured: Measurements) -> None:
        with self._lock:
            job = self._current_job
            latched = self._estop_latched
            if self._fallen:
                mode = Mode.FALLEN
            elif latched:
                mode = Mode.ESTOP
            elif job:
                mode = Mode.EXECUTING
            elif self._teleop_active:
                mode = Mode.TELEOP
            else:
                mode = Mode.IDLE
            posture = self._posture_name.value if self._posture.settled else "moving"
            shown = job or self._held_job or self._finished_job
            approval = self._approval_required
            plan_status = shown.status if shown else None
        position = measured.base_position
        self._board.publish(
            RobotState(
                sim_time_s=measured.sim_time_s,
                wall_time_s=time.time(),
                mode=mode,
                estop_latched=latched,
                base_position=(float(position[0]), float(position[1]), float(position[2])),
                base_yaw_rad=measured.yaw_rad,
                tilt_deg=measured.tilt_deg,
                fallen=measured.fallen,
                qpos=tuple(self.backend.qpos().tolist()),
                mocap_positions=tuple(self.backend.mocap_positions().ravel().tolist()),
                navigation=self._navigation,
                approval_required=approval,
                power=self._power_state(),
                objects=tuple(ObjectPose(n, p) for n, p in self.backend.object_positions().items()),
                held_object=self._held_object,
                plan=plan_status,
                control=self._stats.snapshot(),
                locomotion=self._locomotion_state(posture),
                perception=self._perception_state(),
                proprioception=Proprioception(
                    orientation=_floats(measured.imu_quat),
                    angular_velocity=_floats(measured.imu_gyro),
                    linear_acceleration=_floats(measured.imu_accel),
                    left_foot_n=_floats(measured.foot_forces[0]),
                    right_foot_n=_floats(measured.foot_forces[1]),
                ),
            )
        )

    def _power_state(self) -> PowerState:
        b = self._battery.reading
        return PowerState(voltage_v=b.voltage_v, current_a=b.current_a, soc=b.soc, power_w=b.power_w)

    def _perception_state(self) -> PerceptionState | None:
        if self._perception is None:
            return None
        pose = self._loco.odometry.pose
        return replace(self._perception.state(), head=self._head.command,
                       pose=self._perception.localise(pose.x, pose.y, pose.yaw))  # fmt: skip

    def _locomotion_state(self, posture: str) -> LocomotionState:
        loco = self._loco
        target, current, pose = loco.velocity.target, loco.velocity.current, loco.odometry.pose
        overlay = loco.overlay()
        position, rotation = self._estimated_trunk()
        state = LocomotionState(
            phase=loco.phase.value,
            posture=posture,
            command=(target.vx, target.vy, target.yaw_rate),
            velocity=(current.vx, current.vy, current.yaw_rate),
            estimated_pose=(pose.x, pose.y, pose.yaw),
            estimated_trunk=(*(float(v) for v in position), *matrix_to_quat_wxyz(rotation)),
        )
        if overlay is None:
            return state
        return replace(
            state,
            footsteps=tuple(Footprint(side, x, y, yaw) for side, x, y, yaw in overlay.footsteps),
            com=overlay.com,
            zmp=overlay.zmp,
            support=overlay.support,
        )


_HEAD_PAN = humanoid_v1.JOINT_NAMES.index("head_pan")
_HEAD_TILT = humanoid_v1.JOINT_NAMES.index("head_tilt")


def _floats(values: np.ndarray) -> tuple[float, ...]:
    return tuple(float(v) for v in values)


def _crouch_targets() -> np.ndarray:
    posture = humanoid_v1.crouch_posture()
    return np.array([posture[n] for n in humanoid_v1.JOINT_NAMES])
