"""The one narrow interface between the robot worker and everything else: commands in, state and events out.

Every type here is a frozen dataclass of plain values, so the worker can later move to its own process and
these cross a pipe unchanged.
"""

from __future__ import annotations

from collections.abc import Iterable
from concurrent.futures import Future
from dataclasses import dataclass, field
from enum import IntEnum, StrEnum
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from robot.telemetry import TelemetryBatch

# ---------------------------------------------------------------------------------------------------------------
# Plans


@dataclass(frozen=True)
class Step:
    """One action of a plan, e.g. Step("navigate_to", {"target": "kitchen counter"})."""

    action: str
    args: dict[str, str]

    def to_dict(self) -> dict[str, Any]:
        return {"action": self.action, "args": dict(self.args)}


@dataclass(frozen=True)
class Plan:
    steps: tuple[Step, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"steps": [s.to_dict() for s in self.steps]}

    def to_seed_list(self) -> list[dict[str, str]]:
        """As the seed's flat list of actions: `[{"action": "pick_object", "object": "red mug"}, ...]`."""
        return [{"action": s.action, **s.args} for s in self.steps]

    @staticmethod
    def from_dict(data: dict[str, Any]) -> Plan:
        """Build a plan from already schema-validated JSON (numbers among the arguments become text)."""
        return Plan(
            tuple(
                Step(s["action"], {k: v if isinstance(v, str) else f"{v:g}" for k, v in s.get("args", {}).items()})
                for s in data["steps"]
            )
        )


class StepState(StrEnum):
    PENDING = "pending"
    RUNNING = "running"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    SKIPPED = "skipped"
    CANCELLED = "cancelled"
    PAUSED = "paused"  # interrupted by a pause: runs again, from the robot's state then, on resume


@dataclass(frozen=True)
class StepStatus:
    index: int
    action: str
    args: dict[str, str]
    state: StepState = StepState.PENDING
    detail: str = ""
    sim_start_s: float | None = None
    sim_end_s: float | None = None


class PlanState(StrEnum):
    AWAITING_APPROVAL = "awaiting_approval"  # planned; runs when the operator approves it
    RUNNING = "running"
    PAUSED = "paused"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELLED = "cancelled"


@dataclass(frozen=True)
class PlanStatus:
    """A plan being or having been executed: which command it serves, which revision, per-step status."""

    plan_id: int
    command_id: int
    command_text: str
    revision: int
    state: PlanState
    steps: tuple[StepStatus, ...]
    replanning: bool = False  # failed, and the executor is planning the command's next revision


# ---------------------------------------------------------------------------------------------------------------
# Commands in


@dataclass(frozen=True)
class RunCommand:
    """A natural-language command: planned, validated, then executed. `alternatives`: other wordings a recogniser
    heard nearly as likely (likeliest first); when `text` cannot be planned, the first that can is, and its plan
    waits for the operator's approval (a question: "did you mean ...?") instead of running."""

    text: str
    alternatives: tuple[str, ...] = ()


@dataclass(frozen=True)
class ExecutePlan:
    """An explicit plan as JSON (e.g. edited by the operator): checked against the schema and the world, then run."""

    plan_json: Any
    text: str = ""
    # A revision of this command (an operator's edit of its plan) instead of a new command; runs without asking
    # for approval, since the operator wrote it.
    command_id: int | None = None


@dataclass(frozen=True)
class EStop:
    """Latch the emergency stop.

    `client_time_s` (Unix time of the press) and `relayed_at_s` (when the web server got it) let the worker
    split the latency it reports into browser-to-server and server-to-control-loop.
    """

    source: str = "api"
    client_time_s: float | None = None
    relayed_at_s: float | None = None
    reason: str = ""  # why, when it was not a person (e.g. the diagnostics' safe stop: "r_knee at 78 C")


@dataclass(frozen=True)
class ReleaseEStop:
    source: str = "api"


