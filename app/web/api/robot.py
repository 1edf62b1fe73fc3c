"""Commands, plans, e-stop and state of the robot."""

from __future__ import annotations

import asyncio
import dataclasses
import time
from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException, Request, Response
from pydantic import BaseModel, ConfigDict, Field

from app.diagnostics import robot_health
from app.runtime import Runtime
from app.web.api.deps import Operator, raise_if_refused, runtime
from app.web.robot_calls import IMMEDIATE_TIMEOUT_S, PLANNING_TIMEOUT_S, ask, shown
from app.web.serialize import event_json, reply_json, state_json
from robot.interface import (
    ApprovePlan,
    CancelPlan,
    Command,
    EStop,
    ExecutePlan,
    OperatorHeartbeat,
    PausePlan,
    PlaceObstacle,
    Posture,
    ReleaseEStop,
    Replan,
    ResetRobot,
    ResumePlan,
    RunCommand,
    SetApproval,
    SetPosture,
    SetTorque,
    StopTeleop,
    Teleop,
)
from robot.speech.asr import ALTERNATIVES_KEPT
from robot.worker import MAX_COMMAND_CHARS

router = APIRouter(prefix="/api", tags=["robot"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]


async def _accepted(rt: Runtime, command: Command, timeout_s: float = IMMEDIATE_TIMEOUT_S) -> dict[str, Any]:
    """Submit a command; its reply as JSON, or the HTTP error its refusal maps to."""
    reply = await ask(rt.worker, command, timeout_s)
    raise_if_refused(reply)
    return reply_json(reply)


class CommandIn(BaseModel):
    """A typed command, or an explicit plan (checked against the plan schema and the world): ours,
    `{"steps": [{"action": ..., "args": {...}}]}`, or the seed's list of flat actions. With `command_id`, the plan
    is the operator's edit of that command's plan (its next revision), and runs without asking for approval."""

    model_config = ConfigDict(extra="forbid")
    text: str = Field("", max_length=MAX_COMMAND_CHARS, examples=["pick up the red mug from the kitchen counter"])
    plan: dict[str, Any] | list[Any] | None = Field(
        None, examples=[{"steps": [{"action": "say", "args": {"text": "hello"}}]}]
    )
    command_id: int | None = Field(None, ge=1, description="revise this command's plan (with `plan`)")
    source: str = Field("api", max_length=16, pattern=r"^[a-z_]+$")
    alternatives: list[Annotated[str, Field(max_length=MAX_COMMAND_CHARS)]] = Field(
        default_factory=list,
        max_length=ALTERNATIVES_KEPT,
        description="other wordings the recogniser heard (`/api/speech/transcribe`'s `alternatives`): when `text` "
        "cannot be planned, the first that can is, and its plan awaits approval",
    )


class ApproveIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    plan_id: int | None = Field(None, ge=1, description="the plan being approved (refused if another awaits)")


class ApprovalIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    required: bool


class EStopIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    source: str = Field("api", max_length=16, pattern=r"^[a-z_-]+$")
    client_time_s: float | None = Field(
        None, allow_inf_nan=False, description="Unix time of the press, for latency measurement"
    )


# Beyond these a velocity is a mistake, not a wish to walk fast: refused (below them, clipped to the walking limits).
TELEOP_MAX_SPEED_M_S = 1.0
TELEOP_MAX_YAW_RATE = 3.0


class TeleopIn(BaseModel):
    """Velocity in the robot's frame. A deadman: repeat it at least every 300 ms, or the robot stops."""

    model_config = ConfigDict(extra="forbid")
    vx: float = Field(
        0.0,
        allow_inf_nan=False,
        ge=-TELEOP_MAX_SPEED_M_S,
        le=TELEOP_MAX_SPEED_M_S,
        description="forward, m/s (clipped to the walking limits; beyond 1 m/s refused)",
    )
    vy: float = Field(
        0.0, allow_inf_nan=False, ge=-TELEOP_MAX_SPEED_M_S, le=TELEOP_MAX_SPEED_M_S, description="to the left, m/s"
    )
    yaw_rate: float = Field(
        0.0,
        allow_inf_nan=False,
        ge=-TELEOP_MAX_YAW_RATE,
        le=TELEOP_MAX_YAW_RATE,
        description="counter-clockwise, rad/s (beyond 3 rad/s refused)",
    )
    source: str = Field("api", max_length=16, pattern=r"^[a-z_-]+$")


class PostureIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    posture: Posture


@router.get("/health")
async def health(rt: RuntimeDep, request: Request, response: Response) -> dict[str, Any]:
    """200 while the robot worker runs and answers; 503 with the status and the reason when it does not:
    "worker_down" (not running: the robot is not driven) or "worker_not_answering" (frozen: noticed within a
    second; the supervisor restarts it after a grace period). `relay_priority`: how the event loop, the
    e-stop's relay, is scheduled."""
    state = rt.worker.state()
    status, reason = robot_health(rt)
    if status != "ok":
        response.status_code = 503
    return {
        "status": status,
        "reason": reason,
        "robot_pid": rt.worker.pid,
        "mode": state.mode.value,
        "estop_latched": state.estop_latched,
        "sim_time_s": state.sim_time_s,
        "control": state_json(state)["control"],
        "session_id": rt.recorder.session_id,
        "mirrors": {name: {"port": rt.scene_port(name), "updates": m.updates} for name, m in rt.mirrors.items()},
        "relay_priority": getattr(request.app.state, "relay_priority", "unknown"),
    }


@router.get("/config")
def config(rt: RuntimeDep) -> dict[str, Any]:
    """What this server runs: the 3D views' ports, the seed, the robot, its places and objects, control and
    physics rates, the planner, the robot's microphone and speaker, whether plans wait for approval, the session
    being recorded and the diagnostics thresholds."""
    description = rt.worker.describe()
    return {
        "viser_ports": {name: rt.scene_port(name) for name in rt.mirrors},
        "replay_port": rt.scene_port("replay"),
        "mirror_software_dpr": rt.settings.mirror_software_dpr,
        "seed": description.seed,
        "robot": description.model_name,
        "places": list(description.places),
        "objects": list(description.objects),
        "control_hz": description.control_hz,
        "physics_hz": description.physics_hz,
        "planner": description.planner,
        "planner_backend": rt.settings.planner_backend,
        "microphone": description.microphone,
        "speaker": description.speaker,
        "spoken_stop": rt.settings.spoken_stop,
        "approval_required": rt.worker.state().approval_required,
        "session_id": rt.recorder.session_id,
        "diagnostics_thresholds": dataclasses.asdict(rt.settings.diagnostics),
    }


@router.get("/state")
def state(rt: RuntimeDep, qpos: bool = False) -> dict[str, Any]:
    """The robot's latest state (what the page's WebSocket pushes 20 times a second); `qpos=true` adds the whole
    scene's joint positions."""
    return state_json(rt.worker.state(), include_qpos=qpos)


@router.get("/events")
def events(rt: RuntimeDep) -> list[dict[str, Any]]:
    """The most recent events (e-stops, plans, steps, alarms, refusals), oldest first."""
    return [event_json(e) for e in rt.worker.recent_events()]


@router.post("/commands", status_code=202, dependencies=[Operator])
async def post_command(body: CommandIn, rt: RuntimeDep) -> dict[str, Any]:
    """Plan (or check the given plan) and start executing it. 422: not understood or invalid; 409: e-stop."""
    received = time.time()  # (recorded as when it came, before the plan made of it)
    if body.plan is not None:
        command: Command = ExecutePlan(body.plan, body.text, command_id=body.command_id)
    elif body.command_id is not None:
        raise HTTPException(422, detail={"message": "command_id revises a plan: send the edited plan with it"})
    else:
        command = RunCommand(body.text, tuple(body.alternatives))
    reply = await ask(rt.worker, command, PLANNING_TIMEOUT_S)
    await asyncio.to_thread(rt.recorder.record_command, body.text or "(plan)", body.source, reply, received)
    raise_if_refused(reply)
    return reply_json(reply)


@router.post("/replan", status_code=202, dependencies=[Operator])
async def replan(rt: RuntimeDep) -> dict[str, Any]:
    """Re-run the planner for the current command from the current state."""
    return await _accepted(rt, Replan(), PLANNING_TIMEOUT_S)


@router.post("/plan/cancel", dependencies=[Operator])
async def cancel_plan(rt: RuntimeDep) -> dict[str, Any]:
    """Stop the running plan, or reject the one awaiting approval; the robot stands where it is."""
    return reply_json(await ask(rt.worker, CancelPlan()))


@router.post("/plan/approve", dependencies=[Operator])
async def approve_plan(rt: RuntimeDep, body: ApproveIn | None = None) -> dict[str, Any]:
    """Run the plan awaiting approval. 409 when none awaits; 422 when `plan_id` is not the one that does."""
    return await _accepted(rt, ApprovePlan((body or ApproveIn()).plan_id))


@router.post("/plan/pause", dependencies=[Operator])
async def pause_plan(rt: RuntimeDep) -> dict[str, Any]:
    """Interrupt the running step and stand still; 409 when no plan runs."""
    return await _accepted(rt, PausePlan())


@router.post("/plan/resume", dependencies=[Operator])
async def resume_plan(rt: RuntimeDep) -> dict[str, Any]:
    """Run the paused step again (from the robot's state now) and go on; 409 when no plan is paused."""
    return await _accepted(rt, ResumePlan())


@router.put("/plan/approval", dependencies=[Operator])
async def set_approval(body: ApprovalIn, rt: RuntimeDep) -> dict[str, Any]:
    """Whether plans (automatic replans too) wait for the operator's approval before they run. Answered once the
    robot's state says so: a page or script that reads the state next sees its change."""
    reply = await ask(rt.worker, SetApproval(body.required))
    if reply.accepted:
        await shown(rt.worker, lambda state: state.approval_required == body.required)
    return reply_json(reply)


@router.post("/estop")
async def estop(rt: RuntimeDep, body: EStopIn | None = None) -> dict[str, Any]:
    """Latch the e-stop: cancel the plan and hold position. Idempotent."""
    relayed = time.time()
    body = body or EStopIn()
    command = EStop(source=body.source, client_time_s=body.client_time_s, relayed_at_s=relayed)
    return reply_json(await ask(rt.worker, command))


@router.post("/estop/reset", dependencies=[Operator])
async def estop_reset(rt: RuntimeDep) -> dict[str, Any]:
    """Release a latched e-stop. Never restarts motion: a new command or a replan does."""
    return await _accepted(rt, ReleaseEStop(source="api"))


@router.post("/teleop", dependencies=[Operator])
async def teleop(body: TeleopIn, rt: RuntimeDep) -> dict[str, Any]:
    """Drive the robot's velocity (409 while a plan runs, after a fall or under e-stop)."""
    return await _accepted(rt, Teleop(body.vx, body.vy, body.yaw_rate, body.source))


@router.post("/teleop/stop")
async def teleop_stop(rt: RuntimeDep) -> dict[str, Any]:
    """Input ended: decelerate and stop."""
    return reply_json(await ask(rt.worker, StopTeleop(source="api")))


@router.post("/posture", dependencies=[Operator])
async def posture(body: PostureIn, rt: RuntimeDep) -> dict[str, Any]:
    """Stand (the walk-ready stance) or crouch; 409 while walking, running a plan, or under e-stop."""
    return await _accepted(rt, SetPosture(body.posture))


class ObstacleIn(BaseModel):
    """Where to drop a 14 x 14 x 30 cm box (world frame, m)."""

    model_config = ConfigDict(extra="forbid")
    x: float = Field(..., allow_inf_nan=False, ge=-50, le=50)
    y: float = Field(..., allow_inf_nan=False, ge=-50, le=50)


@router.post("/sim/obstacles", status_code=202, dependencies=[Operator])
async def place_obstacle(body: ObstacleIn, rt: RuntimeDep) -> dict[str, Any]:
    """Simulation: drop an obstacle into the world (e.g. across the robot's path, to see it replan)."""
    return await _accepted(rt, PlaceObstacle(body.x, body.y))


class TorqueIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    enabled: bool


@router.post("/torque", dependencies=[Operator])
async def torque(body: TorqueIn, rt: RuntimeDep) -> dict[str, Any]:
    """Real robot: every servo's torque on (it first holds where it stands) or off; 501 in simulation, 409 while
    the e-stop is latched."""
    return await _accepted(rt, SetTorque(body.enabled, source="api"))


@router.post("/heartbeat", dependencies=[Operator])
async def heartbeat(rt: RuntimeDep) -> dict[str, Any]:
    """The operator deadman for scripts (the page sends its own over the WebSocket): on the real robot, torque
    stays on only while a heartbeat comes at least every `HUMANOID_DEADMAN_S` (1.5 s)."""
    return await _accepted(rt, OperatorHeartbeat(source="api"))


@router.post("/reset", dependencies=[Operator])
async def reset(rt: RuntimeDep) -> dict[str, Any]:
    """Simulation: put the robot back standing at its start pose (after a fall); 501 on hardware."""
    return await _accepted(rt, ResetRobot())
