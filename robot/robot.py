"""The robot behind the `RobotPort` interface, for any body: the one place that builds the core's units and wires
them to each other, and the table from each command type to the unit that serves it.

- The control loop owns the body (the MuJoCo simulation, or the servos): each tick it reads, computes targets,
  writes, steps, and publishes an immutable `RobotState`. An e-stop wakes it at once, so the controlled stop is
  applied within one tick of the press, not at the next scheduled one.
- A body with legs that balance (an IMU and foot sensors) also gets the mission: teleop, plans on the task
  runner's thread, the skills, perception and voice. What a body cannot do is refused with its reason.
- `submit()` is called from any thread (the web server): it plans and validates synchronously, so a bad command
  is refused with reasons and changes nothing.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from robot.behaviours.registry import discover
from robot.behaviours.runner import BEHAVIOUR_ACTION, BehaviourParts, BehaviourRunner
from robot.config import RobotConfig
from robot.control.gait import write_placo_model
from robot.control.head import HeadController
from robot.control.locomotion import LocomotionController
from robot.control.stack import measured_pose, sensors
from robot.control.stats import LoopStats
from robot.core.arbiter import JointArbiter
from robot.core.body import Body, BodyLinks, CommandHandler
from robot.core.inbox import MotionInbox
from robot.core.loop import ControlLoop
from robot.core.motion import MotionCommands
from robot.core.publisher import MissionParts, StatePublisher
from robot.core.safety import SafetyLatch
from robot.core.tick import ControlTick
from robot.diagnostics.robot_sources import RobotDiagnostics
from robot.diagnostics.servo_heat import ServoHeatGauge
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
    Level,
    PauseBehaviour,
    PausePlan,
    PerceptionState,
    Plan,
    Refusal,
    ReleaseEStop,
    Replan,
    ResetRobot,
    ResumeBehaviour,
    ResumePlan,
    RobotDescription,
    RobotState,
    RunCommand,
    SensorFeed,
    SetApproval,
    SetPosture,
    StartBehaviour,
    StopBehaviour,
    StopTeleop,
    Teleop,
)
from robot.manipulation.arm_motion import ArmMotion
from robot.manipulation.reach_ik import ReachIK
from robot.model import humanoid_v1
from robot.model.scene import scene_xml
from robot.model.world import WorldLayout
from robot.parts import MapLocaliser, RobotArm, RobotLegs, SimClock
from robot.planning.context import PlanningContext
from robot.planning.executor import Capability, PlanExecutor
from robot.planning.pipeline import PlannerConfig, PlanningPipeline, build_pipeline
from robot.planning.world_context import WorldContext
from robot.skills.body import BodyParts
from robot.skills.catalogue import Skills, build_skills
from robot.speech.robot_voice import RobotVoice
from robot.tasks.commands import PlanCommands
from robot.tasks.runner import TaskRunner
from robot.telemetry import TelemetryBatch


class Robot(InProcessPort):
    """Runs one robot. Use `start()`, then talk to it only through the `RobotPort` methods.

    `locomotion`: the legs' controller (None: a body that cannot balance, whose posture controller owns the
    joints); `planning`: the planners (default: from `config.planning`); `capabilities`: what plan steps can do
    (default: the skills)."""

    def __init__(
        self,
        body: Body,
        layout: WorldLayout,
        config: RobotConfig | None = None,
        *,
        locomotion: LocomotionController | None = None,
        planning: PlanningPipeline | None = None,
        capabilities: dict[str, Capability] | None = None,
    ) -> None:
        config = config or RobotConfig()
        self.body = body
        self.layout = layout
        self.config = config
        self.realtime = config.realtime
        self.control_hz = config.control_hz
        self.dt = config.dt
        self.locomotion = locomotion
        self._lock = threading.RLock()  # the robot's state lock: units whose state changes together share it
        self._events = EventBus(sim_clock=body.now)
        publish = self._events.publish
        self.latch = SafetyLatch(self._lock, publish, lambda: self.health.unsafe(), body.latch_words)
        self.stats = LoopStats(config.control_hz)
        stand = locomotion.stand_targets if locomotion is not None else body.stand_posture()
        if body.connected:  # the simulation: the robot stands at its start pose from the first state on
            measured = body.place(stand)
            if locomotion is not None:
                locomotion.reset_odometry(measured_pose(measured), sensors(measured))
        legs = locomotion is not None and body.senses.can_walk
        self.inbox = MotionInbox(self._lock, time.monotonic if config.realtime else body.now) if legs else None
        self.runner: TaskRunner | None = None
        # The lambdas below name units built further down (the publisher and the skills need the body bound first,
        # for its perception): they are read once everything is built, never during construction.
        self.arbiter = self._build_arbiter(stand, legs)
        self.motion = MotionCommands(
            self._lock,
            self.latch,
            self.arbiter,
            publish,
            body.crouch_posture(),
            body.motion_refusal,
            inbox=self.inbox,
            locomotion=locomotion if legs else None,
            plan_running=lambda: self.runner is not None and self.runner.running,
            plans_busy=lambda: self.runner is not None and self.runner.busy,
            reset_pending=lambda: self.ticker.reset_pending,
        )
        body.bind(
            BodyLinks(
                publish=publish,
                latch=self.latch,
                hold=self.arbiter.hold,
                latest_state=lambda: self.publisher.latest(),
                wait_for=lambda predicate, timeout_s: self.publisher.wait_for(predicate, timeout_s),
                loop_alive=lambda: self.loop.is_alive(),
                tick_age_s=lambda: self.loop.tick_age_s(),
            )
        )
        self.perception = body.perception
        self.arm = RobotArm(self.arbiter, lambda: body.latest().joint_positions)
        self.skills: Skills | None = None
        self.plans: PlanCommands | None = None
        self.behaviours: BehaviourRunner | None = None
        if legs:
            assert locomotion is not None
            self._build_mission(locomotion, planning, capabilities)
        self.publisher = StatePublisher(
            self._lock,
            self.latch,
            body.snapshot,
            self.stats.snapshot,
            self.arbiter.posture_label,
            self._mission_parts() if legs else None,
        )
        self.ticker = ControlTick(
            body,
            self._lock,
            self.latch,
            self.arbiter,
            self.publisher,
            self.stats,
            publish,
            lambda: self.loop.wake(),
            inbox=self.inbox,
            locomotion=locomotion if legs else None,
            on_fall=self.runner.fault if self.runner is not None else lambda reason: None,
            on_reset_requested=self._stop_for_reset,
            on_reset=lambda: self.arm.hold_object(None),
        )
        perception = self.perception
        self.loop = ControlLoop(
            config.control_hz,
            config.realtime,
            self.ticker.tick,
            self.ticker.on_error,
            publish,
            on_wake=self.ticker.on_wake,
            # headless: the sensors keep their rate in simulated time
            pace=(lambda: perception.wait_until_served(body.now())) if perception and not config.realtime else None,
            after_tick=self.ticker.after_tick,
            guard=body.tick_guard,
            stats=self.stats,
            tick_on_wake=config.realtime and body.stop_by_tick,
        )
        self.latch.on_latch(self.loop.wake)  # the control thread applies the stop now, not at its next tick
        self._voice: RobotVoice | None = None  # the robot's microphone and speaker, opened on start
        self.health = RobotDiagnostics(
            body.readings(self.stats, self._perception_state, self.sensor_feed, lambda: self._voice),
            config.diagnostics,
            config.realtime,
            config.disk_path,
            config.planning if self.plans is not None else None,
            self._planner_name(),
            publish,
            self._safe_stop,
        )
        self._handlers = self._command_table()
        self._description: RobotDescription | None = None
        if body.connected:
            self.publisher.publish(body.latest())

    # ----------------------------------------------------------------------------------------------------------
    # wiring

    def _build_arbiter(self, stand: np.ndarray, legs: bool) -> JointArbiter:
        names = self.body.joint_names
        pan, tilt = names.index("head_pan"), names.index("head_tilt")
        dt = self.dt

        def arm() -> ArmMotion:  # whole-body reaching: placo loads a model, so only on first use
            return ArmMotion(ReachIK(write_placo_model(), dt), dt)

        return JointArbiter(
            self._lock,
            dt,
            names,
            stand,
            self.latch,
            self._events.publish,
            locomotion=self.locomotion if legs else None,
            inbox=self.inbox,
            plan_running=lambda: self.runner is not None and self.runner.running,
            head=HeadController(start=(float(stand[pan]), float(stand[tilt]))) if legs else None,
            arm=arm if legs else None,
            stop_posture=self.body.stop_posture(),
        )

    def _build_mission(
        self,
        locomotion: LocomotionController,
        planning: PlanningPipeline | None,
        capabilities: dict[str, Capability] | None,
    ) -> None:
        """The skills, the task runner and the planning front of a body that walks."""
        assert self.inbox is not None and self.arbiter.head is not None
        publish = self._events.publish
        self.localiser = MapLocaliser(locomotion.odometry, self.perception)
        parts = BodyParts(
            head=self.arbiter.head,
            legs=RobotLegs(self.inbox, locomotion, self.latch),
            arm=self.arm,
            localiser=self.localiser,
            perception=self.perception,
            clock=SimClock(self.body.now),
            servo_heat=ServoHeatGauge(lambda: self.health.readings, self.config.diagnostics.servo_temperature_warn_c),
        )
        self.skills = build_skills(parts, self.layout, self._world_context, publish)
        arbiter = self.arbiter
        skill_steps = capabilities or self.skills.capabilities(lambda ctx: arbiter.wait_arm_finished(ctx.wait_sim))
        executor = PlanExecutor(
            skill_steps | {BEHAVIOUR_ACTION: lambda args, ctx: self._behaviours().run_step(args, ctx)}
        )

        def refusal() -> CommandReply | None:
            return self.latch.refusal() or self.motion.teleop_refusal()

        runner = self.runner = TaskRunner(
            executor,
            self._lock,
            self.latch,
            refusal,
            publish,
            self.body.now,
            settle=lambda cancel: arbiter.wait_arm_finished(lambda seconds: runner.wait_sim(seconds, cancel)),
            stand=arbiter.begin_plan,
            held_object=lambda: self.arm.held,
            approve_plans=self.config.approve_plans,
        )
        latch = self.latch
        behaviours = self.behaviours = BehaviourRunner(
            discover(),
            BehaviourParts(
                parts,
                self.skills,
                skill_steps,
                self.layout,
                self._world_context,
                runner,
                lambda: not latch.latched and not latch.fallen,
                refusal,
                self._plan_text,
            ),
            self._lock,
            publish,
        )
        pipeline = planning if planning is not None else build_pipeline(self.config.planning or PlannerConfig())
        self.plans = PlanCommands(
            runner,
            pipeline,
            self._lock,
            self.latch,
            lambda: refusal() or behaviours.plan_refusal(),
            self._world_context,
            publish,
            self.config.max_auto_replans,
        )
        self.latch.on_latch(lambda: runner.cancel("cancelled by e-stop"))
        self.latch.on_latch(lambda: behaviours.estopped(self.latch.cause))

    def _behaviours(self) -> BehaviourRunner:
        assert self.behaviours is not None
        return self.behaviours

    def _plan_text(self, text: str) -> Plan:
        """A command's plan, as the planner reads it now (for a behaviour that takes commands)."""
        assert self.plans is not None
        return self.plans.planning.plan(text, PlanningContext(self._world_context())).plan

    def _mission_parts(self) -> MissionParts:
        assert self.runner is not None and self.skills is not None and self.inbox is not None
        assert self.locomotion is not None
        return MissionParts(
            plans=self.runner,
            teleop=self.inbox,
            navigation=self.skills.navigate,
            hand=self.arm,
            locomotion=self.locomotion,
            trunk=self.localiser.estimated_trunk,
            perception=self._perception_state,
            behaviour=self.behaviours.status if self.behaviours is not None else None,
        )

    def _command_table(self) -> dict[type, CommandHandler]:
        """Which unit serves each command type; what is not here, this body cannot do (`Body.lacks` says why)."""
        handlers: dict[type, CommandHandler] = {
            EStop: self.latch.latch,
            ReleaseEStop: self.latch.release,
            SetPosture: self.motion.set_posture,
        }
        runner, plans = self.runner, self.plans
        if runner is not None and plans is not None:
            handlers |= {
                RunCommand: lambda command: self._behaviours().take_command(command) or plans.run_command(command),
                ExecutePlan: plans.execute_plan,
                Replan: lambda command: plans.replan(),
                CancelPlan: lambda command: runner.cancel("cancelled by operator"),
                ApprovePlan: runner.approve,
                PausePlan: lambda command: runner.pause(),
                ResumePlan: lambda command: runner.resume(),
                SetApproval: lambda command: runner.set_approval(command.required),
                Teleop: lambda command: self._behaviours().teleop_refusal() or self.motion.teleop(command),
                StopTeleop: self.motion.stop_teleop,
            }
        behaviours = self.behaviours
        if behaviours is not None:
            handlers |= {
                StartBehaviour: behaviours.start,
                StopBehaviour: behaviours.stop,
                PauseBehaviour: behaviours.pause,
                ResumeBehaviour: lambda command: behaviours.resume(),
            }
        if self.body.resettable:
            handlers[ResetRobot] = self._reset
        return handlers | self.body.commands()

    def _stop_for_reset(self) -> None:
        """Under the lock, as a reset is asked: nothing drives the robot while it is put back."""
        if self.inbox is not None:
            self.inbox.drop_teleop()
        if self.runner is not None:
            self.runner.cancel("cancelled by reset")

    def _reset(self, command: ResetRobot) -> CommandReply:
        self.ticker.request_reset()
        return CommandReply(True, "resetting the robot to standing at its start pose")

    def _safe_stop(self, reason: str) -> None:
        """Diagnostics found a fault that makes motion unsafe: the controlled stop, latched."""
        self.latch.safe_stop(reason)
        self.body.after_safe_stop()

    def _world_context(self) -> WorldContext:
        known = self.perception.memory.snapshot() if self.perception is not None else ()
        return WorldContext.from_layout(self.layout, held_object=self.arm.held, known_objects=known)

    def _perception_state(self) -> PerceptionState | None:
        perception, head = self.perception, self.arbiter.head
        if perception is None or head is None or self.locomotion is None:
            return None
        pose = self.locomotion.odometry.pose
        return replace(perception.state(), head=head.command, pose=perception.localise(pose.x, pose.y, pose.yaw))

    def _planner_name(self) -> str:
        return self.plans.planning.describe() if self.plans is not None else f"none ({self.body.kind})"

    # ----------------------------------------------------------------------------------------------------------
    # lifecycle

    def start(self) -> None:
        if self.loop.is_alive():
            return
        was_connected = self.body.connected
        self.body.start()
        if not was_connected:  # the real robot: its first state once the bus is read
            self.publisher.publish(self.body.latest())
        if self.perception is not None:  # it places its sensors by the robot's state: started once there is one
            self.perception.start()
        self.loop.start()
        if self.runner is not None:
            self.runner.start()
        self.health.start()
        if self.config.voice is not None and self.plans is not None:
            world = self._world_context()
            self._voice = RobotVoice(
                self.config.voice,
                world.objects,
                world.places,
                self._events.publish,
                self.submit,
                self._events.subscribe,
                estop=lambda: self.submit(EStop(source="voice")),
                world=world,
            )
            self._voice.start()
        how = "real time" if self.realtime else "headless"
        self._events.publish("worker/started", f"robot worker started ({how})")

    def is_alive(self) -> bool:
        return self.loop.is_alive() and (self.runner is None or self.runner.is_alive())

    def stop(self) -> None:
        self.body.before_shutdown()
        if self.runner is not None:
            self.runner.stop()
        self.loop.stop()
        self.health.stop()
        if self._voice is not None:
            self._voice.stop()
            self._voice = None
        self.body.close()
        if self.locomotion is not None:
            self.locomotion.walking.planner.close()

    # ----------------------------------------------------------------------------------------------------------
    # RobotPort

    def submit(self, command: Command) -> CommandReply:
        handler = self._handlers.get(type(command))
        if handler is not None:
            return handler(command)
        name = type(command).__name__
        if self.body.lacks:
            return CommandReply(False, f"{name} {self.body.lacks}", Refusal.UNSUPPORTED)
        return CommandReply(False, f"unknown command type {name}", Refusal.INVALID)

    def state(self) -> RobotState:
        return self.publisher.latest()

    def announce(self, kind: str, message: str, level: Level = Level.OK, **data: Any) -> Event:
        """An event from the server about the robot (e.g. a refused 3D-view click), said like the robot's own."""
        return self._events.publish(kind, message, level, **data)

    def subscribe(self) -> Subscription:
        return self._events.subscribe()

    def recent_events(self) -> list[Event]:
        return self._events.history()

    def sensor_feed(self) -> SensorFeed:
        return self.perception.feed() if self.perception is not None else SensorFeed()

    def telemetry_since(self, seq: int) -> TelemetryBatch | None:
        telemetry = self.body.telemetry
        return telemetry.ring.since(seq) if telemetry is not None else None

    def diagnostics(self) -> DiagnosticArray | None:
        return self.health.latest()

    def sample_diagnostics(self) -> DiagnosticArray:
        """Sample every diagnostic now (headless runs and tests; a running robot samples once a second)."""
        return self.health.monitor.sample()

    def describe(self) -> RobotDescription:
        if self._description is None:
            telemetry = self.body.telemetry
            self._description = RobotDescription(
                model_name=humanoid_v1.MODEL_NAME,
                seed=self.layout.seed,
                mjcf_xml=scene_xml(self.layout),
                joint_names=tuple(self.body.joint_names),
                places=self.layout.place_names,
                objects=self.layout.object_names,
                control_hz=self.control_hz,
                physics_hz=self.body.physics_hz,
                planner=self._planner_name(),
                telemetry_layout=telemetry.layout.to_json() if telemetry is not None else {},
                telemetry_hz=telemetry.rate_hz if telemetry is not None else 0.0,
                behaviours=self.behaviours.describe() if self.behaviours is not None else (),
            )
        if self._voice is None:
            return self._description
        return replace(self._description, microphone=self._voice.microphone_status, speaker=self._voice.speaker_status)

    # ----------------------------------------------------------------------------------------------------------
    # for headless runs and tests

    def wait_for(self, predicate: Callable[[RobotState], bool], timeout_s: float) -> bool:
        """Block until `predicate(state)` holds or the wall-clock timeout passes."""
        return self.publisher.wait_for(predicate, timeout_s)