@dataclass(frozen=True)
class Replan:
    """Re-run the planner for the current command from the current state."""


@dataclass(frozen=True)
class CancelPlan:
    """Stop executing the current plan, or reject one awaiting approval (not an e-stop: the robot keeps
    balancing)."""


@dataclass(frozen=True)
class ApprovePlan:
    """Run the plan awaiting approval; `plan_id` guards against approving a plan that has since been replaced."""

    plan_id: int | None = None


@dataclass(frozen=True)
class PausePlan:
    """Interrupt the running step and hold still; `ResumePlan` runs that step again from the robot's state then."""


@dataclass(frozen=True)
class ResumePlan:
    """Go on with a paused plan."""


@dataclass(frozen=True)
class SetApproval:
    """Whether new plans (and automatic replans) wait for the operator's approval before they run."""

    required: bool


@dataclass(frozen=True)
class Teleop:
    """Operator velocity in the robot's frame: forward (m/s), left (m/s), counter-clockwise turn (rad/s).

    A deadman command: the robot stops unless another one arrives within the teleop timeout (300 ms). Refused
    while a plan runs (teleop and plan execution are exclusive), after a fall, and under a latched e-stop.
    """

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0
    source: str = "api"


@dataclass(frozen=True)
class StopTeleop:
    """Input ended (keys released, joystick let go, browser gone): decelerate and stop now."""

    source: str = "api"


@dataclass(frozen=True)
class SetTorque:
    """Real robot: turn every servo's torque on (it first holds where it stands) or off. Torque is off at start-up
    until the operator turns it on; it is refused on while the e-stop is latched or a servo is lost."""

    enabled: bool
    source: str = "api"


@dataclass(frozen=True)
class OperatorHeartbeat:
    """The operator is there (a page open, a script alive): the deadman. On the real robot, torque needs one at
    least every `deadman_s` (the page sends one every 250 ms), or it stops as for an e-stop: the controlled-stop
    posture, then torque off. The simulator takes it and has nothing to do."""

    source: str = "browser"


class Posture(StrEnum):
    STAND = "stand"  # the walk-ready stance every walk starts from and ends in
    CROUCH = "crouch"


@dataclass(frozen=True)
class SetPosture:
    posture: Posture


@dataclass(frozen=True)
class PlaceObstacle:
    """Simulation only: drop a 14 x 14 x 30 cm box at (x, y) in the world, e.g. across the robot's path."""

    x: float
    y: float


class Fault(StrEnum):
    """Faults the simulation can be made to have, so that diagnostics and the safe stop can be seen working."""

    SERVO_HEAT = "servo_heat"  # a servo's winding `value` degrees hotter (then it cools as a real one would)
    SERVO_OVERLOAD = "servo_overload"  # a servo's output jammed: its load pinned at `value` % of stall
    IMU_LOST = "imu_lost"  # the IMU stops answering: its readings freeze
    CAMERA_STALE = "camera_stale"  # no more camera frames
    LIDAR_STALE = "lidar_stale"  # no more lidar scans
    CONTROL_STALL = "control_stall"  # the control loop hangs for `value` seconds, once
    BATTERY_SOC = "battery_soc"  # the pack's state of charge set to `value` (0..1)
    SIM_DIVERGE = "sim_diverge"  # the physics blows up (a velocity no simulation survives)
    CONTROL_ERROR = "control_error"  # the control tick raises for `value` ticks, as a controller bug would
    CLEAR = "clear"  # every injected fault removed (a hot servo still has to cool down)


@dataclass(frozen=True)
class InjectFault:
    """Simulation only: give the robot a fault; `target` names the servo (joint) where one is meant."""

    fault: Fault
    target: str = ""
    value: float = 0.0


@dataclass(frozen=True)
class ResetRobot:
    """Simulation only: put the robot back standing at its start pose (after a fall, or to start over)."""


