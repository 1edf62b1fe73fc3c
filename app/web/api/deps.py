"""Shared dependencies and the mapping from robot refusals to HTTP errors."""

from __future__ import annotations

from fastapi import Depends, HTTPException, Request

from app.auth.control import VIEWER_REFUSAL, ControlHeld
from app.auth.roles import Principal, Role
from app.runtime import Runtime
from app.web.serialize import reply_json
from robot.interface import CommandReply, Refusal

REFUSAL_STATUS = {
    Refusal.ESTOP_LATCHED: 409,
    Refusal.NOT_LATCHED: 409,
    Refusal.NOTHING_TO_REPLAN: 409,
    Refusal.NOTHING_TO_DO: 409,
    Refusal.BUSY: 409,
    Refusal.UNSUPPORTED: 501,
    Refusal.INVALID: 422,
    Refusal.UNAVAILABLE: 503,
    Refusal.FORBIDDEN: 403,
}


def runtime(request: Request) -> Runtime:
    return request.app.state.runtime


def raise_if_refused(reply: CommandReply) -> None:
    if not reply.accepted:
        assert reply.refusal is not None
        raise HTTPException(status_code=REFUSAL_STATUS[reply.refusal], detail=reply_json(reply))


def principal(request: Request) -> Principal:
    """Who sent the request (identified by the access middleware; the local operator when access control is
    off)."""
    who = getattr(request.state, "principal", None)
    if who is None:
        raise HTTPException(401, detail={"message": "log in first"})
    return who


def require_operator(request: Request) -> Principal:
    """An operator, and the one in control (taking it if nobody has it): 403 for a viewer, 409 while another
    operator has control."""
    who = principal(request)
    if not who.role.allows(Role.OPERATOR):
        raise HTTPException(403, detail={"message": VIEWER_REFUSAL})
    try:
        runtime(request).control.ensure(who)
    except ControlHeld as exc:
        raise HTTPException(409, detail={"message": str(exc), "holder": exc.holder.name}) from exc
    return who


Operator = Depends(require_operator)
