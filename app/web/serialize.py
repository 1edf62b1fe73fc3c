"""Robot-side dataclasses to JSON-ready dicts for the API and the WebSocket."""

from __future__ import annotations

import dataclasses
from typing import Any

from robot.interface import BehaviourInfo, BehaviourStatus, CommandReply, Event, PlanStatus, RobotState


def plan_status_json(plan: PlanStatus | None) -> dict[str, Any] | None:
    return dataclasses.asdict(plan) if plan is not None else None


def behaviour_status_json(status: BehaviourStatus | None) -> dict[str, Any] | None:
    return dataclasses.asdict(status) if status is not None else None


def behaviour_info_json(info: BehaviourInfo) -> dict[str, Any]:
    """A behaviour as listed (the CLI's `behaviours list`, the API, the page's panel)."""
    return {
        "name": info.name,
        "description": info.description,
        "states": list(info.states),
        "package": info.package,
        "params": [dataclasses.asdict(p) | {"extra": list(p.extra)} for p in info.params],
    }


def state_json(state: RobotState, include_qpos: bool = False) -> dict[str, Any]:
    x, y, z = state.base_position
    out: dict[str, Any] = {
        "sim_time_s": state.sim_time_s,
        "wall_time_s": state.wall_time_s,
        "mode": state.mode.value,
        "estop_latched": state.estop_latched,
        "pose": {"x": x, "y": y, "z": z, "yaw_rad": state.base_yaw_rad},
        "tilt_deg": state.tilt_deg,
        "fallen": state.fallen,
        "held_object": state.held_object,
        "objects": {o.name: list(o.position) for o in state.objects},
        "plan": plan_status_json(state.plan),
        "control": dataclasses.asdict(state.control),
        "locomotion": dataclasses.asdict(state.locomotion) if state.locomotion is not None else None,
        "perception": dataclasses.asdict(state.perception) if state.perception is not None else None,
        "proprioception": dataclasses.asdict(state.proprioception) if state.proprioception is not None else None,
        "navigation": dataclasses.asdict(state.navigation) if state.navigation is not None else None,
        "approval_required": state.approval_required,
        "torque_enabled": state.torque_enabled,
        "behaviour": behaviour_status_json(state.behaviour),
    }
    if include_qpos:
        out["qpos"] = list(state.qpos)
    return out


def event_json(event: Event) -> dict[str, Any]:
    return {
        "seq": event.seq,
        "kind": event.kind,
        "message": event.message,
        "level": int(event.level),
        "wall_time_s": event.wall_time_s,
        "sim_time_s": event.sim_time_s,
        "data": event.data,
    }


def reply_json(reply: CommandReply) -> dict[str, Any]:
    return {
        "accepted": reply.accepted,
        "message": reply.message,
        "refusal": reply.refusal.value if reply.refusal else None,
        "errors": list(reply.errors),
        "command_id": reply.command_id,
        "plan": reply.plan.to_dict() if reply.plan else None,
        "clarify": reply.clarify,
    }