@dataclass(frozen=True)
class StartBehaviour:
    """Start a behaviour (a long-running mission, `robot.behaviours`) by name, with its parameters (by name; values
    as JSON gives them, or as text from a command line: checked against the behaviour's typed parameters)."""

    name: str
    params: dict[str, Any] = field(default_factory=dict)
    source: str = "api"


@dataclass(frozen=True)
class StopBehaviour:
    """End the running (or paused) behaviour: the robot stands where it is, its arm stowed."""

    reason: str = "stopped by the operator"


@dataclass(frozen=True)
class PauseBehaviour:
    """Interrupt the running behaviour and stand still; it goes on from its state on resume."""

    reason: str = "paused by the operator"


@dataclass(frozen=True)
class ResumeBehaviour:
    pass


BehaviourCommand = StartBehaviour | StopBehaviour | PauseBehaviour | ResumeBehaviour


PlanCommand = RunCommand | ExecutePlan | Replan | CancelPlan | ApprovePlan | PausePlan | ResumePlan | SetApproval
MotionCommand = Teleop | StopTeleop | SetPosture | ResetRobot | PlaceObstacle | InjectFault | SetTorque
Command = PlanCommand | MotionCommand | BehaviourCommand | EStop | ReleaseEStop | OperatorHeartbeat


class Refusal(StrEnum):
    """Why a command was not accepted; the web side maps these to HTTP status codes."""

    ESTOP_LATCHED = "estop_latched"  # 409
    INVALID = "invalid"  # 422
    NOTHING_TO_REPLAN = "nothing_to_replan"  # 409
    NOT_LATCHED = "not_latched"  # 409
    NOTHING_TO_DO = "nothing_to_do"  # 409: no plan awaits approval, none is running to pause, none is paused
    BUSY = "busy"  # 409: the robot is doing something else (a plan, teleop, walking)
    UNSUPPORTED = "unsupported"  # 501: not possible with this backend (e.g. reset on hardware)
    UNAVAILABLE = "unavailable"  # 503: the worker does not answer
    FORBIDDEN = "forbidden"  # 403: not for this caller (a viewer; refused by the server, before the robot)


@dataclass(frozen=True)
class CommandReply:
    accepted: bool
    message: str = ""
    refusal: Refusal | None = None
    errors: tuple[str, ...] = ()
    command_id: int | None = None
    plan: Plan | None = None
    clarify: str | None = None  # not planned: two readings were close, and this is the question to ask


# ---------------------------------------------------------------------------------------------------------------
# State and events out


class Mode(StrEnum):
    IDLE = "idle"  # standing, no plan
    EXECUTING = "executing"  # a plan is running
    TELEOP = "teleop"  # an operator drives the robot's velocity
    ESTOP = "estop"  # e-stop latched: controlled stop, holding in place
    FALLEN = "fallen"


