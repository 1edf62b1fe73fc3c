"""Diagnostics: the robot's and the server's health as JSON, as Prometheus metrics, and (in simulation) faults to
inject so that operators and tests can see the alarms and the safe stop work."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Response
from pydantic import BaseModel, ConfigDict, Field

from app.diagnostics import diagnostics_json, prometheus_text, snapshot
from app.runtime import Runtime
from app.web.api.deps import Operator, raise_if_refused, runtime
from app.web.robot_calls import ask
from app.web.serialize import reply_json
from robot.interface import Fault, InjectFault

router = APIRouter(tags=["diagnostics"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]


@router.get("/api/diagnostics")
def diagnostics(rt: RuntimeDep) -> dict[str, Any]:
    """Every component's status (OK / WARN / ERROR / STALE, as ROS DiagnosticStatus levels 0-3) with its key-values,
    grouped (compute, control, servos, sensors, power, links), and the alarms (everything not OK)."""
    return diagnostics_json(snapshot(rt))


@router.get("/metrics", response_class=Response)
def metrics(rt: RuntimeDep) -> Response:
    """Prometheus text exposition: `humanoid_diagnostic_level{name,group}` and a gauge per numeric value."""
    return Response(prometheus_text(snapshot(rt)), media_type="text/plain; version=0.0.4; charset=utf-8")


class FaultIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    fault: Fault
    target: str = Field("", max_length=32, pattern=r"^[a-z_]*$", description="the servo (joint name) for servo faults")
    value: float = Field(0.0, allow_inf_nan=False, ge=-200, le=200)


@router.post("/api/sim/faults", dependencies=[Operator])
async def inject_fault(body: FaultIn, rt: RuntimeDep) -> dict[str, Any]:
    """Simulation: give the robot a fault (a servo overheating or jammed, the IMU lost, a sensor silent, the control
    loop hanging, a flat battery) or clear them all; 501 on hardware, 422 for an unknown servo."""
    reply = await ask(rt.worker, InjectFault(body.fault, body.target, body.value))
    raise_if_refused(reply)
    return reply_json(reply)
