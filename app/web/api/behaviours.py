"""Behaviours: list them, start one with parameters, pause, resume, stop, and the one running (or last run)."""

from __future__ import annotations

import asyncio
import time
from typing import Annotated, Any

from fastapi import APIRouter, Depends
from pydantic import BaseModel, ConfigDict, Field

from app.runtime import Runtime
from app.web.api.deps import Operator, raise_if_refused, runtime
from app.web.robot_calls import ask
from app.web.serialize import behaviour_info_json, behaviour_status_json, reply_json
from robot.interface import Command, PauseBehaviour, ResumeBehaviour, StartBehaviour, StopBehaviour

router = APIRouter(prefix="/api/behaviours", tags=["behaviours"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]


class StartIn(BaseModel):
    """The behaviour's parameters by name (see `GET /api/behaviours`); left out, a parameter takes its default."""

    model_config = ConfigDict(extra="forbid")
    params: dict[str, Any] = Field(default_factory=dict, examples=[{"laps": 2, "waypoints": ["charging dock"]}])
    source: str = Field("api", max_length=16, pattern=r"^[a-z_]+$")


async def _accepted(rt: Runtime, command: Command) -> dict[str, Any]:
    reply = await ask(rt.worker, command)
    raise_if_refused(reply)
    return reply_json(reply) | {"behaviour": behaviour_status_json(rt.worker.state().behaviour)}


@router.get("")
def list_behaviours(rt: RuntimeDep) -> dict[str, Any]:
    """Every behaviour the robot can run (name, description, typed parameters with defaults, states), and the one
    running, paused or last run."""
    return {
        "behaviours": [behaviour_info_json(info) for info in rt.worker.describe().behaviours],
        "status": behaviour_status_json(rt.worker.state().behaviour),
    }


@router.get("/status")
def status(rt: RuntimeDep) -> dict[str, Any] | None:
    """The behaviour running, paused or last run: its state, state machine state, progress and feedback lines."""
    return behaviour_status_json(rt.worker.state().behaviour)


@router.post("/{name}/start", status_code=202, dependencies=[Operator])
async def start(name: str, rt: RuntimeDep, body: StartIn | None = None) -> dict[str, Any]:
    """Start behaviour `name`. 422 for an unknown behaviour or a bad parameter (the error names it); 409 while a
    plan, teleop or another behaviour runs, or under e-stop."""
    body = body or StartIn()
    received = time.time()
    reply = await ask(rt.worker, StartBehaviour(name, body.params, body.source))
    text = f"behaviour {name}" + "".join(f" {k}={v}" for k, v in body.params.items())
    await asyncio.to_thread(rt.recorder.record_command, text, body.source, reply, received)
    raise_if_refused(reply)
    return reply_json(reply) | {"behaviour": behaviour_status_json(rt.worker.state().behaviour)}


@router.post("/pause", dependencies=[Operator])
async def pause(rt: RuntimeDep) -> dict[str, Any]:
    """Interrupt the running behaviour and stand still; it keeps its state. 409 when none runs."""
    return await _accepted(rt, PauseBehaviour())


@router.post("/resume", dependencies=[Operator])
async def resume(rt: RuntimeDep) -> dict[str, Any]:
    """Go on from the paused behaviour's state. 409 when none is paused."""
    return await _accepted(rt, ResumeBehaviour())


@router.post("/stop", dependencies=[Operator])
async def stop(rt: RuntimeDep) -> dict[str, Any]:
    """End the running or paused behaviour: the robot stands where it is, its arm stowed. 409 when none runs."""
    return await _accepted(rt, StopBehaviour())