class Level(IntEnum):
    """Severity of an event, as ROS diagnostic_msgs/DiagnosticStatus levels."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


@dataclass(frozen=True)
class ControlStats:
    tick_p50_ms: float = 0.0
    tick_p99_ms: float = 0.0
    tick_max_ms: float = 0.0
    ticks: int = 0
    deadline_misses: int = 0
    rtf: float = 0.0
    control_hz: float = 0.0


@dataclass(frozen=True)
class ObjectPose:
    name: str
    position: tuple[float, float, float]


@dataclass(frozen=True)
class Footprint:
    side: str  # "left" | "right"
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class LocomotionState:
    """The walk as the operator sees it: phase, velocities, estimated pose, and what the mirror draws."""

    phase: str  # standing | starting | walking | stopping
    posture: str  # stand | crouch | moving | held (where a stop left a reach: not a stance)
    command: tuple[float, float, float]  # accepted (vx, vy, yaw rate)
    velocity: tuple[float, float, float]  # after acceleration limits
    estimated_pose: tuple[float, float, float]  # leg odometry + IMU heading: x, y, yaw
    footsteps: tuple[Footprint, ...] = ()  # planned ahead, world frame
    com: tuple[float, float, float] | None = None
    zmp: tuple[float, float] | None = None
    support: str = "both"
    estimated_trunk: tuple[float, ...] = ()  # x, y, z, qw, qx, qy, qz: the whole trunk pose the estimate holds
    late_plans: int = 0  # walk plans that came after they were due, since start (a gait planner short of CPU)
    late_plans_s: float = 0.0  # their lateness summed (s)


@dataclass(frozen=True)
class Proprioception:
    """The IMU (as ROS sensor_msgs/Imu, in the trunk frame) and the force pads under each sole (N; front-left,
    front-right, back-left, back-right of each foot): what the balance controller and the leg odometry read."""

    orientation: tuple[float, float, float, float]  # wxyz
    angular_velocity: tuple[float, float, float]  # rad/s
    linear_acceleration: tuple[float, float, float]  # m/s^2
    left_foot_n: tuple[float, ...]
    right_foot_n: tuple[float, ...]


@dataclass(frozen=True)
class DetectedObject:
    """A known object found in a camera frame, with where it is in the world (centre of its base)."""

    label: str
    confidence: float
    position: tuple[float, float, float]
    box: tuple[int, int, int, int]  # pixels x0, y0, x1, y1 in the frame it was found in
    distance_m: float


@dataclass(frozen=True)
class KnownObject:
    """World memory: where an object was last seen, and on which place."""

    name: str
    position: tuple[float, float, float]
    place: str | None
    seen_sim_s: float
    confidence: float


@dataclass(frozen=True)
class PerceptionState:
    """Sensor rates and what perception currently believes; the images, scans and map are in `SensorFeed`."""

    status: str  # "starting" | "ok" | "error: ..."
    camera_hz: float = 0.0
    lidar_hz: float = 0.0
    frame_ms: float = 0.0  # render + detect + encode time of the last frame
    frame_seq: int = 0
    frame_sim_s: float = 0.0
    detections: tuple[DetectedObject, ...] = ()  # in the latest frame
    known_objects: tuple[KnownObject, ...] = ()
    head: tuple[float, float] = (0.0, 0.0)  # commanded pan, tilt (rad)
    map_scans: int = 0
    # scan matching's correction of the leg odometry (x, y, yaw), as ROS's map -> odom transform, and the trunk's
    # pose in the map with it applied: what navigation steers by
    correction: tuple[float, float, float] = (0.0, 0.0, 0.0)
    pose: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class CameraImage:
    seq: int
    sim_time_s: float
    width: int
    height: int
    jpeg: bytes
    detections: tuple[DetectedObject, ...]


@dataclass(frozen=True)
class ScanView:
    """A lidar scan as ROS sensor_msgs/LaserScan, with the estimated sensor pose it was taken from."""

    sim_time_s: float
    pose: tuple[float, float, float]  # x, y, yaw (world)
    height_m: float
    angle_min: float
    angle_increment: float
    range_max: float
    ranges: tuple[float, ...]  # inf where nothing was hit


@dataclass(frozen=True)
class OccupancyMap:
    """As ROS nav_msgs/OccupancyGrid: `data[j * width + i]` is cell (i along x, j along y), 0-100 or -1 unknown;
    cell (0, 0)'s corner is at `origin`."""

    sim_time_s: float
    resolution: float
    origin: tuple[float, float]
    width: int
    height: int
    data: bytes  # int8
    scans: int


@dataclass(frozen=True)
class SensorFeed:
    """The latest heavy sensor products (each updated at its own rate; None until the first one)."""

    camera: CameraImage | None = None
    scan: ScanView | None = None
    map: OccupancyMap | None = None


@dataclass(frozen=True)
class NavigationState:
    """The walk a `navigate_to` step is making: where to, along which path (map frame), how often replanned."""

    goal: tuple[float, float, float]  # x, y, heading
    path: tuple[tuple[float, float], ...]
    replans: int = 0
    phase: str = "following"  # backing away | backing out | following | resting | approaching | arrived


@dataclass(frozen=True)
class PowerState:
    """The battery pack as the robot measures it (simulated: drained by what the servos do)."""

    voltage_v: float
    current_a: float
    soc: float  # state of charge, 0..1
    power_w: float


class BehaviourState(StrEnum):
    QUEUED = "queued"
    RUNNING = "running"
    PAUSED = "paused"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    STOPPED = "stopped"  # by the operator, the e-stop or a newer command

    @property
    def finished(self) -> bool:
        return self in (BehaviourState.SUCCEEDED, BehaviourState.FAILED, BehaviourState.STOPPED)


@dataclass(frozen=True)
class BehaviourParam:
    """One typed parameter of a behaviour: `kind` is "int" | "float" | "str" | "bool" | "list[str]"; `choices`:
    the values a text parameter (or each list item) may take ("places", "objects": the world's names)."""

    name: str
    kind: str
    default: Any
    doc: str = ""
    minimum: float | None = None
    maximum: float | None = None
    choices: str | None = None
    extra: tuple[str, ...] = ()  # values allowed besides the choices


@dataclass(frozen=True)
class BehaviourInfo:
    """A behaviour as the operator picks it: its name, what it does, its parameters and its states."""

    name: str
    description: str
    params: tuple[BehaviourParam, ...] = ()
    states: tuple[str, ...] = ()
    package: str = ""  # the distribution it came from ("" for the built-ins)


@dataclass(frozen=True)
class BehaviourStatus:
    """The behaviour running, paused or last run: its state machine's state, progress and feedback lines."""

    run_id: int
    name: str
    params: dict[str, Any]
    state: BehaviourState
    machine_state: str  # the behaviour's own state (e.g. "searching", "carrying")
    progress: float  # 0..1
    feedback: tuple[str, ...]
    reason: str = ""  # why it ended, when not with success
    command_id: int | None = None  # the command it runs as (its plan is one `behaviour` step)
    started_sim_s: float = 0.0
    ended_sim_s: float | None = None


@dataclass(frozen=True)
class RobotState:
    """An immutable snapshot published by the control loop."""

    sim_time_s: float
    wall_time_s: float
    mode: Mode
    estop_latched: bool
    base_position: tuple[float, float, float]
    base_yaw_rad: float
    tilt_deg: float
    fallen: bool
    qpos: tuple[float, ...]
    objects: tuple[ObjectPose, ...]
    held_object: str | None
    plan: PlanStatus | None
    control: ControlStats
    locomotion: LocomotionState | None = None
    perception: PerceptionState | None = None
    proprioception: Proprioception | None = None
    mocap_positions: tuple[float, ...] = ()  # kinematic bodies of the scene (x, y, z each), beside qpos
    navigation: NavigationState | None = None
    approval_required: bool = False  # plans wait for the operator's approval before they run
    power: PowerState | None = None
    torque_enabled: bool | None = None  # the real robot's servos (None in simulation, where they are always on)
    behaviour: BehaviourStatus | None = None  # the behaviour running, paused or last run


_SEVERITY = {Level.OK: 0, Level.WARN: 1, Level.STALE: 2, Level.ERROR: 3}


def worst_level(levels: Iterable[Level]) -> Level:
    """The worst of some levels (STALE counts as worse than WARN, below ERROR: the data is missing, not bad)."""
    return max(levels, key=_SEVERITY.__getitem__, default=Level.OK)


@dataclass(frozen=True)
class DiagnosticStatus:
    """One component's health, as ROS diagnostic_msgs/DiagnosticStatus. `name` is "group/component" (e.g.
    "servos/r_knee"); `values` are its key-values, numbers where they are measurements (units in the key)."""

    name: str
    level: Level
    message: str
    hardware_id: str = ""
    values: tuple[tuple[str, float | str], ...] = ()
    stops_motion: bool = False  # at ERROR, the robot may not move: the diagnostics stop it

    @property
    def group(self) -> str:
        return self.name.split("/", 1)[0]


@dataclass(frozen=True)
class DiagnosticArray:
    """Every component's status at one instant (as ROS diagnostic_msgs/DiagnosticArray), sampled at ~1 Hz."""

    wall_time_s: float
    sim_time_s: float
    statuses: tuple[DiagnosticStatus, ...]
    monitor_cpu_ms: float = 0.0  # CPU time the last sample cost the monitor

    @property
    def level(self) -> Level:
        return worst_level(s.level for s in self.statuses)

    def find(self, name: str) -> DiagnosticStatus | None:
        return next((s for s in self.statuses if s.name == name), None)


@dataclass(frozen=True)
class Event:
    """Something that happened, in order (`seq`), with a topic-like kind such as "estop/latched"."""

    seq: int
    kind: str
    message: str
    level: Level = Level.OK
    wall_time_s: float = 0.0
    sim_time_s: float = 0.0
    data: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class RobotDescription:
    """What a viewer needs to draw the robot and its world, and what a planner may talk about."""

    model_name: str
    seed: int
    mjcf_xml: str  # the compiled scene as MJCF; mesh files are referenced by absolute path
    joint_names: tuple[str, ...]
    places: tuple[str, ...]
    objects: tuple[str, ...]
    control_hz: float
    physics_hz: float
    planner: str = "rules"  # which planner plans, and with which model: shown to the operator
    microphone: str = ""  # the robot's microphone, or why it has none ("" when voice is not set up)
    speaker: str = ""
    telemetry_layout: dict[str, Any] = field(default_factory=dict)  # robot.telemetry.TelemetryLayout.to_json()
    telemetry_hz: float = 0.0
    behaviours: tuple[BehaviourInfo, ...] = ()  # what `StartBehaviour` can start


class EventSubscription(Protocol):
    def get(self, timeout: float | None = None) -> Event | None: ...

    def close(self) -> None: ...


class RobotPort(Protocol):
    """What `app/` may call on the robot side. Nothing else crosses the boundary.

    Implemented in-process by `robot.robot.Robot` on a body (built as `robot.worker.RobotWorker` for the
    simulation, `robot.hardware.worker.HardwareWorker` for the real robot) and across a process boundary by
    `robot.process.WorkerProcess`.
    """

    def start(self) -> None: ...

    def stop(self) -> None: ...

    def is_alive(self) -> bool: ...

    def submit(self, command: Command) -> CommandReply:
        """Blocks until the robot answers (planning may take long): for threads, never for an event loop."""
        ...

    def submit_async(self, command: Command) -> Future[CommandReply]:
        """Sends and returns at once; the reply comes in the future (what the web server's event loop uses)."""
        ...

    @property
    def pid(self) -> int | None:
        """The robot's process (None while it is not running)."""
        ...

    def silent_for_s(self) -> float:
        """How long a running robot has not answered (0 while it answers): a frozen robot process, not a dead one."""
        ...

    def state(self) -> RobotState: ...

    def announce(self, kind: str, message: str, level: Level = Level.OK, **data: Any) -> Event:
        """An event from the server about the robot (a refused 3D-view click, the process restarted), said to
        every subscriber like the robot's own."""
        ...

    def subscribe(self) -> EventSubscription: ...

    def recent_events(self) -> list[Event]: ...

    def describe(self) -> RobotDescription: ...

    def sensor_feed(self) -> SensorFeed: ...

    def telemetry_since(self, seq: int) -> TelemetryBatch | None:
        """Telemetry rows numbered `seq` and later (see robot.telemetry), for recording."""
        ...

    def diagnostics(self) -> DiagnosticArray | None:
        """The robot's latest diagnostics (None before the first sample)."""
        ...
